#!/usr/bin/python3
"""A bar dropped across a round post breaks in two: a scene given as a Python dict.

The bar (24 × 3 × 3 quanta, 1 cm apart) falls from 3 cm onto a sphere under its middle; its
ends swing down, the bonds over the post stretch past the fracture strain and break. Prints
when the first bond broke, how many did, and the pieces the bar ended in (connected components
of the bonds left, counted here with NumPy).

    PYTHONPATH=build/python /usr/bin/python3 examples/drop_and_break.py --duration 0.25
"""
import argparse

import numpy as np

import qbond


def scene(max_strain):
    return {
        "name": "drop_and_break",
        "seed": 3,
        "timestep": 5e-4,
        "duration": 1.0,
        "gravity": [0, 0, -9.81],
        "materials": {"glassy": {"law": "linear", "stiffness": 3000, "damping": 0.05}},
        "bodies": [{"name": "bar", "type": "lattice", "cell": "cubic", "neighbors": "face_diagonal",
                    "size": [24, 3, 3], "spacing": 0.01, "quanta_mass": 2e-3, "material": "glassy",
                    "origin": [-0.115, -0.01, 0.03]}],
        "heuristics": [
            {"type": "sphere", "center": [0, 0, -0.02], "radius": 0.02, "friction": 0.3},
            {"type": "break", "max_strain": max_strain},
        ],
    }


def pieces(n, ends, alive):
    """Connected components of the quanta through the bonds that hold (union-find)."""
    parent = np.arange(n)

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a, b in ends[alive]:
        ra, rb = root(a), root(b)
        if ra != rb:
            parent[ra] = rb
    return len({root(i) for i in range(n)})


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=0.25, help="simulated time [s]")
    parser.add_argument("--max-strain", type=float, default=0.02, help="fracture strain of the bonds")
    args = parser.parse_args()

    sim = qbond.Simulation(qbond.Scene.parse(scene(args.max_strain), source="drop_and_break"))
    first_break = None
    while sim.time < args.duration - 1e-12:
        sim.step(10)
        if first_break is None and not sim.bond_alive.all():
            first_break = sim.time
    alive = sim.bond_alive
    broken = int(np.count_nonzero(~alive))
    when = f"{first_break * 1e3:.1f} ms" if first_break is not None else "never"
    print(f"after {sim.time:.3f} s: first bond broke at {when}, {broken} of {sim.num_bonds} bonds broken, "
          f"{pieces(sim.num_quanta, sim.bond_ends, alive)} pieces")


if __name__ == "__main__":
    main()
