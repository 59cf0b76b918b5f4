#!/usr/bin/python3
"""Compares two builds of qbond_bench on the same benchmark rows, in interleaved pairs.

    bench/ab.py BASE NEW [--filter REGEX] [--rounds N] [--min-time S] [--json FILE]
                [--base-label TEXT] [--new-label TEXT] [-- QBOND_BENCH_ARGS...]

BASE and NEW are qbond_bench programs (say the previous commit's build and this one's). Each
round times every row the filter selects with both, BASE first in even rounds and NEW first in
odd ones, so that a host whose load drifts moves both alike; arguments after `--` go to both
(e.g. `--n=40 --threads=1,2 --integrators=hybrid_frozen`). For each row it prints both
minima and medians, the ratio of the minima and the median of the rounds' ratios, NEW / BASE:
below 1, NEW is faster. On a shared machine read the median pair ratio over several rounds, not
one timing (docs/performance.md). --json also writes every round's times, with the date, the
machine and the labels, as docs/bench/ab-DATE.json (scripts/bench_tables.py renders it)."""
import argparse
import datetime
import json
import os
import platform
import statistics
import subprocess
import sys


def times(program, pattern, min_time, extra):
    """Each row the pattern selects: its time (a step's, for the step rows) and unit, from one run."""
    cmd = [program, f"--benchmark_filter={pattern}", f"--benchmark_min_time={min_time}",
           "--benchmark_format=json", *extra]
    try:
        run = subprocess.run(cmd, capture_output=True, text=True)
    except OSError as e:
        sys.exit(f"ab.py: cannot run {program}: {e.strerror}")
    if run.returncode != 0:
        sys.exit(f"ab.py: {' '.join(cmd)} failed ({run.returncode}):\n{run.stderr}")
    try:
        found = json.loads(run.stdout)["benchmarks"] if run.stdout.strip() else []
    except (json.JSONDecodeError, KeyError):
        sys.exit(f"ab.py: {program} did not print Google Benchmark's JSON")
    rows = {b["name"]: (b["real_time"], b["time_unit"]) for b in found if b.get("run_type") != "aggregate"}
    if not rows:
        sys.exit(f"ab.py: no benchmark matches '{pattern}' in {program}")
    return rows


def main():
    argv = sys.argv[1:]
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    ours = argv[:argv.index("--")] if "--" in argv else argv
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("base")
    p.add_argument("new")
    p.add_argument("--filter", default="step/", help="benchmark rows (a regular expression; default: every step)")
    p.add_argument("--rounds", type=int, default=6, help="interleaved pairs (default 6)")
    p.add_argument("--min-time", type=float, default=0.5, help="seconds each row runs in each program (default 0.5)")
    p.add_argument("--json", help="also write the rounds' times and their provenance to this file")
    p.add_argument("--base-label", default="", help="what BASE is (say a commit), for --json")
    p.add_argument("--new-label", default="", help="what NEW is, for --json")
    a = p.parse_args(ours)
    if a.rounds < 1 or not a.min_time > 0:
        sys.exit("ab.py: --rounds must be >= 1 and --min-time > 0")
    base, new, unit = {}, {}, {}
    for r in range(a.rounds):
        order = [(a.base, base), (a.new, new)]
        for program, into in order if r % 2 == 0 else order[::-1]:
            for name, (t, u) in times(program, a.filter, a.min_time, extra).items():
                into.setdefault(name, []).append(t)
                unit[name] = u
    print(f"{'row':<48} {'unit':>4} {'base min':>10} {'base med':>10} {'new min':>10} {'new med':>10} "
          f"{'min ratio':>9} {'med pair':>9}")
    for name in base:
        if name not in new:
            continue
        b, n = base[name], new[name]
        pairs = [y / x for x, y in zip(b, n)]
        print(f"{name:<48} {unit[name]:>4} {min(b):>10.4g} {statistics.median(b):>10.4g} {min(n):>10.4g} "
              f"{statistics.median(n):>10.4g} {min(n) / min(b):>9.3f} {statistics.median(pairs):>9.3f}")
    if a.json:
        rows = [{"name": k, "unit": unit[k], "base": base[k], "new": new[k]} for k in base if k in new]
        out = {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
               "machine": cpu_model(), "command": "bench/ab.py " + " ".join({a.base: "BASE", a.new: "NEW"}.get(x, x) for x in sys.argv[1:]),
               "base": a.base_label or a.base, "new": a.new_label or a.new, "rounds": a.rounds, "rows": rows}
        tmp = a.json + ".tmp"
        with open(tmp, "w") as f:
            json.dump(out, f, indent=1)
            f.write("\n")
        os.replace(tmp, a.json)


def cpu_model():
    """The CPU's name as /proc/cpuinfo gives it (the platform's otherwise)."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


if __name__ == "__main__":
    main()
