#!/usr/bin/python3
"""energy_momentum over MPI ranks taking in halves the steps its Newton iteration cannot converge
whole (docs/distributed.md), on a scene without external forces or dampers of linear bonds.

Usage: mpi_newton_halves_test.py QBOND SCENE WORKDIR --ranks N --mpiexec MPIEXEC [--mpiexec-flag F ...]

Over ranks the iteration stays on the modified matrix, where the run alone may take exact Newton
corrections: a step the run alone takes whole can be taken in halves over ranks, a different step
of the same scheme, so the two runs are not compared. What each (sub)step keeps is checked
instead. A substep of length H ≤ h solves R(y) = M y − H f̄(y) = 0 to ‖R‖₂ ≤ τ ref, ref² =
Σ_i (m_i |y_i| + H Σ_b |f_b|)² (newton.hpp, no external force), with Δx_i = H (v_i + y_i/2) and f̄
the discrete gradient, whose work is −ΔU exactly. Then ΔK + ΔU = Σ_i R_i·Δx_i / H, at most
‖R‖₂ √N v_max, and the momentum changes by Σ_i R_i, at most √N ‖R‖₂ a component. Energy bounds
the rest: v_max ≤ √(2E/m_min), |y_i| ≤ 2 v_max, a bond's |f_b| ≤ √(2 k E) (½ k δ² ≤ E), so
    ref ≤ √N (2 m_max v_max + h z √(2 k E)),
z the most bonds a quanta has. A run of S steps of which K were split takes at most
S − K + K 2^8 substeps (kNewtonSplitDepth). Checks:
  - the run says it took steps again in halves (K ≥ 1), and two runs wrote the same bytes;
  - at every diagnostics row, |numerical| and each momentum component's change from the start
    within their bounds above summed over the substeps, plus the round-off of the sums.
Exits non-zero with a message naming the row, the column and the difference.
"""
import json
import math
import os
import re
import shutil
import subprocess
import sys

from run_outputs import ranks_arguments, rows, same_bytes

p = ranks_arguments()
a = p.parse_args()

ROUND_OFF = 1e-12
SPLIT_DEPTH = 8  # kNewtonSplitDepth (newton.hpp)
with open(a.scene) as f:
    scene = json.load(f)
if scene["integrator"].get("type") != "energy_momentum":
    sys.exit(f"{a.scene}: the bounds are energy_momentum's")
if scene.get("gravity", [0, 0, 0]) != [0, 0, 0] or scene.get("loads") or scene.get("anchors"):
    sys.exit(f"{a.scene}: the bounds are for a scene without external forces")
laws = scene["materials"].values()
if any(m["law"] != "linear" or m.get("damping", 0) != 0 for m in laws):
    sys.exit(f"{a.scene}: the bounds are for linear bonds without dampers")
k = max(m["stiffness"] for m in laws)
h, steps, tau = scene["timestep"], scene["steps"], scene["integrator"]["tolerance"]
masses = [b["mass"] for b in scene["bodies"] if b["type"] == "quanta" for _ in b["positions"]]
if len(masses) != sum(len(b.get("positions", [])) for b in scene["bodies"]):
    sys.exit(f"{a.scene}: the bounds read the masses of 'quanta' bodies")
N = len(masses)
z = N - 1  # every quanta bonded to every other, at most


def run(out):
    shutil.rmtree(out, ignore_errors=True)
    cmd = [a.mpiexec] + a.mpiexec_flag + ["-n", str(a.ranks), a.qbond, "run", a.scene, "-o", out]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: exit {r.returncode}\n{r.stdout}\n{r.stderr}")
    return r.stdout + r.stderr


os.makedirs(a.work, exist_ok=True)
first, second = os.path.join(a.work, "ranks_a"), os.path.join(a.work, "ranks_b")
log = run(first)
run(second)
same_bytes(first, second, f"two runs over {a.ranks} ranks")
m = re.search(r"steps taken again in halves (\d+) times", log)
if not m or int(m.group(1)) < 1:
    sys.exit(f"no step was taken again in halves over {a.ranks} ranks:\n{log}")
split = int(m.group(1))

table = rows(first)
col = {name: i for i, name in enumerate(table[0])}
E = float(table[1][col["total"]])
v_max = math.sqrt(2 * E / min(masses))
ref = math.sqrt(N) * (2 * max(masses) * v_max + h * z * math.sqrt(2 * k * E))
substeps = steps - split + split * 2**SPLIT_DEPTH
energy_bound = substeps * tau * ref * math.sqrt(N) * v_max + ROUND_OFF * E
momentum_bound = substeps * tau * ref * math.sqrt(N)
p0 = [float(table[1][col[c]]) for c in ("px", "py", "pz")]
p_scale = sum(mass * v_max for mass in masses)
worst_e = worst_p = 0.0
for row in table[1:]:
    numerical = abs(float(row[col["numerical"]]))
    if numerical > energy_bound:
        sys.exit(f"step {row[0]}: numerical {numerical:g} J beyond the bound {energy_bound:g} J")
    for c, start in zip(("px", "py", "pz"), p0):
        d = abs(float(row[col[c]]) - start)
        if d > momentum_bound + ROUND_OFF * p_scale:
            sys.exit(f"step {row[0]}: {c} moved {d:g} from the start, beyond the bound {momentum_bound:g}")
        worst_p = max(worst_p, d)
    worst_e = max(worst_e, numerical)
print(f"{a.ranks} ranks: {split} of {steps} steps in halves; |numerical| ≤ {worst_e:.3g} J (bound {energy_bound:.3g}), "
      f"momentum moved ≤ {worst_p:.3g} (bound {momentum_bound:.3g})")
