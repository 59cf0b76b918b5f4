#!/usr/bin/python3
"""What a run over ranks does not distribute yet is refused before anything is written.

Usage: mpi_refusal_test.py QBOND SCENE WORKDIR EXPECTED --mpiexec MPIEXEC [--mpiexec-flag F ...]
                           [--run-arg A ...] [--stops]
Runs SCENE over 2 ranks; passes when the program exits 2 (bad input), its message contains
EXPECTED and WORKDIR/out was not created. With --stops, what is refused is a step of the run: it
exits 3 (a blow-up) with EXPECTED, its last good state in WORKDIR/out/checkpoint.qbc.
"""
import argparse
import os
import shutil
import subprocess
import sys

p = argparse.ArgumentParser()
p.add_argument("qbond")
p.add_argument("scene")
p.add_argument("work")
p.add_argument("expected")
p.add_argument("--mpiexec", required=True)
p.add_argument("--mpiexec-flag", action="append", default=[])
p.add_argument("--run-arg", action="append", default=[])
p.add_argument("--stops", action="store_true")
a = p.parse_args()

out = os.path.join(a.work, "out")
shutil.rmtree(a.work, ignore_errors=True)
cmd = [a.mpiexec] + a.mpiexec_flag + ["-n", "2", a.qbond, "run", a.scene, "-o", out, "--quiet"] + a.run_arg
r = subprocess.run(cmd, capture_output=True, text=True)
code = 3 if a.stops else 2
if r.returncode != code or a.expected not in r.stderr:
    sys.exit(f"{' '.join(cmd)}: exit {r.returncode}, expected {code} and '{a.expected}'\n{r.stderr}")
if a.stops:
    if not os.path.exists(os.path.join(out, "checkpoint.qbc")):
        sys.exit(f"{out}/checkpoint.qbc: the last good state was not written")
elif os.path.exists(out):
    sys.exit(f"{out} was created by a refused run")
print(f"refused: {r.stderr.strip().splitlines()[0]}")
