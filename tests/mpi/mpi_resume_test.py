#!/usr/bin/python3
"""A run over ranks stops half way; its checkpoint resumes on any number of ranks as if the run
alone had never stopped.

Usage: mpi_resume_test.py QBOND SCENE WORKDIR --ranks N --mpiexec MPIEXEC [--mpiexec-flag F ...]
                          [--resume-ranks R ...] [--stop-at K] [--reference-ranks M] [--integrator NAME]

Runs SCENE alone to its end, and over N ranks to half its steps (or to step K), then resumes a copy of that
run's directory from its checkpoint to the end for each R (0, the default: alone, without the
launcher; else over R ranks): every frame of each resumed run must hold the bytes of the run
alone's (the state, velocity Verlet's carried forces included, travels whole through the
checkpoint), and its diagnostics match to 1e-12 of the energy's scale (the ledger's sums,
added rank by rank, differ in the last digits). With --reference-ranks M the run it must match is
the scene run over M ranks without stopping (coupled_implicit, whose solve over ranks is not the
run alone's: the checkpoint carries the solve's last solutions, the next steps' guesses; bdf2 its
history). --integrator runs the scene with that integrator instead of its own (a checkpoint keeps it).
With adaptive steps (the steps then a time, steps × timestep) the run alone stops where the run over
ranks stops and is resumed alone, for a run stopped at a time takes a step that ends there.
"""
import csv
import json
import os
import shutil
import subprocess
import sys

from run_outputs import ranks_arguments

p = ranks_arguments()
p.add_argument("--resume-ranks", type=int, action="append", default=[])
p.add_argument("--stop-at", type=int)
p.add_argument("--reference-ranks", type=int, default=0)
p.add_argument("--integrator")
a = p.parse_args()
a.resume_ranks = a.resume_ranks or [0]


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: exit {r.returncode}\n{r.stdout}\n{r.stderr}")


shutil.rmtree(a.work, ignore_errors=True)
alone, split = os.path.join(a.work, "alone"), os.path.join(a.work, "split")
scene = json.load(open(a.scene))
adaptive = "adaptive" in scene
steps = scene["steps"] if "steps" in scene else round(scene["duration"] / scene["timestep"])
chosen = ["--integrator", a.integrator] if a.integrator else []
reference = [a.qbond, "run", a.scene, "-o", alone, "--quiet"] + chosen
if adaptive:
    # An adaptive run stopped at a time takes a step that ends there: the reference stops there too,
    # alone, and is resumed alone.
    reference += ["--steps", str(a.stop_at or steps // 2)]
run(reference if not a.reference_ranks else [a.mpiexec] + a.mpiexec_flag + ["-n", str(a.reference_ranks)] + reference)
if adaptive:
    run([a.qbond, "run", "--resume", os.path.join(alone, "checkpoint.qbc"), "--steps", str(steps), "--quiet"])
run([a.mpiexec] + a.mpiexec_flag + ["-n", str(a.ranks), a.qbond, "run", a.scene, "-o", split, "--quiet",
                                     "--steps", str(a.stop_at or steps // 2)] + chosen)
whom = f"run over {a.reference_ranks} ranks" if a.reference_ranks else "run alone"
frames = sorted(os.listdir(os.path.join(alone, "frames")))
one = list(csv.reader(open(os.path.join(alone, "diagnostics.csv"))))
scale = max(abs(float(r[one[0].index("total")])) for r in one[1:])
for ranks in a.resume_ranks:
    where = "alone" if ranks == 0 else f"over {ranks} ranks"
    resumed = os.path.join(a.work, f"resumed_{ranks}")
    shutil.copytree(split, resumed)
    cmd = [a.qbond, "run", "--resume", os.path.join(resumed, "checkpoint.qbc"), "--steps", str(steps), "--quiet"]
    run(cmd if ranks == 0 else [a.mpiexec] + a.mpiexec_flag + ["-n", str(ranks)] + cmd)
    if frames != sorted(os.listdir(os.path.join(resumed, "frames"))):
        sys.exit(f"the run resumed {where} wrote other frames than the {whom}")
    for f in frames:
        if open(os.path.join(alone, "frames", f), "rb").read() != open(os.path.join(resumed, "frames", f), "rb").read():
            sys.exit(f"frames/{f}: the run stopped over {a.ranks} ranks and resumed {where} differs from the {whom}")
    two = list(csv.reader(open(os.path.join(resumed, "diagnostics.csv"))))
    if one[0] != two[0] or len(one) != len(two):
        sys.exit(f"the diagnostics' columns or rows differ (resumed {where})")
    for r1, r2 in zip(one[1:], two[1:]):
        for h, x, y in zip(one[0], r1, r2):
            if abs(float(x) - float(y)) > 1e-12 * max(scale, abs(float(x))):
                sys.exit(f"diagnostics step {r1[0]}, {h}: {x} in the {whom}, {y} stopped over {a.ranks} ranks and "
                         f"resumed {where}")
    print(f"resumed {where}: {len(frames)} frames the same bytes; diagnostics within 1e-12 of the energy's scale")
