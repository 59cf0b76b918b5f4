#!/usr/bin/python3
"""Peak resident memory of `qbond run` against the estimate it checks before building a scene.

Usage: scripts/run_memory.py QBOND OUT_JSON [--sizes 20,40,100]
Runs n^3 cubic lattices (the canonical workload's, with each neighbour shell at n = 40) for two
steps with ParaView frames on, under /usr/bin/time, and writes one row per run: quanta, bonds, the
measured peak (KiB) and the estimate `qbond validate` prints. The n = 40 lattice with each
integrator, and the largest, run a second time with a fracture rule that breaks nothing
(max_strain 10): a scene with heuristics keeps a copy of its bonds to undo a blown-up step, which
a scene without does not.
docs/running.md ("Memory") cites it.
"""
import argparse
import datetime
import json
import os
import re
import subprocess
import tempfile

p = argparse.ArgumentParser()
p.add_argument("qbond")
p.add_argument("out")
p.add_argument("--sizes", default="20,40,100")
a = p.parse_args()
sizes = list(map(int, a.sizes.split(",")))
runs = [(n, "face_diagonal", "coupled_implicit", False) for n in sizes]
runs += [(40, "nearest", "coupled_implicit", False), (40, "body_diagonal", "coupled_implicit", False)]
runs += [(40, "face_diagonal", i, False) for i in ("velocity_verlet", "hybrid_implicit", "bdf2", "energy_momentum")]
runs += [(40, "face_diagonal", i, True) for i in ("coupled_implicit", "velocity_verlet", "hybrid_implicit", "bdf2",
                                                  "energy_momentum")]
runs += [(max(sizes), "face_diagonal", "coupled_implicit", True)]
rows = []
with tempfile.TemporaryDirectory() as d:
    for n, shells, integrator, fracture in runs:
        scene = os.path.join(d, f"lattice_{n}_{shells}.json")
        json.dump({"timestep": 1e-4, "steps": 2, "gravity": [0, 0, -9.81],
                   "materials": {"bond": {"law": "linear", "stiffness": 1000, "damping": 0.01}},
                   "bodies": [{"name": "lattice", "type": "lattice", "cell": "cubic", "neighbors": shells,
                               "size": [n, n, n], "spacing": 0.01, "quanta_mass": 1e-3, "material": "bond"}],
                   "anchors": [{"select": {"box": [[-1e-9, -1, -1], [1e-9, 1e3, 1e3]]}}],
                   "heuristics": [{"type": "break", "max_strain": 10}] if fracture else []}, open(scene, "w"))
        summary = subprocess.run([a.qbond, "validate", scene], capture_output=True, text=True, check=True).stdout
        field = lambda key: re.search(rf"^  {key} +(\S+)", summary, re.M).group(1)
        estimate = re.search(r"^  memory +about (.+) for a run", summary, re.M).group(1)
        r = subprocess.run(["/usr/bin/time", "-f", "%M", a.qbond, "run", scene, "-q", "--integrator", integrator,
                            "--out", os.path.join(d, "out")], capture_output=True, text=True, check=True)
        rss = int(r.stderr.strip().splitlines()[-1])
        rows.append({"n": n, "neighbors": shells, "integrator": integrator,
                     "heuristics": "break" if fracture else "none", "quanta": int(field("quanta")),
                     "bonds": int(field("bonds")), "max_rss_kib": rss, "estimate": estimate})
        print(rows[-1], flush=True)
json.dump({"date": datetime.datetime.utcnow().strftime("%Y-%m-%dT%H:%M:%SZ"),
           "machine": f"{os.cpu_count()} cores",
           "command": "scripts/run_memory.py build/qbond OUT --sizes " + a.sizes, "rows": rows},
          open(a.out, "w"), indent=1)
