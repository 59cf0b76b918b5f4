#!/usr/bin/env python3
"""Checks that a heuristic and a law are each declared in their own files and registered by one
line, so that adding one touches only its files, its tests and that line; and that integrator
options are read and written through their table's rows alone.

For each rule of QBOND_HEURISTICS (include/qbond/heuristics/registry.hpp): its factory
make_heuristic(Rule) is declared in a header of include/qbond/heuristics/, and its factory and
its scene types (scene_readers(std::type_identity<Rule>)) are defined in one source file of
src/heuristics/. Outside those files and the registry, no file of the library, the programs or
the Python module names the rule, except the consumers listed below, which use a rule for their
own purpose (drawing, diagnostics), not to make it work. A rule declared outside
include/qbond/heuristics/ (Obstacle and QuantaContactRule: also the model's, for contacts inside
the step) is checked for its factory and scene types only.

For each law of QBOND_LAWS (include/qbond/laws/registry.hpp): no file outside its header and the
registry names its type or its enum value, except the consumers listed below.

Prints, per rule and law, the files that name it. Usage: check_registration.py ROOT
"""
import pathlib
import re
import sys

# Files that use a registered rule for their own purpose: the `liquid` scene type makes a break
# rule beside its form rule, and the Python module offers it as a method; the gas builder's doc
# names the contact its quanta need; the viewer draws quanta at the contact radius. A run over MPI
# ranks tests the break rule on the bonds each rank owns and draws in the whole world's order
# (its criteria apart from the heuristic's draws, in break_criteria.hpp).
CONSUMERS = {
    "BreakRule": {"src/heuristics/formation.cpp", "python/simulation.cpp", "src/heuristics/break_criteria.hpp",
                  "src/distributed/distributed_run.cpp", "src/distributed/distributed_step.cpp",
                  "src/distributed/distributed_step.hpp"},
    "QuantaContactRule": {"include/qbond/builders/gas.hpp", "apps/viewer/viewer_draw.cpp"},
}
# Files that use a law for their own purpose: the linear law is the default bond's and has the
# kernels' fast paths; a checkpoint of the older format stores the inverse law's ε apart.
LAW_CONSUMERS = {
    "LinearLaw": {"include/qbond/io/checkpoint.hpp", "include/qbond/model/bonds.hpp", "include/qbond/model/world.hpp",
                  "src/integrators/affine_run_terms.hpp", "src/integrators/hybrid_frozen_kernel.cpp",
                  "src/ledger/energy_sums.cpp"},
    "InverseLaw": {"src/io/checkpoint.cpp"},
}
# Files that name an integrator option for another purpose: the scene reader checks the values of
# `solver` and `warm_start` an integrator takes; the diagnostics write the solver's own iteration
# count.
OPTION_CONSUMERS = {
    "solver": {"src/io/scene/builder.cpp"},
    "warm_start": {"src/io/scene/builder.cpp"},
    "iterations": {"src/io/diagnostics.cpp"},
}
SCANNED = ("src", "include", "apps", "python", "fuzz")


def sources(root):
    for top in SCANNED:
        for p in sorted((root / top).rglob("*")):
            if p.suffix in (".hpp", ".cpp", ".h", ".cc") and p.is_file():
                yield p.relative_to(root).as_posix(), p.read_text(encoding="utf-8", errors="replace")


def macro_list(text, name):
    m = re.search(r"#define " + name + r"\(X\)((?:[^\n]*\\\n)*[^\n]*)", text)
    if not m:
        raise SystemExit(f"no #define {name}(X)")
    return re.findall(r"X\(([^)]*)\)", m.group(1))


def main():
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else ".").resolve()
    files = dict(sources(root))
    failures = []

    registry = "include/qbond/heuristics/registry.hpp"
    rules = [r.strip() for r in macro_list(files[registry], "QBOND_HEURISTICS")]
    for rule in rules:
        word = re.compile(r"\b" + rule + r"\b")
        naming = {f for f, t in files.items() if word.search(t)}
        declared = {f for f, t in files.items() if re.search(r"\bstruct " + rule + r"\s*\{", t)}
        factory_decl = {f for f, t in files.items() if f.startswith("include/")
                        and re.search(r"make_heuristic\((?:const )?" + rule + r"\b", t)}
        readers = {f for f, t in files.items()
                   if re.search(r"scene_readers\(std::type_identity<" + rule + r">\)\s*\{", t)}
        factory_def = {f for f, t in files.items() if f.startswith("src/")
                       and re.search(r"make_heuristic\((?:const )?" + rule + r"\b[^;]*\{", t)}
        if len(factory_decl) != 1 or not next(iter(factory_decl)).startswith("include/qbond/heuristics/"):
            failures.append(f"{rule}: make_heuristic({rule}) declared in {sorted(factory_decl)}, "
                            "not in one header of include/qbond/heuristics/")
        if len(readers) != 1 or readers != factory_def or not next(iter(readers)).startswith("src/heuristics/"):
            failures.append(f"{rule}: scene types in {sorted(readers)} and factory in {sorted(factory_def)}, "
                            "not both in one source of src/heuristics/")
        own = declared | factory_decl | readers | {registry}
        others = naming - own
        if all(d.startswith("include/qbond/heuristics/") for d in declared):
            extra = others - CONSUMERS.get(rule, set())
            if extra:
                failures.append(f"{rule}: also named in {sorted(extra)}: a heuristic is its own files "
                                "and one line of QBOND_HEURISTICS")
            print(f"heuristic {rule}: {len(own)} files {sorted(own)}"
                  + (f"; consumers {sorted(others)}" if others else ""))
        else:
            print(f"heuristic {rule}: factory and scene types in {sorted(factory_decl | readers)} "
                  f"(a type of {sorted(declared)}, used by {len(others)} other files)")

    law_registry = "include/qbond/laws/registry.hpp"
    for entry in macro_list(files[law_registry], "QBOND_LAWS"):
        law_id, law_type = (s.strip() for s in entry.split(","))
        word = re.compile(r"\b" + law_type + r"\b|\bLaw::" + law_id + r"\b")
        naming = {f for f, t in files.items() if word.search(t)}
        header = {f for f, t in files.items() if re.search(r"\bstruct " + law_type + r"\s*\{", t)}
        others = naming - header - {law_registry}
        extra = others - LAW_CONSUMERS.get(law_type, set())
        if len(header) != 1 or extra:
            failures.append(f"law {law_type}: declared in {sorted(header)}, also named in {sorted(extra)}")
        own = header | {law_registry}
        print(f"law {law_type}: {len(own)} files {sorted(own)}" + (f"; consumers {sorted(others)}" if others else ""))

    # Integrator options: the scene reader, the resolved scene, the JSON Schema and the Python
    # module go through each option's row of integrator_options() (src/integrators/integrators.cpp).
    table = files["src/integrators/integrators.cpp"]
    options = re.findall(r'\.key = "([a-z_]+)"', table[table.index("kOptions[]"):])
    generic = [f for f in files if f.startswith("src/io/") or (f.startswith("python/") and f.endswith(".cpp"))]
    for key in options:
        pattern = re.compile(r'"' + key + r'"|\.' + key + r"\b")
        naming = {f for f in generic if pattern.search(files[f])} - OPTION_CONSUMERS.get(key, set())
        if naming:
            failures.append(f"integrator option {key}: also read or written in {sorted(naming)}")
    print(f"integrator options: {len(options)} rows, none named by the scene reader, the resolved scene, "
          "the JSON Schema or the Python module")

    for f in failures:
        print("FAIL:", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
