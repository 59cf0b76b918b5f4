#!/usr/bin/python3
"""A scene run over MPI ranks against the same scene run alone (docs/distributed.md).

Usage: mpi_run_test.py QBOND SCENE WORKDIR --ranks N [--repeat] --mpiexec MPIEXEC [--mpiexec-flag F ...]
                       [--run-arg A ...] [--expect-migration] [--expect-recut] [--expect-blowup]
                       [--expect-breaks] [--expect-retakes] [--expect-forms] [--expect-reasons R,...]
                       [--expect-gain] [--expect-restored]

Runs the scene alone, then over N ranks (twice with --repeat), and checks:
  - with --repeat, the two runs over N ranks wrote the same bytes (diagnostics.csv and every frame);
  - every frame holds every quanta and every bond of the run alone, at its positions and
    velocities to 1e-12 of their scale; every diagnostics column matches to 1e-12 of its scale
    (the energy columns, the ledger's work and dissipation among them, of the energy's; a
    momentum's components of the momentum's; the solve's relative residual of ‖b‖, its unit);
  - with N = 1, the run writes the same bytes as the run alone;
  - with --expect-migration, quanta moved between ranks during the run; with --expect-recut, the
    boxes were cut anew when the ranks' loads drifted apart;
  - with --expect-retakes, steps were taken again after a quanta moved past its contact halo;
  - with --expect-blowup, every run stops with exit 3 (a blow-up, or an energy gain past
    limits.stop_on_energy_gain) at the same step with the same message, keeping the state before
    that step;
  - with --expect-breaks, bonds broke, events.csv lists the run alone's breaks (step, bond, ends,
    reason; strain and tension to 1e-12 of their scale) in its order, and in every frame the
    bonds shown plus those broken by then are every bond of the scene and those formed by then:
    none lost, none twice;
  - with --expect-forms, bonds formed, and events.csv lists the run alone's events in its order;
  - with --expect-reasons, the run alone broke bonds for each reason listed (e.g. ductility,strain);
  - with --expect-gain, the run alone's energy exceeded its initial value plus the external work
    (limits.energy_gain), and the run over ranks reports it alike: events.csv's energy_gain row at
    the same step and time, and run.json's record (the first step and time exactly; the largest
    gain g = E - E0 - W within 2e-12 of the energy scale E*, two energy columns' round-off; its
    value relative to what the system could hold, r = g / A, within r (2e-12 E* / g + 1e-12), A
    being a sum of magnitudes, exact to 1e-12). The diagnostics must be written every step: the
    row's g is read from them at its step.
  - with --expect-restored (a scene with restore_energy), every diagnostics row's `numerical`
    stays within 1e-12 of the energy scale alone and over the ranks: the restoration closes the
    ledger each step from the books summed over the ranks;
Exits non-zero with a message naming the file, the column or quanta and the difference.
"""
import csv
import json
import os
import re
import shutil
import subprocess
import sys

from vtkmodules.util.numpy_support import vtk_to_numpy

from run_outputs import events, frames, poly, ranks_arguments, restored, rows, same_breaks, same_bytes, same_events

p = ranks_arguments()
p.add_argument("--repeat", action="store_true")
p.add_argument("--run-arg", action="append", default=[])
p.add_argument("--expect-migration", action="store_true")
p.add_argument("--expect-recut", action="store_true")
p.add_argument("--expect-blowup", action="store_true")
p.add_argument("--expect-breaks", action="store_true")
p.add_argument("--expect-retakes", action="store_true")
p.add_argument("--expect-forms", action="store_true")
p.add_argument("--expect-reasons", default="")
p.add_argument("--expect-gain", action="store_true")
p.add_argument("--expect-restored", action="store_true")
a = p.parse_args()

REL = 1e-12
ENERGY = {"kinetic", "potential", "dissipated", "total", "work", "numerical_damping", "numerical"}
VECTORS = [("px", "py", "pz"), ("lx", "ly", "lz")]


def run(out, ranks):
    if os.path.exists(out):
        shutil.rmtree(out)
    cmd = [a.qbond, "run", a.scene, "-o", out] + a.run_arg
    if ranks:
        cmd = [a.mpiexec] + a.mpiexec_flag + ["-n", str(ranks)] + cmd
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != (3 if a.expect_blowup else 0):
        sys.exit(f"{' '.join(cmd)}: exit {r.returncode}\n{r.stdout}\n{r.stderr}")
    if a.expect_blowup:
        blowups.append([line for line in r.stderr.splitlines()
                        if "blow-up at step" in line or "energy gained at step" in line])
    return r.stdout


blowups = []


os.makedirs(a.work, exist_ok=True)
alone = os.path.join(a.work, "alone")
first, second = os.path.join(a.work, "ranks_a"), os.path.join(a.work, "ranks_b")
run(alone, 0)
log = run(first, a.ranks)

# The same rank count, the same bits.
if a.repeat:
    run(second, a.ranks)
    same_bytes(first, second, f"two runs over {a.ranks} ranks")

if a.ranks == 1:
    same_bytes(alone, first, "the run on one rank and the run alone")

# Diagnostics: every column to 1e-12 of its scale.
one, many = rows(alone), rows(first)
if one[0] != many[0]:
    sys.exit(f"diagnostics columns differ: {one[0]} vs {many[0]}")
if len(one) != len(many):
    sys.exit(f"diagnostics: {len(one) - 1} rows alone, {len(many) - 1} over {a.ranks} ranks")
header = one[0]
values = [[float(x) for x in r] for r in one[1:]]
scale = {h: max(abs(r[k]) for r in values) for k, h in enumerate(header)}
energy_scale = max(scale[h] for h in ENERGY if h in scale)
# A component's round-off is the vector's (a sum over the ranks in another order, as the
# hybrid's momentum restoration takes it), not the component's own, which may be zero.
for group in VECTORS:
    for h in group:
        if h in scale:
            scale[h] = max(scale[g] for g in group if g in scale)
# The solve's residual is relative to ‖b‖: a small residual is a difference of nearly equal
# terms, whose round-off is of ‖b‖'s order, not of the residual's.
if "residual" in scale:
    scale["residual"] = max(scale["residual"], 1.0)
if a.expect_restored:
    restored([("alone", one), (f"over {a.ranks} ranks", many)], REL * energy_scale)
    print(f"numerical within {REL:g} of the energy scale {energy_scale:g} on every row, alone and over {a.ranks} ranks")
worst = 0.0
for r1, rn in zip(one[1:], many[1:]):
    for k, h in enumerate(header):
        x, y = float(r1[k]), float(rn[k])
        s = energy_scale if h in ENERGY else scale[h]
        if abs(x - y) > REL * s:
            sys.exit(f"diagnostics step {r1[0]}, {h}: {x!r} alone, {y!r} over {a.ranks} ranks (scale {s:g})")
        if s > 0:
            worst = max(worst, abs(x - y) / s)

# Frames: every quanta and bond, positions and velocities.
if frames(alone) != frames(first):
    sys.exit("the runs wrote different frames")
for name in frames(alone):
    p1, pn = poly(os.path.join(alone, "frames", name)), poly(os.path.join(first, "frames", name))
    if (p1.GetNumberOfPoints(), p1.GetNumberOfLines()) != (pn.GetNumberOfPoints(), pn.GetNumberOfLines()):
        sys.exit(f"{name}: {p1.GetNumberOfPoints()} quanta and {p1.GetNumberOfLines()} bonds alone, "
                 f"{pn.GetNumberOfPoints()} and {pn.GetNumberOfLines()} over {a.ranks} ranks")
    for what, get in [("position", lambda d: vtk_to_numpy(d.GetPoints().GetData())),
                      ("velocity", lambda d: vtk_to_numpy(d.GetPointData().GetArray("velocity")))]:
        x1, xn = get(p1), get(pn)
        s = max(abs(x1).max(), 1e-300)
        d = abs(x1 - xn).max()
        if d > REL * s:
            sys.exit(f"{name}: {what}s differ by {d:g} (scale {s:g}) over {a.ranks} ranks")
        worst = max(worst, d / s)
    lines1 = vtk_to_numpy(p1.GetLines().GetData())
    linesn = vtk_to_numpy(pn.GetLines().GetData())
    if (lines1 != linesn).any():
        sys.exit(f"{name}: the bonds' ends differ over {a.ranks} ranks")

if a.expect_breaks:
    broke = same_breaks(alone, first, a.ranks, lambda column, scale: REL * scale)
    print(f"{broke} bonds broke, the same over {a.ranks} ranks")

if a.expect_reasons:
    with open(os.path.join(alone, "events.csv")) as f:
        found = {r["reason"] for r in csv.DictReader(f) if r["event"] == "broken"}
    missing = set(a.expect_reasons.split(",")) - found
    if missing:
        sys.exit(f"the run alone broke no bond for {sorted(missing)} (its reasons: {sorted(found)})")

if a.expect_forms:
    kind = same_events(alone, first, a.ranks, lambda column, scale: REL * scale, "formed")
    formed = sum(1 for r in kind[1:] if r[kind[0].index("event")] == "formed")
    print(f"{formed} bonds formed, the same over {a.ranks} ranks")

if a.expect_gain:
    def gain_rows(out):
        e = events(out)
        return [dict(zip(e[0], r)) for r in e[1:] if r[e[0].index("event")] == "energy_gain"]

    def relative_bound(r, g):
        return r * (2 * REL * energy_scale / abs(g) + REL)

    g1, gn = gain_rows(alone), gain_rows(first)
    if len(g1) != 1:
        sys.exit(f"the run alone wrote {len(g1)} energy_gain rows, not one")
    if len(gn) != 1 or (gn[0]["step"], gn[0]["time"]) != (g1[0]["step"], g1[0]["time"]):
        sys.exit(f"energy_gain rows: {g1} alone, {gn} over {a.ranks} ranks")
    at = next(r for r in values if r[header.index("step")] == float(g1[0]["step"]))
    g = at[header.index("total")] - values[0][header.index("total")] - at[header.index("work")]
    r1, rn = float(g1[0]["strain"]), float(gn[0]["strain"])
    if abs(r1 - rn) > relative_bound(r1, g):
        sys.exit(f"energy_gain row: relative gain {r1!r} alone, {rn!r} over {a.ranks} ranks "
                 f"(bound {relative_bound(r1, g):g})")
    j1, jn = (json.load(open(os.path.join(out, "run.json")))["energy_gain"] for out in (alone, first))
    if any(j1[k] != jn[k] for k in ("exceeded", "first_step", "first_time", "limit")):
        sys.exit(f"run.json's energy_gain: {j1} alone, {jn} over {a.ranks} ranks")
    if abs(j1["largest"] - jn["largest"]) > 2 * REL * energy_scale:
        sys.exit(f"run.json's largest gain: {j1['largest']!r} alone, {jn['largest']!r} over {a.ranks} ranks")
    if abs(j1["relative"] - jn["relative"]) > relative_bound(j1["relative"], j1["largest"]):
        sys.exit(f"run.json's relative gain: {j1['relative']!r} alone, {jn['relative']!r} over {a.ranks} ranks")
    print(f"the energy gained past its limit at step {g1[0]['step']}, alone and over {a.ranks} ranks")

if a.expect_blowup and not (len(blowups[0]) == 1 and all(b == blowups[0] for b in blowups)):
    sys.exit(f"the blow-up messages differ: {blowups}")

moved = re.search(r"quanta moved between ranks after (\d+) steps; boxes cut anew (\d+) times", log)
if a.expect_migration and (not moved or int(moved.group(1)) == 0):
    sys.exit(f"no quanta moved between ranks:\n{log}")
if a.expect_recut and (not moved or int(moved.group(2)) == 0):
    sys.exit(f"the boxes were never cut anew:\n{log}")
halos = re.search(r"contact halos built anew (\d+) times, steps taken again (\d+) times", log)
if a.expect_retakes and (not halos or int(halos.group(2)) == 0):
    sys.exit(f"no step was taken again:\n{log}")
print(f"{a.ranks} ranks: largest difference {worst:.3g} of scale; "
      f"{moved.group(1) if moved else 0} steps with migrations, {moved.group(2) if moved else 0} new cuts"
      + (f"; contact halos built anew {halos.group(1)} times, steps taken again {halos.group(2)}" if halos else ""))
