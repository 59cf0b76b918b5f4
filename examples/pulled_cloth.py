#!/usr/bin/python3
"""A cloth pinned along its top edge, its bottom corners pulled out and down by keyframed
motions, drawn as a matplotlib animation (saved to a file, no display needed).

The sheet is a 16 × 16 square lattice (diagonal and bending bonds) hanging in the xz plane.
Each frame draws the bonds seen from the front (x, z) and from the side (y, z).

    PYTHONPATH=build/python /usr/bin/python3 examples/pulled_cloth.py --out cloth.gif
"""
import argparse

import matplotlib

matplotlib.use("Agg")  # draws into files: no display needed
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.animation import FuncAnimation, PillowWriter  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402

import qbond  # noqa: E402

N, SPACING = 16, 0.02


def build_cloth():
    world = qbond.World()
    world.gravity = (0.0, 0.0, -9.81)
    world.add_body("cloth")
    ids = world.add_square_lattice((N, N), spacing=SPACING, quanta_mass=2e-4, stiffness=2000.0, damping=0.05,
                                   bending=True)
    # The sheet is built in the xy plane: stand it up in xz, hanging from its top edge at z = 0.
    world.place(ids, axis=(1, 0, 0), angle=np.pi / 2, origin=(0, 0, -(N - 1) * SPACING))
    x = world.positions
    top = np.flatnonzero(np.isclose(x[:, 2], 0.0, atol=1e-9))
    bottom = np.flatnonzero(np.isclose(x[:, 2], x[:, 2].min(), atol=1e-9))
    left, right = bottom[np.argmin(x[bottom, 0])], bottom[np.argmax(x[bottom, 0])]
    world.anchor(top)
    for corner, side in ((left, -1.0), (right, 1.0)):
        # Out and down over 0.3 s, then toward the viewer, then held (smooth: no jerk).
        world.prescribe([corner], "keyframes", interpolation="smooth",
                        keyframes=[(0.3, (side * 0.02, 0.0, -0.02)), (0.6, (side * 0.02, -0.08, -0.02))])
    return world


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="cloth.gif", help="the animation file (.gif)")
    parser.add_argument("--duration", type=float, default=0.8, help="simulated time [s]")
    parser.add_argument("--frames", type=int, default=24)
    args = parser.parse_args()

    sim = qbond.Simulation(build_cloth(), timestep=1e-3)
    ends = sim.bond_ends
    steps_per_frame = max(1, round(args.duration / sim.timestep / args.frames))
    frames = [sim.positions.copy()]
    for _ in range(args.frames):
        sim.step(steps_per_frame)
        frames.append(sim.positions.copy())

    fig, (front, side) = plt.subplots(1, 2, figsize=(7, 3.6), dpi=60)
    views = []
    for ax, (a, b), title in ((front, (0, 2), "front (x, z)"), (side, (1, 2), "side (y, z)")):
        lines = LineCollection([], linewidths=0.6, colors="tab:blue")
        ax.add_collection(lines)
        lo = np.min([f[:, [a, b]].min(axis=0) for f in frames], axis=0) - 0.02
        hi = np.max([f[:, [a, b]].max(axis=0) for f in frames], axis=0) + 0.02
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal")
        ax.set_title(title)
        views.append((lines, a, b))
    label = fig.suptitle("")

    def draw(k):
        x = frames[k]
        for lines, a, b in views:
            lines.set_segments(np.stack([x[ends[:, 0]][:, [a, b]], x[ends[:, 1]][:, [a, b]]], axis=1))
        label.set_text(f"t = {k * steps_per_frame * sim.timestep:.3f} s")
        return [v[0] for v in views] + [label]

    FuncAnimation(fig, draw, frames=len(frames), blit=False).save(args.out, writer=PillowWriter(fps=12))
    low = frames[-1][:, 2].min()
    print(f"{len(frames)} frames to {args.out}; at t = {sim.time:.3f} s the cloth's lowest point is "
          f"z = {low * 1e3:.1f} mm, its largest bond strain {sim.bond_tension_strain()[1].max():.4f}")


if __name__ == "__main__":
    main()
