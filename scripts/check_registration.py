#!/usr/bin/env python3
"""Checks that a new law, integrator, integrator option or heuristic touches three files: its own file, its
tests, and its registration; and that the existing ones keep to their files. The docs' key tables
and the JSON Schema are generated from the same declarations (`qbond key-tables`, `qbond schema`).

Heuristics, QBOND_HEURISTICS (include/qbond/heuristics/registry.hpp): a rule is either whole in
its header of include/qbond/heuristics/ (the struct, make_heuristic(Rule) defined there, and its
scene type: `from_scene`), so that it is that header, its tests and the registry; or its factory
is declared in that header and defined, with its scene types (scene_readers(std::type_identity<
Rule>)), in one source of src/heuristics/, one file more: its struct is public (HeuristicSpec,
the Python module) and the helpers its step needs (the spatial hash) are not. No other file of the library, the
programs or the Python module names the rule, except the consumers listed below, which use a rule
for their own purpose (drawing, diagnostics), not to make it work. A rule declared outside
include/qbond/heuristics/ (Obstacle and QuantaContactRule: also the model's, for contacts inside
the step) is checked for its factory and scene types only.

Laws, QBOND_LAWS (include/qbond/laws/registry.hpp): no file outside its header and the registry
names its type or its enum value, except the consumers listed below.

Integrator options, kIntegratorOptions (include/qbond/integrators/integrators.hpp): each row sits
in the header that declares its field of IntegratorConfig and says which integrators read it, so
that an option is that header (its field and its row), the code that reads it (src/integrators/)
and its tests. Outside the header no file names the option (IntegratorOption::key), except the
consumers listed below; the scene reader, the resolved scene, the JSON Schema and the Python
module never name its key or its field.

Integrators, QBOND_INTEGRATORS (include/qbond/integrators/integrators.hpp): each one's row
(`const IntegratorInfo NAME_integrator`) is defined in one file of src/integrators/, so that an
integrator is that file, its tests and its line of the list (the options it reads name it in
their read_by, in the same header).

Prints, per item, the files that name it (tests included). Usage: check_registration.py ROOT
"""
import pathlib
import re
import sys

# Files that use a registered rule for their own purpose: the `liquid` scene type makes a break
# rule beside its form rule, and the Python module offers it as a method; the gas builder's doc
# names the contact its quanta need; the viewer draws quanta at the contact radius. A run over MPI
# ranks tests the break rule on the bonds each rank owns and draws in the whole world's order
# (its criteria apart from the heuristic's draws, in break_criteria.hpp), flows them with the
# plastic rule's flow (apart from its ductile breaks, in plastic_flow.hpp), forms the whole world's
# bonds on every rank with the form rule's pass (apart from its heuristic, in formation_pass.hpp),
# and takes damping zones, like obstacles, as projection rules of each piece.
CONSUMERS = {
    "BreakRule": {"src/heuristics/formation.cpp", "python/simulation.cpp", "src/heuristics/break_criteria.hpp",
                  "src/distributed/distributed_run.cpp", "src/distributed/distributed_step.cpp",
                  "src/distributed/distributed_step.hpp"},
    "FormRule": {"src/heuristics/formation_pass.hpp", "src/distributed/distributed_run.cpp",
                 "src/distributed/distributed_step.cpp", "src/distributed/distributed_step.hpp"},
    "PlasticRule": {"src/heuristics/plastic_flow.hpp", "src/distributed/distributed_run.cpp",
                    "src/distributed/distributed_step.cpp", "src/distributed/distributed_step.hpp"},
    "DampingZone": {"src/distributed/distributed_run.cpp", "src/distributed/distributed_step.cpp",
                    "src/distributed/distributed_step.hpp"},
    "QuantaContactRule": {"include/qbond/builders/gas.hpp", "apps/viewer/viewer_draw.cpp"},
}
# Files that use a law for their own purpose: the linear law is the default bond's and has the
# kernels' fast paths; a checkpoint of the older format stores the inverse law's ε apart.
LAW_CONSUMERS = {
    "LinearLaw": {"include/qbond/io/checkpoint.hpp", "include/qbond/model/bonds.hpp", "include/qbond/model/world.hpp",
                  "src/integrators/affine_run_terms.hpp", "src/integrators/hybrid_frozen_kernel.cpp",
                  "src/integrators/newton.cpp", "src/ledger/energy_sums.cpp"},
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
# Files that name an option's bit (IntegratorOption::key) for their own purpose: the command
# line's shorthand flags, the viewer's panel, the checks of the values of `solver`, `warm_start`
# and `newton_iterations` an integrator takes.
OPTION_BIT_CONSUMERS = {
    "neighbours": {"apps/qbond/main.cpp", "apps/viewer/viewer_panel.cpp"},
    "solver": {"apps/qbond/main.cpp", "apps/viewer/viewer_panel.cpp", "src/integrators/integrators.cpp",
               "src/io/scene/builder.cpp"},
    "preconditioner": {"apps/qbond/main.cpp", "apps/viewer/viewer_panel.cpp"},
    "iterations": {"apps/qbond/main.cpp", "apps/viewer/viewer_panel.cpp"},
    "tolerance": {"apps/qbond/main.cpp"},
    "max_iterations": {"apps/viewer/viewer_panel.cpp"},
    "newton_iterations": {"apps/viewer/viewer_panel.cpp", "src/integrators/integrators.cpp"},
    "warm_start": {"apps/viewer/viewer_panel.cpp", "src/integrators/integrators.cpp", "src/io/scene/builder.cpp"},
}
OPTIONS_HEADER = "include/qbond/integrators/integrators.hpp"
SCANNED = ("src", "include", "apps", "python", "fuzz")


def sources(root, scanned=SCANNED):
    for top in scanned:
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
    tests = dict(sources(root, ("tests",)))
    failures = []

    def tested_in(pattern):
        return sorted(f for f, t in tests.items() if pattern.search(t))

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
        # Whole in its header: the factory defined there (inline) and the scene type read there.
        whole = {f for f in declared | factory_decl if f.startswith("include/qbond/heuristics/")
                 and re.search(r"make_heuristic\((?:const )?" + rule + r"\b[^;]*\{", files[f])
                 and re.search(r"\bfrom_scene\(", files[f])}
        if len(factory_decl) != 1 or not next(iter(factory_decl)).startswith("include/qbond/heuristics/"):
            failures.append(f"{rule}: make_heuristic({rule}) declared in {sorted(factory_decl)}, "
                            "not in one header of include/qbond/heuristics/")
        if whole:
            if readers or factory_def:
                failures.append(f"{rule}: whole in {sorted(whole)} but also read or made in "
                                f"{sorted(readers | factory_def)}")
        elif len(readers) != 1 or readers != factory_def or not next(iter(readers)).startswith("src/heuristics/"):
            failures.append(f"{rule}: scene types in {sorted(readers)} and factory in {sorted(factory_def)}, "
                            "not both in one source of src/heuristics/ (nor the rule whole in its header)")
        own = declared | factory_decl | readers | {registry}
        others = naming - own
        tested = tested_in(word)
        if not tested:
            failures.append(f"{rule}: no test of tests/ names it")
        if all(d.startswith("include/qbond/heuristics/") for d in declared):
            extra = others - CONSUMERS.get(rule, set())
            if extra:
                failures.append(f"{rule}: also named in {sorted(extra)}: a heuristic is its own files "
                                "and one line of QBOND_HEURISTICS")
            print(f"heuristic {rule}: {len(own) + 1} files {sorted(own)} + its tests {tested}"
                  + (" (whole in its header)" if whole else " (its step in a source beside its header)")
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
        tested = tested_in(word)
        if not tested:
            failures.append(f"law {law_type}: no test of tests/ names it")
        print(f"law {law_type}: {len(own) + 1} files {sorted(own)} + its tests {tested}"
              + (f"; consumers {sorted(others)}" if others else ""))

    # Integrator options: each row in the header beside its field; the scene reader, the resolved
    # scene, the JSON Schema and the Python module go through the rows alone.
    header = files[OPTIONS_HEADER]
    config = re.search(r"struct IntegratorConfig \{(.*?)\n\};", header, re.S).group(1)
    rows = header[header.index("kIntegratorOptions") if "rows[] = {" not in header else header.index("rows[] = {"):]
    options = re.findall(r'\.key = "([a-z_]+)"', rows)
    if not options:
        failures.append(f"integrator options: no rows of kIntegratorOptions in {OPTIONS_HEADER}")
    for f, t in files.items():
        if f != OPTIONS_HEADER and re.search(r'\.key = "[a-z_]+",\s*\.description', t) and "IntegratorOption" in t:
            failures.append(f"integrator options: rows outside {OPTIONS_HEADER}, in {f}")
    generic = [f for f in files if f.startswith("src/io/") or (f.startswith("python/") and f.endswith(".cpp"))]
    for key in options:
        row = rows[rows.index(f'.key = "{key}"'):]
        row = row[:row.find("{.option", 1) if "{.option" in row[1:] else len(row)]
        if ".read_by" not in row:
            failures.append(f"integrator option {key}: its row does not say which integrators read it")
        fields = set(re.findall(r"&C::(\w+)", row)) | set(re.findall(r"\bc\.(\w+)", row))
        for field in sorted(fields):
            if not re.search(r"\b" + field + r"\s*=", config):
                failures.append(f"integrator option {key}: field {field} not declared in IntegratorConfig")
        pattern = re.compile(r'"' + key + r'"|\.' + key + r"\b")
        naming = {f for f in generic if pattern.search(files[f])} - OPTION_CONSUMERS.get(key, set())
        if naming:
            failures.append(f"integrator option {key}: also read or written in {sorted(naming)}")
        bit = re.compile(r"\b(?:IntegratorOption|O)::" + key + r"\b")
        bit_files = {f for f, t in files.items() if bit.search(t)} - {OPTIONS_HEADER}
        extra = bit_files - OPTION_BIT_CONSUMERS.get(key, set())
        if extra:
            failures.append(f"integrator option {key}: named in {sorted(extra)}: an option is its field and "
                            f"row in {OPTIONS_HEADER}, the code that reads it and its tests")
        field_word = re.compile(r"\.(?:" + "|".join(sorted(fields)) + r")\b") if fields else None
        readers = sorted(f for f, t in files.items() if (f.startswith("src/integrators/") or f.startswith("src/simulation/")) and field_word
                         and field_word.search(t))
        tested = tested_in(re.compile(r"\b(?:" + "|".join(sorted(fields | {key})) + r")\b"))
        if not tested:
            failures.append(f"integrator option {key}: no test of tests/ names it")
        print(f"integrator option {key}: {OPTIONS_HEADER} (field and row), read in {readers}, tests {tested}"
              + (f"; consumers {sorted(bit_files)}" if bit_files else ""))

    # Integrators: each line of QBOND_INTEGRATORS has its row defined in one file of src/integrators/.
    for name in (n.strip() for n in macro_list(header, "QBOND_INTEGRATORS")):
        row = re.compile(r"\bconst IntegratorInfo " + name + r"_integrator\s*=")
        defined = sorted(f for f, t in files.items() if row.search(t))
        if len(defined) != 1 or not defined[0].startswith("src/integrators/"):
            failures.append(f"integrator {name}: its row defined in {defined}, not in one file of src/integrators/")
        tested = tested_in(re.compile(r"\bIntegratorType::" + name + r"\b|\"" + name + r"\""))
        if not tested:
            failures.append(f"integrator {name}: no test of tests/ names it")
        print(f"integrator {name}: its row in {defined}, its line of QBOND_INTEGRATORS in {OPTIONS_HEADER}, "
              f"tests {tested}")

    for f in failures:
        print("FAIL:", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
