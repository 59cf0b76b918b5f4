#!/usr/bin/python3
"""Draws docs/images/geometry_packing.png (packings and voxelised meshes as built) and
docs/images/geometry_fig12.png (scenes/asymmetric_block.json at its end: the paper's Figure 12).

Usage: scripts/geometry_figures.py [BUILD_DIR]   (default: build; needs build/qbond)
Builds small scenes with `qbond run --steps 0` (the first frame is the world as built), reads
the ParaView frames back with VTK and draws quanta and bonds with matplotlib; uses Debian's
python3-vtk9 and python3-matplotlib.
"""
import json
import os
import struct
import subprocess
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.collections import LineCollection
from mpl_toolkits.mplot3d.art3d import Line3DCollection
import numpy as np

from qbond_frames import frames, read

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BUILD = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "build")
QBOND = os.path.join(BUILD, "qbond")
OUT = os.path.join(ROOT, "docs", "images")
RUNS = os.path.join(BUILD, "geometry_runs")
MATERIAL = {"m": {"stiffness": 1000}}

# name, body (built at the origin), view (elevation, azimuth), title
PANELS = [
    ("poisson3d", {"type": "packing", "points": "poisson", "size": [0.06, 0.04, 0.04], "min_distance": 0.008,
                   "bond_radius": 0.013, "seed": 3},
     (20, -60), "Poisson-disk block, r = 8 mm,\nbonds within 13 mm"),
    ("poisson2d", {"type": "packing", "points": "poisson", "size": [0.1, 0.1, 0], "min_distance": 0.008,
                   "bond_radius": 0.013, "seed": 3},
     (90, -90), "flat (2D) Poisson-disk packing:\nthe asymmetric lattice"),
    ("torus", {"type": "mesh", "file": os.path.join(ROOT, "scenes", "meshes", "torus.obj"), "scale": 0.001,
               "spacing": 0.006, "neighbors": "nearest"},
     (35, -60), "torus.obj voxelised, a = 6 mm\n(nearest bonds only, mesh in grey)"),
    ("blob", {"type": "mesh", "file": os.path.join(ROOT, "scenes", "meshes", "blob.stl"), "spacing": 0.005,
              "neighbors": "nearest"},
     (10, -80), "blob.stl voxelised, a = 5 mm\n(nearest bonds only, mesh in grey)"),
]


def run(name, scene, *args):
    out = os.path.join(RUNS, name)
    path = os.path.join(RUNS, name + ".json")
    with open(path, "w") as f:
        json.dump(scene, f, indent=1)
    subprocess.run([QBOND, "run", path, "-q", "--out", out, *args], check=True)
    return frames(out)


def obj_edges(path, scale):
    verts, edges = [], set()
    for line in open(path):
        t = line.split()
        if t and t[0] == "v":
            verts.append([float(c) * scale for c in t[1:4]])
        elif t and t[0] == "f":
            f = [int(c.split("/")[0]) - 1 for c in t[1:]]
            edges |= {tuple(sorted((f[k], f[(k + 1) % len(f)]))) for k in range(len(f))}
    v = np.array(verts)
    return v[np.array(sorted(edges))]


def stl_edges(path):
    data = open(path, "rb").read()
    (n,) = struct.unpack_from("<I", data, 80)
    segs = []
    for t in range(n):
        c = np.array(struct.unpack_from("<9f", data, 84 + 50 * t + 12)).reshape(3, 3)
        segs += [c[[0, 1]], c[[1, 2]], c[[2, 0]]]
    return np.array(segs)


def equal_axes(ax, x, flat=False):
    lo, hi = x.min(axis=0), x.max(axis=0)
    mid, span = (hi + lo) / 2, (hi - lo).max() / 2 * 1.05
    ax.set_xlim(mid[0] - span, mid[0] + span)
    ax.set_ylim(mid[1] - span, mid[1] + span)
    ax.set_zlim(mid[2] - span, mid[2] + span)
    ax.set_box_aspect((1, 1, 1))
    ax.tick_params(labelsize=6)
    if flat:
        ax.set_zticks([])


def packing_figure():
    fig = plt.figure(figsize=(10, 10))
    for k, (name, body, (elev, azim), title) in enumerate(PANELS):
        scene = {"timestep": 1e-4, "steps": 0, "materials": MATERIAL,
                 "bodies": [dict(name=name, material="m", quanta_mass=1e-3, **body)]}
        _, frame = run(name, scene, "--steps", "0")[0]
        x, lines, _ = read(frame)
        ax = fig.add_subplot(2, 2, k + 1, projection="3d")
        if name == "torus":
            ax.add_collection3d(Line3DCollection(obj_edges(body["file"], body["scale"]), colors="0.75",
                                                 linewidths=0.3))
        if name == "blob":
            ax.add_collection3d(Line3DCollection(stl_edges(body["file"]), colors="0.75", linewidths=0.3))
        ax.add_collection3d(Line3DCollection(x[lines], colors="tab:blue", linewidths=0.4, alpha=0.6))
        ax.scatter(x[:, 0], x[:, 1], x[:, 2], s=3, c="k", depthshade=True)
        equal_axes(ax, x, flat=name == "poisson2d")
        ax.view_init(elev, azim)
        bonds_per = 2 * len(lines) / len(x)
        ax.set_title(f"{title}\n{len(x)} quanta, {len(lines)} bonds ({bonds_per:.1f} per quanta)", fontsize=9)
    fig.suptitle("qbond bodies from packings and meshes (as built, [m])", fontsize=12)
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    path = os.path.join(OUT, "geometry_packing.png")
    fig.savefig(path, dpi=100)
    plt.close(fig)
    print("wrote", path)


def fig12_figure():
    with open(os.path.join(ROOT, "scenes", "asymmetric_block.json")) as f:
        scene = json.load(f)
    series = run("asymmetric_block", scene)
    x0, lines0, _ = read(series[0][1])
    t, frame = series[-1]
    x, lines, strain = read(frame)
    split = 0.05  # the symmetric block has y < 0.05, the asymmetric one y > 0.05
    fig, axes = plt.subplots(2, 1, figsize=(9, 7.5), sharex=True)
    lim = 0.04
    for ax, (label, side) in zip(axes, (("symmetric cubic lattice", x0[:, 1] < split),
                                        ("asymmetric Poisson-disk packing", x0[:, 1] > split))):
        keep0 = side[lines0[:, 0]] & side[lines0[:, 1]]
        ax.add_collection(LineCollection(x0[lines0[keep0]][:, :, [0, 2]], colors="0.8", linewidths=0.5))
        keep = side[lines[:, 0]] & side[lines[:, 1]]
        lc = LineCollection(x[lines[keep]][:, :, [0, 2]], cmap="coolwarm", linewidths=0.8)
        lc.set_array(np.clip(strain[keep], -lim, lim))
        lc.set_clim(-lim, lim)
        ax.add_collection(lc)
        ax.scatter(x[side, 0], x[side, 2], s=2, c="k")
        tip = side & (x0[:, 0] > 0.11)
        sag = (x[tip, 2] - x0[tip, 2]).mean()
        broken = int(keep0.sum() - keep.sum())
        ax.set_title(f"{label}: tip sags {-sag * 1000:.1f} mm, {broken} bonds broken", fontsize=10)
        ax.set_aspect("equal")
        ax.set_ylabel("z [m]")
        ax.set_ylim(-0.035, 0.04)
        ax.set_xlim(-0.005, 0.125)
    axes[-1].set_xlabel("x [m] (anchored at x = 0)")
    fig.colorbar(lc, ax=axes, label="bond strain", shrink=0.8)
    fig.suptitle(f"Figure 12 (scenes/asymmetric_block.json at t = {t:.2f} s): same size, mass and bond stiffness\n"
                 "under gravity; bonds past 4% strain break with probability 0.1 per step (grey: t = 0)", fontsize=10)
    path = os.path.join(OUT, "geometry_fig12.png")
    fig.savefig(path, dpi=100)
    plt.close(fig)
    print("wrote", path)


def main():
    os.makedirs(OUT, exist_ok=True)
    os.makedirs(RUNS, exist_ok=True)
    packing_figure()
    fig12_figure()


if __name__ == "__main__":
    main()
