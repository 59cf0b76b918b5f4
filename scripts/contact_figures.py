#!/usr/bin/python3
"""Pictures and energy ledgers of the scenes of contact inside the step (docs/heuristics.md).

Usage: scripts/contact_figures.py [BUILD_DIR [SCENE...]]   (default: build, every scene; needs
BUILD_DIR/qbond and xvfb-run)
Runs each scene with `qbond run`, replays the run in the viewer headless under Xvfb at the
moments listed below (`qbond view RUN --time T --screenshot`), and draws the frames side by side
into docs/images/contact_SCENE.png; plots the run's diagnostics.csv ledger over time into
docs/images/contact_SCENE_ledger.png (Debian's python3-matplotlib).
"""
import csv
import os
import shutil
import subprocess
import sys
import tempfile

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib import image

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BUILD = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "build")
ONLY = set(sys.argv[2:])
OUT = os.path.join(ROOT, "docs", "images")
RUNS = os.path.join(BUILD, "contact_figure_runs")

# scene, moments to show [s] with what they show (a function of the run's diagnostics rows and
# the time, or text), camera (eye, target) or None (the viewer's framing of that frame), title.
H = 1 / 60  # ball_bounce's step: a row a step
SCENES = [
    ("block_rest", [(0.0, "set on the ground"), (10.0, "at rest after 10 s")],
     ((0.09, -0.12, 0.07), (0.015, 0.015, 0.015)), "block_rest: a 4×4×4 block on the ground"),
    ("block_incline", [(0.0, "set on the incline"),
                       (1.0, lambda rows, t: f"slid {at(rows, t, 'block_x') - rows[0]['block_x']:.2f} m down it")],
     None, "block_incline: sliding with friction (gravity tilted 35°, the view follows the block)"),
    ("ball_bounce", [(26 * H, lambda rows, t: f"{gap_cm(rows, t):.1f} cm up, falling {-speed(rows, t):.2f} m/s"),
                     (27 * H, lambda rows, t: f"{gap_cm(rows, t):.1f} cm up: {-speed(rows, t) * H / 5e-3:.0f} radii a step"),
                     (28 * H, lambda rows, t: f"{gap_cm(rows, t):.1f} cm up, after its contact step: left at "
                                              f"{at_ground(rows, t, speed(rows, t + H) + 9.81 * H):.2f} = e × "
                                              f"{at_ground(rows, t - H, speed(rows, t - H)):.2f} m/s")],
     ((0.2, -0.3, 0.07), (0.0, 0.0, 0.05)), "ball_bounce: restitution 0.5, a 5 mm quanta dropped 1 m"),
    ("stack", [(0.0, "set 0.5 mm apart"), (10.0, "at rest after 10 s")],
     ((0.12, -0.16, 0.12), (0.015, 0.015, 0.055)), "stack: three 4×4×4 blocks on the ground"),
    ("trampoline", [(0.2, "dropped 20 cm: meeting the sheet at 2 m/s"), (10.0, "at rest on the sagging sheet")],
     ((0.03, -0.2, 0.135), (0.0, 0.0, 0.105)), "trampoline: a 4×4×4 block on a 15×15 sheet held on its edges"),
    ("gap", [(0.2, "falling"), (3.0, "at rest wedged across the gap, not through it")],
     ((0.04, -0.18, 0.19), (0.0, 0.0, 0.155)), "gap: a 3×3×3 block onto ledges 1.5 cm apart"),
    ("mesh_drop", [(0.05, "falling, tilted"), (0.1, "landing"), (1.5, "at rest on the ground")],
     ((0.07, -0.3, 0.12), (0.07, 0.0, 0.02)), "mesh_drop: a voxelised torus and blob dropped on the ground at 1/60 s"),
]


def at(rows, t, col):
    """The column's value on the last diagnostics row at or before t."""
    return [r[col] for r in rows if r["time"] <= t + 1e-6][-1]


def gap_cm(rows, t):
    """ball_bounce: the quanta's height above the ground less its 5 mm margin, in cm."""
    return 100 * (at(rows, t, "ball_z") - 5e-3)


def speed(rows, t):
    """ball_bounce: the quanta's vertical velocity at t after a step of free flight, which is exact:
    the step's mean velocity less g h / 2."""
    return (at(rows, t, "ball_z") - at(rows, t - H, "ball_z")) / H - 9.81 * H / 2


def at_ground(rows, t, v):
    """ball_bounce: the speed of its exact flight where it meets the ground, from velocity v at t."""
    return (v * v + 2 * 9.81 * gap_cm(rows, t) / 100) ** 0.5


LEDGER = [  # column, label, style
    ("kinetic", "kinetic", "-"),
    ("potential", "potential − its start", "-"),
    ("contact_energy", "contact springs", "-"),
    ("work", "work", "--"),
    ("dissipated", "dissipated (all)", "-"),
    ("dissipated_contact", "dissipated by contact", ":"),
    ("numerical_damping", "numerical damping", "-."),
    ("numerical", "numerical", "-"),
]


def qbond_run(scene):
    out = os.path.join(RUNS, scene)
    shutil.rmtree(out, ignore_errors=True)
    subprocess.run([os.path.join(BUILD, "qbond"), "run", os.path.join(ROOT, "scenes", scene + ".json"),
                    "--out", out, "--quiet"], check=True, stdout=subprocess.DEVNULL)
    return out


def screenshot(run, t, camera, path):
    cmd = ["xvfb-run", "-a", "-s", "-screen 0 1280x720x24", os.path.join(BUILD, "qbond"), "view", run,
           "--frames", "1", "--time", f"{t + 1e-6:g}", "--no-ui", "--size", "960", "--screenshot", path]
    if camera:
        eye, target = camera
        cmd += ["--camera-position", ",".join(map(str, eye)), "--camera-target", ",".join(map(str, target))]
    subprocess.run(cmd, check=True, capture_output=True, timeout=300)


def pictures(scene, run, rows, moments, camera, title):
    with tempfile.TemporaryDirectory() as tmp:
        shots = []
        for k, (t, _) in enumerate(moments):
            p = os.path.join(tmp, f"{k}.png")
            screenshot(run, t, camera, p)
            shots.append(image.imread(p))
    fig, axes = plt.subplots(1, len(moments), figsize=(4.8 * len(moments), 3.0))
    for ax, img, (t, what) in zip(axes, shots, moments):
        if callable(what):
            what = what(rows, t)
        ax.imshow(img)
        ax.set_axis_off()
        ax.set_title(f"t = {t:.4g} s: {what}", fontsize=9)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    path = os.path.join(OUT, f"contact_{scene}.png")
    fig.savefig(path, dpi=100)
    plt.close(fig)
    print("wrote", path)


def diagnostics(run):
    with open(os.path.join(run, "diagnostics.csv")) as f:
        return [{k: float(v) for k, v in r.items()} for r in csv.DictReader(f)]


def ledger(scene, rows, title):
    t = [r["time"] for r in rows]
    fig, ax = plt.subplots(figsize=(8.5, 3.4))
    for col, label, style in LEDGER:
        y = [r[col] - (rows[0][col] if col == "potential" else 0) for r in rows]
        ax.plot(t, y, style, label=label, linewidth=1.2)
    ax.axhline(0, color="0.6", linewidth=0.6)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("energy [J]")
    ax.set_title(f"{title}: the energy ledger (diagnostics.csv)", fontsize=9)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    fig.tight_layout()
    path = os.path.join(OUT, f"contact_{scene}_ledger.png")
    fig.savefig(path, dpi=100)
    plt.close(fig)
    print("wrote", path)


def main():
    os.makedirs(OUT, exist_ok=True)
    for scene, moments, camera, title in SCENES:
        if ONLY and scene not in ONLY:
            continue
        run = qbond_run(scene)
        rows = diagnostics(run)
        if moments:
            pictures(scene, run, rows, moments, camera, title)
        ledger(scene, rows, title.split(":")[0])


if __name__ == "__main__":
    main()
