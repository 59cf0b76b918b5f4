#!/usr/bin/python3
"""What the Python module adds to a step: the canonical workload (docs/performance.md) stepped from
Python against the same bare step in C++ (qbond_step_times), and the cost per quanta of a Python
force callback and of a Python heuristic. Each step is timed on its own and the medians compared, as qbond_step_times
does (a shared host's slow steps then do not decide the result).

    PYTHONPATH=build/python /usr/bin/python3 bench/python_overhead.py build/qbond_step_times [--n 20] [--steps 200] \
        [--json docs/bench/python-DATE.json --machine "vm, 2 cores"]

With --json the rows are written there; scripts/bench_tables.py renders them into docs/api.md.
"""
import argparse
import datetime
import json
import os
import re
import statistics
import subprocess
import time

import numpy as np

import qbond


def canonical(n):
    # The scene of src/builders/samples.cpp's canonical_lattice(n).
    return qbond.Scene.parse({
        "timestep": 1e-4, "steps": 1000, "gravity": [0, 0, -9.81],
        "materials": {"bond": {"law": "linear", "stiffness": 1000, "damping": 0.01, "damping_model": "axial"}},
        "bodies": [{"name": "lattice", "type": "lattice", "cell": "cubic", "neighbors": "face_diagonal",
                    "size": [n, n, n], "spacing": 0.01, "quanta_mass": 1e-3, "material": "bond"}],
        "anchors": [{"select": {"box": [[-1e-9, -1, -1], [1e-9, 1e3, 1e3]]}}]})


def python_step_ms(n, steps, callback=None, heuristic=None):
    sim = qbond.Simulation(canonical(n))
    sim.set_integrator(threads=1)
    sim.track_energy = False  # the bare step, as qbond_step_times times it
    sim.keep_last_good = False
    sim.set_force_callback(callback)
    if heuristic:
        sim.add_heuristic(heuristic)
    sim.step(5)  # buffers grown, caches warm
    ms = []
    for _ in range(steps):
        start = time.perf_counter()
        sim.step()
        ms.append((time.perf_counter() - start) * 1e3)
    return statistics.median(ms), sim.num_quanta


def cpp_step_ms(exe, n, steps):
    out = subprocess.run([exe, f"--n={n}", "--integrator=default", f"--steps={steps}", "--threads=1"],
                         capture_output=True, text=True, check=True).stdout
    return float(re.search(r"median ([\d.eE+-]+)", out).group(1))


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("step_times", help="the qbond_step_times program")
    p.add_argument("--n", type=int, default=20)
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--json", help="write the results to this file")
    p.add_argument("--machine", default=f"{os.cpu_count()} cores", help="the machine, for the results' provenance")
    args = p.parse_args()

    def drag(x, v, f):
        np.multiply(v, -1e-3, out=f)

    rows = {"C++": [], "Python": [], "Python + empty callback": [], "Python + drag callback": [],
            "Python + empty heuristic": []}
    n_quanta = 0
    for _ in range(args.rounds):  # interleaved, so that the host's load falls on every row alike
        rows["C++"].append(cpp_step_ms(args.step_times, args.n, args.steps))
        rows["Python"].append(python_step_ms(args.n, args.steps)[0])
        rows["Python + empty callback"].append(python_step_ms(args.n, args.steps, lambda x, v, f: None)[0])
        t, n_quanta = python_step_ms(args.n, args.steps, drag)
        rows["Python + drag callback"].append(t)
        rows["Python + empty heuristic"].append(python_step_ms(args.n, args.steps, heuristic=lambda x, dx, dv: None)[0])
    base = statistics.median(rows["C++"])
    print(f"canonical lattice n = {args.n} ({n_quanta} quanta), default integrator, 1 thread, "
          f"median of {args.steps} steps, median of {args.rounds} rounds")
    out = []
    for name, values in rows.items():
        ms = statistics.median(values)
        extra = (ms - base) * 1e6 / n_quanta
        print(f"{name:26s} {ms:9.4f} ms/step  {100 * (ms / base - 1):+6.2f} %  {extra:+8.2f} ns/quanta")
        out.append({"config": name, "ms_per_step": ms, "rounds_ms": values, "percent_over_cpp": 100 * (ms / base - 1),
                    "ns_per_quanta_over_cpp": extra})
    if args.json:
        command = (f"PYTHONPATH=build/python /usr/bin/python3 bench/python_overhead.py build/qbond_step_times "
                   f"--n {args.n} --steps {args.steps} --rounds {args.rounds}")
        with open(args.json, "w") as f:
            json.dump({"date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
                       "machine": args.machine, "command": command, "n": args.n, "quanta": n_quanta,
                       "steps": args.steps, "rounds": args.rounds, "rows": out}, f, indent=1)
            f.write("\n")


if __name__ == "__main__":
    main()
