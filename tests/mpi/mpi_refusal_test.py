#!/usr/bin/python3
"""What a run over ranks does not distribute yet is refused before anything is written.

Usage: mpi_refusal_test.py QBOND SCENE WORKDIR EXPECTED --mpiexec MPIEXEC [--mpiexec-flag F ...]
                           [--run-arg A ...]
Runs SCENE over 2 ranks; passes when the program exits 2 (bad input), its message contains
EXPECTED and WORKDIR/out was not created.
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
a = p.parse_args()

out = os.path.join(a.work, "out")
shutil.rmtree(a.work, ignore_errors=True)
cmd = [a.mpiexec] + a.mpiexec_flag + ["-n", "2", a.qbond, "run", a.scene, "-o", out, "--quiet"] + a.run_arg
r = subprocess.run(cmd, capture_output=True, text=True)
if r.returncode != 2 or a.expected not in r.stderr:
    sys.exit(f"{' '.join(cmd)}: exit {r.returncode}, expected 2 and '{a.expected}'\n{r.stderr}")
if os.path.exists(out):
    sys.exit(f"{out} was created by a refused run")
print(f"refused: {r.stderr.strip().splitlines()[0]}")
