#!/usr/bin/python3
"""A run over ranks stops half way; its checkpoint resumes on one rank as if the run alone had
never stopped.

Usage: mpi_resume_test.py QBOND SCENE WORKDIR --ranks N --mpiexec MPIEXEC [--mpiexec-flag F ...]

Runs SCENE alone to its end, and over N ranks to half its steps, then resumes that run's
checkpoint alone to the end: every frame of the resumed run must hold the bytes of the run
alone's (the state, velocity Verlet's carried forces included, travels whole through the
checkpoint), and its diagnostics match to 1e-12 of the energy's scale (the ledger's sums,
added rank by rank before the stop, differ in the last digits).
"""
import argparse
import csv
import json
import os
import shutil
import subprocess
import sys

p = argparse.ArgumentParser()
p.add_argument("qbond")
p.add_argument("scene")
p.add_argument("work")
p.add_argument("--ranks", type=int, required=True)
p.add_argument("--mpiexec", required=True)
p.add_argument("--mpiexec-flag", action="append", default=[])
a = p.parse_args()


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: exit {r.returncode}\n{r.stdout}\n{r.stderr}")


shutil.rmtree(a.work, ignore_errors=True)
alone, split = os.path.join(a.work, "alone"), os.path.join(a.work, "split")
steps = json.load(open(a.scene))["steps"]
run([a.qbond, "run", a.scene, "-o", alone, "--quiet"])
run([a.mpiexec] + a.mpiexec_flag + ["-n", str(a.ranks), a.qbond, "run", a.scene, "-o", split, "--quiet",
                                     "--steps", str(steps // 2)])
run([a.qbond, "run", "--resume", os.path.join(split, "checkpoint.qbc"), "--steps", str(steps), "--quiet"])

frames = sorted(os.listdir(os.path.join(alone, "frames")))
if frames != sorted(os.listdir(os.path.join(split, "frames"))):
    sys.exit("the resumed run wrote other frames than the run alone")
for f in frames:
    if open(os.path.join(alone, "frames", f), "rb").read() != open(os.path.join(split, "frames", f), "rb").read():
        sys.exit(f"frames/{f}: the run stopped over {a.ranks} ranks and resumed alone differs from the run alone")
one = list(csv.reader(open(os.path.join(alone, "diagnostics.csv"))))
two = list(csv.reader(open(os.path.join(split, "diagnostics.csv"))))
if one[0] != two[0] or len(one) != len(two):
    sys.exit("the diagnostics' columns or rows differ")
scale = max(abs(float(r[one[0].index("total")])) for r in one[1:])
for r1, r2 in zip(one[1:], two[1:]):
    for h, x, y in zip(one[0], r1, r2):
        if abs(float(x) - float(y)) > 1e-12 * max(scale, abs(float(x))):
            sys.exit(f"diagnostics step {r1[0]}, {h}: {x} alone, {y} stopped over {a.ranks} ranks and resumed")
print(f"{len(frames)} frames the same bytes; diagnostics within 1e-12 of the energy's scale")
