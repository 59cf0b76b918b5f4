#!/usr/bin/python3
"""A scene stepped by coupled_implicit or a Newton integrator (energy_momentum, implicit_midpoint,
bdf2) over MPI ranks against the same scene run alone (docs/distributed.md).

Usage: mpi_implicit_test.py QBOND SCENE WORKDIR --ranks N [--repeat] --mpiexec MPIEXEC [--mpiexec-flag F ...]
                            [--integrator NAME] [--expect-breaks] [--expect-halves] [--expect-restored]

--integrator runs the scene with that integrator instead of its own (qbond run --integrator).
With adaptive steps, S below is the number of steps the run alone took and h its longest step.

The run alone solves each step's system with qbond's CG, the run over ranks with PETSc's CG; both
stop at ‖b − A Δv‖ ≤ τ max(‖b‖, h ‖f_ext‖) (τ the scene's `tolerance`), so each step's Δv is within
κ τ ‖Δv*‖ + τ h ‖f_ext‖ / m of the exact one (κ the condition number of A = M + h C + h² K, whose
eigenvalues are at least m) and the two runs' Δv within twice that. κ ≤ 1 + 2 z (h c + h² k) / m by
Gershgorin's theorem (z bonds a quanta at most, each block of norm at most h c + h² k for a linear
law of stiffness k and damping c). ‖f_ext‖ ≤ √N (m_max g + Σ |F|) for N free quanta, gravity g and
the loads' forces F. Summed over S steps, with ‖Δv‖ ≤ 2 max ‖v‖ (a step's change of velocity), the
velocities differ by at most
    ‖v₁ − v_N‖₂ ≤ 4 κ τ S max ‖v‖₂ + 2 S τ h √N (m_max g + Σ |F|) / m_min,
the positions by h S times that, and the energy columns by twice that relative error of their
scale (energies are quadratic in v). The scene's frames are written every step, so that max ‖v‖
is over every step.

Contact inside the solve (method implicit, obstacles and quanta–quanta pairs) adds to κ's bound what
its contacts add to a quanta's row (below); the bound holds while both runs take the same active-set
decisions, each from its own solution.

The Newton integrators stop at ‖R(y)‖ ≤ τ ref, ref² = Σ_i (m_i |y_i − e_i| + s h (|f_ext,i| +
Σ_b |f_b|))² (newton.hpp), with y = Δv; alone their linear solves may take the exact Jacobian,
over ranks the modified one, so the two iterates differ, each within ‖J⁻¹‖ τ ref of the step's
solution. J = M + s h (c K + θ C) is M to within the same Gershgorin bound (κ − 1) m, so
‖J⁻¹‖ ≤ 1 / (m (2 − κ)), and ref ≤ √N (3 m max ‖v‖ + h (m g + z T)) (N free quanta; |y − e| ≤
|Δv| + |Δv_before| / 3 ≤ 3 max ‖v‖, e being bdf2's (v − v₋₁)/3; s ≤ 1; T the largest tension in
the run alone's frames). Summed over S steps, the velocities differ by at most
    ‖v₁ − v_N‖₂ ≤ 2 S τ ref / (m (2 − κ)),
and the positions by h S times that. Checks:
  - with --repeat, the scene run twice over N ranks wrote the same bytes (diagnostics.csv and
    every frame);
  - every frame holds every quanta and bond of the run alone, at its positions and velocities to
    the bounds above; every diagnostics column but the solver's (iterations, residual: PETSc's over ranks) to
    twice the relative bound plus round-off, of its scale (the energy columns of the energy's, a
    vector's components of the vector's);
  - the ledger over ranks closes: total − total at the start = work − dissipated − numerical_damping − numerical to
    round-off;
  - with --expect-halves, the energy guard took steps again in halves over the ranks (where the
    linearised step would create energy, as the run alone takes them);
  - with --expect-breaks, bonds broke, and events.csv lists the run alone's breaks in its order
    (step, bond, ends and reason exactly); a bond's strain within 2 B_x / r₀ and its tension
    within 2 k B_x + 2 c (B_v + 2 max‖v‖ B_x / r₀) (B_x, B_v the positions' and velocities'
    bounds above, r₀ the lattice spacing, the shortest bond: the strain moves with its ends'
    distance, the axial damper with their relative velocity and its direction); in every frame
    the bonds shown plus those broken by then are every bond.
  - with --expect-restored (a scene with restore_energy), every diagnostics row's `numerical`
    stays within 1e-12 of the energy scale alone and over the ranks (the restoration puts back
    what the step lost, whatever the solve's error);
Exits non-zero with a message naming the file, the column or quanta and the difference.
"""
import json
import os
import re
import shutil
import subprocess
import sys

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy

from run_outputs import frames, poly, ranks_arguments, restored, rows, same_breaks, same_bytes

p = ranks_arguments()
p.add_argument("--repeat", action="store_true")
p.add_argument("--integrator")
p.add_argument("--expect-breaks", action="store_true")
p.add_argument("--expect-halves", action="store_true")
p.add_argument("--expect-restored", action="store_true")
a = p.parse_args()

ROUND_OFF = 1e-12
HUGE = float("inf")
ENERGY = {"kinetic", "potential", "dissipated", "total", "work", "numerical_damping", "numerical"}
SOLVER = {"iterations", "residual"}
# Bonds a quanta of a cubic lattice has at most, by its `neighbors`.
BONDS_PER_QUANTA = {"nearest": 6, "face_diagonal": 18, "body_diagonal": 26}

with open(a.scene) as f:
    scene = json.load(f)
h = scene["timestep"]
steps = scene["steps"]
tau = scene["integrator"]["tolerance"]
NEWTON = {"energy_momentum", "implicit_midpoint", "bdf2"}
integrator = a.integrator or scene["integrator"].get("type", "coupled_implicit")
if integrator != "coupled_implicit" and integrator not in NEWTON:
    sys.exit(f"{a.scene}: the bounds are coupled_implicit's and the Newton integrators'")
if scene["output"].get("every") != 1:
    sys.exit(f"{a.scene}: the bound needs a frame every step")


def run(out, ranks):
    if os.path.exists(out):
        shutil.rmtree(out)
    cmd = [a.qbond, "run", a.scene, "-o", out] + (["--integrator", a.integrator] if a.integrator else [])
    if ranks:
        cmd = [a.mpiexec] + a.mpiexec_flag + ["-n", str(ranks)] + cmd
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: exit {r.returncode}\n{r.stdout}\n{r.stderr}")
    return r.stdout


os.makedirs(a.work, exist_ok=True)
alone = os.path.join(a.work, "alone")
first, second = os.path.join(a.work, "ranks_a"), os.path.join(a.work, "ranks_b")
run(alone, 0)
if "adaptive" in scene:
    # S the steps the run alone took, h its longest: κ's bound grows with h, and h S bounds the
    # time. The tries' lengths follow from each step's Δv, so the runs' times differ within the
    # diagnostics' bound too (their time column is checked with the others).
    taken = rows(alone)
    steps = int(taken[-1][0])
    h = max(float(r[taken[0].index("timestep")]) for r in taken[1:])
kappa = 1.0
spacing, stiffness, damping = HUGE, 0.0, 0.0
for body in scene["bodies"]:
    mat = scene["materials"][body["material"]]
    if body["type"] != "lattice" or body.get("cell") != "cubic" or mat["law"] != "linear":
        sys.exit(f"{a.scene}: the bound is for cubic lattices of linear bonds")
    z = BONDS_PER_QUANTA[body.get("neighbors", "face_diagonal")]
    kappa = max(kappa, 1 + 2 * z * (h * mat.get("damping", 0) + h * h * mat["stiffness"]) / body["quanta_mass"])
    spacing = min(spacing, body["spacing"])
    stiffness, damping = max(stiffness, mat["stiffness"]), max(damping, mat.get("damping", 0))
# Contact inside the solve: an obstacle's contact adds h² k n nᵀ = κ_c m n nᵀ to its quanta's
# diagonal block (k = κ_c m / h², κ_c the rule's `penalty`) and, with friction, a damper h c P of
# at most h (100 k h) = 100 κ_c m (a sticking contact's): the eigenvalues stay at least m. A pair of
# quanta in contact adds such a block, of the reduced mass μ ≤ m, to both ends' diagonal blocks
# and its negative off the diagonal: at most 2 κ_c m (1 + 100) to a row's Gershgorin sum, for each
# of the at most 12 equal spheres that touch one.
for rule in scene.get("heuristics", []):
    if rule.get("method") == "implicit":
        rubs = rule.get("friction", 0) > 0 or rule.get("static_friction", 0) > 0
        per_contact = rule.get("penalty", 1000) * (1 + (100 if rubs else 0))
        kappa += per_contact * (2 * 12 if rule.get("type") == "contact" else 1)
REL_V = 4 * kappa * tau * steps
log = run(first, a.ranks)

# The same rank count, the same bits.
if a.repeat:
    run(second, a.ranks)
    same_bytes(first, second, f"two runs over {a.ranks} ranks")

# Frames: every quanta and bond, positions and velocities within the bound.
if frames(alone) != frames(first):
    sys.exit("the runs wrote different frames")
data = []
for name in frames(alone):
    p1, pn = poly(os.path.join(alone, "frames", name)), poly(os.path.join(first, "frames", name))
    if (p1.GetNumberOfPoints(), p1.GetNumberOfLines()) != (pn.GetNumberOfPoints(), pn.GetNumberOfLines()):
        sys.exit(f"{name}: {p1.GetNumberOfPoints()} quanta and {p1.GetNumberOfLines()} bonds alone, "
                 f"{pn.GetNumberOfPoints()} and {pn.GetNumberOfLines()} over {a.ranks} ranks")
    if (vtk_to_numpy(p1.GetLines().GetData()) != vtk_to_numpy(pn.GetLines().GetData())).any():
        sys.exit(f"{name}: the bonds' ends differ over {a.ranks} ranks")
    v = lambda d: vtk_to_numpy(d.GetPointData().GetArray("velocity"))
    x = lambda d: vtk_to_numpy(d.GetPoints().GetData())
    data.append((name, x(p1), x(pn), v(p1), v(pn)))
vmax = max(np.linalg.norm(v1) for _, _, _, v1, _ in data)
if not vmax > 0:
    sys.exit("the scene does not move: nothing to compare")
if integrator not in NEWTON:
    p1 = poly(os.path.join(alone, "frames", frames(alone)[0]))
    moving = vtk_to_numpy(p1.GetPointData().GetArray("kinematic")) == 0
    mass = vtk_to_numpy(p1.GetPointData().GetArray("mass"))[moving]
    load = mass.max() * np.linalg.norm(scene.get("gravity", [0, 0, 0]))
    load += sum(np.linalg.norm(f.get("force", [0, 0, 0])) for f in scene.get("loads", []))
    REL_V += 2 * steps * tau * h * np.sqrt(moving.sum()) * load / mass.min() / vmax
if integrator in NEWTON:
    if kappa >= 2:
        sys.exit(f"{a.scene}: κ = {kappa:g}: J is not within M's reach of the bound")
    tension = free = 0
    for name in frames(alone):
        p1 = poly(os.path.join(alone, "frames", name))
        tension = max(tension, np.abs(vtk_to_numpy(p1.GetCellData().GetArray("tension"))).max())
        moving = vtk_to_numpy(p1.GetPointData().GetArray("kinematic")) == 0
        mass = vtk_to_numpy(p1.GetPointData().GetArray("mass"))[moving]
        free = moving.sum()
    g = np.linalg.norm(scene.get("gravity", [0, 0, 0]))
    z = max(BONDS_PER_QUANTA[b.get("neighbors", "face_diagonal")] for b in scene["bodies"])
    ref = np.sqrt(free) * (mass.max() * 3 * vmax + h * (mass.max() * g + z * tension))
    REL_V = 2 * steps * tau * ref / (mass.min() * (2 - kappa)) / vmax
worst_v = worst_x = 0.0
for name, x1, xn, v1, vn in data:
    dv, dx = np.linalg.norm(v1 - vn), np.linalg.norm(x1 - xn)
    if dv > REL_V * vmax:
        sys.exit(f"{name}: velocities differ by {dv:g}, beyond the bound {REL_V * vmax:g} "
                 f"(κ ≤ {kappa:g}, τ = {tau:g}, S = {steps})")
    if dx > h * steps * REL_V * vmax + ROUND_OFF * np.abs(x1).max():
        sys.exit(f"{name}: positions differ by {dx:g}, beyond h S times the velocities' bound = "
                 f"{h * steps * REL_V * vmax:g}")
    worst_v, worst_x = max(worst_v, dv / vmax), max(worst_x, dx / (h * steps * vmax))

# Diagnostics: every column but the solver's, within twice the bound of its scale.
one, many = rows(alone), rows(first)
if one[0] != many[0]:
    sys.exit(f"diagnostics columns differ: {one[0]} vs {many[0]}")
if len(one) != len(many):
    sys.exit(f"diagnostics: {len(one) - 1} rows alone, {len(many) - 1} over {a.ranks} ranks")
header = one[0]
col = {name: k for k, name in enumerate(header)}
values = [[float(x) for x in r] for r in one[1:]]
scale = {hd: max(abs(r[k]) for r in values) for k, hd in enumerate(header)}
energy_scale = max(scale[hd] for hd in ENERGY if hd in scale)


def group(hd):
    """A vector's or tensor's components share its scale (px, py, pz; a probe's x, y, z, its force
    fx, fy, fz or torque tx, ty, tz; its stress sxx ... sxy)."""
    m = re.match(r"^(.*_s)[xyz]{2}$", hd) or re.match(r"^(.*_[a-z]?)[xyz]$", hd) or re.match(r"^([pl])[xyz]$", hd)
    return m.group(1) if m else hd


for hd in header:
    scale[hd] = max(scale[o] for o in header if group(o) == group(hd))
worst_d = 0.0
for r1, rn in zip(one[1:], many[1:]):
    for k, hd in enumerate(header):
        if hd in SOLVER:
            continue
        x1, xn = float(r1[k]), float(rn[k])
        s = energy_scale if hd in ENERGY else scale[hd]
        if abs(x1 - xn) > (2 * REL_V + ROUND_OFF) * s:
            sys.exit(f"diagnostics step {r1[0]}, {hd}: {x1!r} alone, {xn!r} over {a.ranks} ranks (scale {s:g}, "
                     f"bound {(2 * REL_V + ROUND_OFF) * s:g})")
        if s > 0:
            worst_d = max(worst_d, abs(x1 - xn) / s)

# The ledger over ranks closes: total − total₀ = work − dissipated − numerical_damping − numerical.
total0 = float(many[1][col["total"]]) if int(float(many[1][col["step"]])) == 0 else None
if total0 is not None:
    for rn in many[1:]:
        got = float(rn[col["total"]]) - total0
        want = (float(rn[col["work"]]) - float(rn[col["dissipated"]]) - float(rn[col["numerical_damping"]]) -
                float(rn[col["numerical"]]))
        if abs(got - want) > ROUND_OFF * energy_scale * 10:
            sys.exit(f"diagnostics step {rn[0]}: the ledger over {a.ranks} ranks does not close "
                     f"({got!r} vs {want!r})")

if a.expect_restored:
    restored([("alone", one), (f"over {a.ranks} ranks", many)], ROUND_OFF * energy_scale)

halves = re.search(r"steps taken again in halves (\d+) times", log)
if a.expect_halves and not halves:
    sys.exit(f"no step was taken again in halves:\n{log}")
broke = ""
if a.expect_breaks:
    b_x, b_v = h * steps * REL_V * vmax, REL_V * vmax
    bound = {"time": lambda scale: ROUND_OFF * scale,
             "strain": lambda scale: 2 * b_x / spacing + ROUND_OFF * scale,
             "tension": lambda scale: 2 * stiffness * b_x + 2 * damping * (b_v + 2 * vmax * b_x / spacing)
             + ROUND_OFF * scale}
    broke = f"; {same_breaks(alone, first, a.ranks, lambda column, scale: bound[column](scale))} bonds broke, the same"

print(f"{a.ranks} ranks: κ ≤ {kappa:.4g}, τ = {tau:g}, S = {steps}: velocities differ by {worst_v:.3g} of "
      f"max‖v‖ (bound {REL_V:.3g}), positions by {worst_x:.3g} of h S max‖v‖, diagnostics by {worst_d:.3g} "
      f"of their scale{broke}" + (f"; {halves.group(1)} steps taken again in halves" if halves else ""))
