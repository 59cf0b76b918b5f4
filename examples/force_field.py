#!/usr/bin/python3
"""An elastic block in a force field written in Python: a harmonic trap.

Every quanta is pulled toward the trap's centre c by f = −m ω² (x − c), a field qbond does not
have, computed each step by a Python force callback with NumPy. The bonds' forces are internal,
so the block's centre of mass moves as one particle in the trap: x_cm(t) − c = A cos(ω t). The
script measures the period from the centre's zero crossings and compares it with 2π/ω.

    PYTHONPATH=build/python /usr/bin/python3 examples/force_field.py --frequency 2
"""
import argparse

import numpy as np

import qbond


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frequency", type=float, default=2.0, help="the trap's frequency ω/2π [Hz]")
    parser.add_argument("--periods", type=float, default=2.0, help="simulated time in periods")
    args = parser.parse_args()
    omega = 2 * np.pi * args.frequency
    centre = np.array([0.0, 0.0, 0.0])

    world = qbond.World()  # no gravity: the trap is the only outside force
    ids = world.add_cubic_lattice((4, 4, 4), spacing=0.01, quanta_mass=1e-3, stiffness=500.0, damping=0.05,
                                  origin=(0.05, -0.015, -0.015))
    sim = qbond.Simulation(world, timestep=5e-4)
    m = sim.masses[:, None]

    def trap(x, v, f):
        np.multiply(x - centre, -m * omega**2, out=f)

    sim.set_force_callback(trap)
    times, xs = [0.0], [sim.positions[:, 0].mean()]
    while sim.time < args.periods / args.frequency:
        sim.step()
        times.append(sim.time)
        xs.append(sim.positions[:, 0].mean())
    t, x = np.array(times), np.array(xs)
    # Zero crossings of the centre's x, interpolated linearly between steps: half a period apart.
    k = np.flatnonzero(np.sign(x[:-1]) != np.sign(x[1:]))
    crossings = t[k] - x[k] * (t[k + 1] - t[k]) / (x[k + 1] - x[k])
    period = 2 * np.mean(np.diff(crossings))
    print(f"{len(ids)} quanta in a {args.frequency:g} Hz trap: period {period * 1e3:.3f} ms, "
          f"2π/ω = {2 * np.pi / omega * 1e3:.3f} ms, relative error {period * omega / (2 * np.pi) - 1:+.2e}")


if __name__ == "__main__":
    main()
