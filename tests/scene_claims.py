#!/usr/bin/python3
"""Runs a scene whose description makes a claim, and checks the claim on its frames.

Usage: scene_claims.py QBOND_EXE SOURCE_DIR WORK_DIR CLAIM
CLAIM is one of the functions named claim_*. The frames are read back with VTK (Debian's
python3-vtk9, scripts/qbond_frames.py); run with /usr/bin/python3.
"""
import csv
import json
import os
import shutil
import subprocess
import sys

import numpy as np

QBOND, SOURCE, WORK = sys.argv[1], sys.argv[2], sys.argv[3]
sys.path.insert(0, os.path.join(SOURCE, "scripts"))
from qbond_frames import frames, pieces, read  # noqa: E402


def fail(msg):
    sys.exit("FAIL: " + msg)


def run(scene, name, every, edit=None):
    """Runs `scene` (edited by `edit`, a function of its JSON) and returns its frames."""
    out = os.path.join(WORK, name)
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    path = os.path.join(SOURCE, "scenes", scene)
    if edit:
        s = json.load(open(path))
        edit(s)
        path = os.path.join(out, "scene.json")
        json.dump(s, open(path, "w"))
    r = subprocess.run([QBOND, "run", path, "--every", str(every), "-q", "--out", out], capture_output=True, text=True)
    if r.returncode != 0:
        fail(f"qbond run {scene}: exit {r.returncode}\n{r.stderr}")
    return [(t, *read(f)) for t, f in frames(out)]



def closest_unbonded(x, lines):
    """The smallest distance between two quanta that share no bond."""
    d = np.sqrt(((x[:, None, :] - x[None, :, :]) ** 2).sum(-1))
    np.fill_diagonal(d, np.inf)
    d[lines[:, 0], lines[:, 1]] = np.inf
    d[lines[:, 1], lines[:, 0]] = np.inf
    return d.min()


def claim_liquid_blob_merges():
    """scenes/liquid_blob.json: the impact splashes the blob into drops (at least 4 pieces), and
    they merge again into one puddle by t = 1 s, staying one to the end (2 s)."""
    series = run("liquid_blob.json", "liquid_blob", 20)
    counts = [(t, pieces(len(x), lines)) for t, x, lines, _ in series]
    most = max(c for _, c in counts)
    late = [(t, c) for t, c in counts if t >= 1.0 - 1e-9]
    if most < 4:
        fail(f"the blob splashed into at most {most} pieces: {counts}")
    if not late or any(c != 1 for _, c in late):
        fail(f"the drops are not one puddle from t = 1 s on: {[(round(t, 3), c) for t, c in late if c != 1][:10]}")
    print(f"splash: {most} pieces; one puddle from t = {min(t for t, c in counts if t > 0.3 and all(c2 == 1 for t2, c2 in counts if t2 >= t)):.2f} s")


def claim_sheet_fold_contact():
    """scenes/sheet_fold.json: contact keeps the sheet's folds apart, checked on every step. With
    the contact rule (held inside the step) no two unbonded quanta come closer than 2 radii, less
    5%: a pair under a load F rests F h²/(κ μ) inside contact, and 5% of 2 radii is the depth at
    which one pair would carry 4/5 of the sheet's weight (1.6 N at h = 1/120 s, κ = 1000,
    μ = 0.25 g); and the folds do reach contact (the closest pair is within 10% of 2 radii),
    which without the rule they pass (closer than 1.9 radii)."""
    scene = json.load(open(os.path.join(SOURCE, "scenes", "sheet_fold.json")))
    radius = next(h["radius"] for h in scene["heuristics"] if h["type"] == "contact")
    with_contact = min(closest_unbonded(x, lines) for _, x, lines, _ in run("sheet_fold.json", "sheet_fold", 1))

    def no_contact(s):
        s["heuristics"] = [h for h in s["heuristics"] if h["type"] != "contact"]

    without = min(closest_unbonded(x, lines)
                  for _, x, lines, _ in run("sheet_fold.json", "sheet_fold_no_contact", 1, no_contact))
    print(f"closest unbonded pair: {with_contact * 1e3:.3g} mm with contact, {without * 1e3:.3g} mm without; "
          f"2 radii = {2 * radius * 1e3:.3g} mm")
    if with_contact < 0.95 * 2 * radius:
        fail(f"with contact two unbonded quanta came {with_contact * 1e3:.3g} mm apart, below 2 radii")
    if with_contact > 1.1 * 2 * radius:
        fail(f"the folds never reach contact: closest unbonded pair {with_contact * 1e3:.3g} mm > 1.1 x 2 radii")
    if without > 1.9 * radius:
        fail(f"without contact the folds do not come closer than 1.9 radii ({without * 1e3:.3g} mm): "
             "the rule keeps nothing apart")


def probe_rows(scene, name, edit=None):
    """Runs `scene` (edited by `edit`) without frames and returns its diagnostics.csv rows."""
    out = os.path.join(WORK, name)
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    s = json.load(open(os.path.join(SOURCE, "scenes", scene)))
    if edit:
        edit(s)
    path = os.path.join(out, "scene.json")
    json.dump(s, open(path, "w"))
    r = subprocess.run([QBOND, "run", path, "--every", "1", "--no-vtk", "-q", "--out", out], capture_output=True, text=True)
    if r.returncode != 0:
        fail(f"qbond run {scene}: exit {r.returncode}\n{r.stderr}")
    with open(os.path.join(out, "diagnostics.csv")) as f:
        return list(csv.DictReader(f))


def claim_stick_holds():
    """scenes/stick.json: the glue holds the cube where it landed on the 30-degree plate; without
    the form rule it slides off. The glue carries the cube's weight along the slope,
    27 g x g x sin 30° = 0.13 N, on its bonds (k = 200 N/m each), a stretch of 37 µm on 18 of
    them: from t = 0.25 s on (landed and settled) its centre moves less than 1 mm, a tenth of a
    spacing. Without the rule its centre ends below the plate's lowest quanta."""
    def centre(r):
        return np.array([float(r["cube_x"]), float(r["cube_y"]), float(r["cube_z"])])

    rows = probe_rows("stick.json", "stick")
    settled = [centre(r) for r in rows if float(r["time"]) >= 0.25 - 1e-9]
    moved = max(np.linalg.norm(c - settled[0]) for c in settled)
    formed = int(rows[-1]["bonds_alive"]) - int(rows[0]["bonds_alive"])

    def no_form(s):
        s["heuristics"] = [h for h in s["heuristics"] if h["type"] != "form"]

    slid = probe_rows("stick.json", "stick_no_form", no_form)
    scene = json.load(open(os.path.join(SOURCE, "scenes", "stick.json")))
    plate = next(b for b in scene["bodies"] if b["name"] == "plate")
    half = 0.5 * (plate["size"][1] - 1) * plate["spacing"]
    lowest = -half * np.sin(plate["rotation"]["angle"])  # the plate's lowest row of quanta
    end_z = float(slid[-1]["cube_z"])
    print(f"glued ({formed} bonds): centre moves {moved * 1e3:.3g} mm after 0.25 s; without the rule it ends at "
          f"z = {end_z:.3g} m (plate's lowest quanta at z = {lowest:.3g} m)")
    if formed < 1:
        fail("no glue bond formed")
    if moved > 1e-3:
        fail(f"the glued cube moves {moved * 1e3:.3g} mm after landing")
    if end_z > lowest:
        fail(f"without the form rule the cube stays on the plate (z = {end_z:.3g} m)")


def claim_explicit_stack_rests():
    """scenes/explicit_stack.json: velocity Verlet holds the stack with penalty contact. From
    t = 0.2 s on each block's mean height varies less than 1% of a radius (5 mm) and the blocks sit
    their 4 cm apart within the contacts' depth; at the end the kinetic energy is below 1e-9 of
    the potential energy released; `dissipated_contact` never decreases and |`numerical`| stays
    within 1% of the largest kinetic or potential energy change."""
    rows = probe_rows("explicit_stack.json", "explicit_stack")
    f = [{k: float(v) for k, v in r.items()} for r in rows]
    settled = [r for r in f if r["time"] >= 0.2 - 1e-9]
    for b in ("bottom", "middle", "top"):
        z = [r[b + "_z"] for r in settled]
        if max(z) - min(z) > 0.01 * 0.005:
            fail(f"{b}'s mean height varies {max(z) - min(z):.3g} m after 0.2 s")
    last = f[-1]
    for low, high in (("bottom", "middle"), ("middle", "top")):
        gap = last[high + "_z"] - last[low + "_z"]
        if abs(gap - 0.04) > 0.001:
            fail(f"{high} sits {gap:.4g} m above {low}, not 0.04 m")
    released = f[0]["potential"] - last["potential"]
    scale = max(max(r["kinetic"], abs(r["potential"] - f[0]["potential"])) for r in f)
    worst = max(abs(r["numerical"]) for r in f)
    drops = [b["dissipated_contact"] - a["dissipated_contact"] for a, b in zip(f, f[1:])]
    print(f"after 0.2 s heights vary <= {max(max(r[b + '_z'] for r in settled) - min(r[b + '_z'] for r in settled) for b in ('bottom', 'middle', 'top')):.3g} m; "
          f"kinetic {last['kinetic']:.3g} J of {released:.3g} J released; |numerical| <= {worst / scale:.3g} of the largest energy")
    if not last["kinetic"] < 1e-9 * released:
        fail(f"kinetic energy {last['kinetic']:.3g} J at the end")
    if min(drops) < 0:
        fail(f"dissipated_contact decreases by {-min(drops):.3g} J")
    if worst > 0.01 * scale:
        fail(f"|numerical| reaches {worst / scale:.3g} of the largest energy")


if __name__ == "__main__":
    os.makedirs(WORK, exist_ok=True)
    globals()["claim_" + sys.argv[4]]()
    print("ok")
