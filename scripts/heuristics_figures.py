#!/usr/bin/python3
"""Runs the heuristics' scenes and draws their outcomes into docs/images/heuristics_*.png.

Usage: scripts/heuristics_figures.py [BUILD_DIR [SCENE...]]   (default: build, every figure;
needs BUILD_DIR/qbond)
Reads the runs' ParaView frames back with VTK and draws bonds (coloured by strain) and quanta
with matplotlib; uses Debian's python3-vtk9 and python3-matplotlib.
"""
import os
import subprocess
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
from mpl_toolkits.mplot3d.art3d import Line3DCollection
import numpy as np

from qbond_frames import frames, pieces, read

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BUILD = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "build")
ONLY = set(sys.argv[2:])
OUT = os.path.join(ROOT, "docs", "images")
RUNS = os.path.join(BUILD, "heuristics_runs")

# scene, frames to draw (fractions of the run), view (elevation, azimuth), title
FIGURES = [
    ("fracture_bar", [0.0, 0.5, 1.0], (60, -90), "break: a notched bar pulled apart (crack from the notch)"),
    ("plastic_beam", [0.0, 0.3, 1.0], (0, -90), "plastic: a yielded cantilever sags 4x as far as an elastic one"),
    ("cube_drop", [0.0, 0.1, 0.3, 1.0], (15, -60), "ground: a cube thrown down at 10 m/s comes to rest"),
    ("sheet_fold", [0.0, 0.4, 1.0], (25, -60), "sphere + contact: a sheet drapes over a sphere, its folds kept apart"),
    ("collision", [0.0, 0.5, 1.0], (70, -90), "contact: two blocks collide (momentum conserved)"),
    ("weld", [0.0, 0.03, 1.0], (5, -60), "form: a block thrown up welds to a held one and hangs from the weld"),
    ("stick", [0.0, 0.05, 1.0], (15, 0), "form + contact: a cube sticks where it lands on a 30-degree slope"),
    ("cohesion", [0.0, 0.1, 0.3, 1.0], (90, -90), "liquid: two drops meet and merge into one spinning body"),
    ("liquid_blob", [0.112, 0.125, 0.15, 0.3, 1.0], (50, -60), "liquid: a blob falls into a tank, splashes, and its drops merge again"),
]



def main():
    os.makedirs(OUT, exist_ok=True)
    for name, picks, (elev, azim), title in FIGURES:
        if ONLY and name not in ONLY:
            continue
        run = os.path.join(RUNS, name)
        subprocess.run([os.path.join(BUILD, "qbond"), "run", os.path.join(ROOT, "scenes", name + ".json"),
                        "-q", "--out", run], check=True)
        series = frames(run)
        fig = plt.figure(figsize=(4.2 * len(picks), 4.2))
        shown = [series[round(frac * (len(series) - 1))] for frac in picks]
        all_x = np.vstack([read(f)[0] for _, f in shown])
        lo, hi = all_x.min(axis=0), all_x.max(axis=0)
        span = (hi - lo).max() / 2
        mid = (hi + lo) / 2
        for k, (t, f) in enumerate(shown):
            x, lines, strain = read(f)
            ax = fig.add_subplot(1, len(picks), k + 1, projection="3d")
            segs = x[lines]
            lim = max(1e-3, np.abs(strain).max())
            lc = Line3DCollection(segs, cmap="coolwarm", linewidths=0.6)
            lc.set_array(np.clip(strain, -lim, lim))
            lc.set_clim(-lim, lim)
            ax.add_collection3d(lc)
            ax.scatter(x[:, 0], x[:, 1], x[:, 2], s=1.5, c="k", depthshade=False)
            for a, (m, setter) in enumerate(zip(mid, (ax.set_xlim, ax.set_ylim, ax.set_zlim))):
                setter(m - span, m + span)
            ax.set_box_aspect((1, 1, 1))
            ax.view_init(elev, azim)
            ax.set_title(f"t = {t:.3g} s, {len(lines)} bonds, {pieces(len(x), lines)} pieces", fontsize=9)
            ax.tick_params(labelsize=6)
        fig.suptitle(title + "  (bonds coloured by strain)", fontsize=10)
        fig.tight_layout()
        path = os.path.join(OUT, f"heuristics_{name}.png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        print("wrote", path)


if __name__ == "__main__":
    main()
