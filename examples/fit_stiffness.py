#!/usr/bin/python3
"""Fit a material's bond stiffness to a measured sag with scipy.optimize.

A cantilever (8 × 2 × 2 quanta) sags under gravity; its tip's measured sag is given (here made
by the same model at a stiffness the fit does not know). Each trial stiffness builds the beam,
settles it (a drag critical for its first mode, 0.4 s) and returns its sag; scipy.optimize.brentq finds the
stiffness whose sag equals the measurement (the sag falls as the stiffness rises, so one root).

    PYTHONPATH=build/python /usr/bin/python3 examples/fit_stiffness.py --measured-sag-mm 2.5
"""
import argparse

import numpy as np
from scipy import optimize

import qbond


def sag(stiffness):
    """The tip's settled sag [m] of the cantilever with bonds of `stiffness` [N/m]."""
    world = qbond.World()
    world.gravity = (0.0, 0.0, -9.81)
    world.add_body("beam")
    world.add_cubic_lattice((8, 2, 2), spacing=0.01, quanta_mass=1e-3, stiffness=stiffness)
    world.anchor(world.select_box((-1e-3, -1, -1), (1e-3, 1, 1)))
    sim = qbond.Simulation(world, timestep=2e-3)
    # A drag f = −c m v critical for the beam's first mode settles it within 0.4 s: ω₁ is 42 rad/s
    # at 1500 N/m (its undamped period, 0.148 s) and grows as √k.
    c = 2 * 42.4 * np.sqrt(stiffness / 1500.0)
    m = sim.masses[:, None]
    sim.set_force_callback(lambda x, v, f: np.multiply(v, -c * m, out=f))
    start = sim.positions.copy()
    sim.run(0.4)
    tip = start[:, 0] > 0.065
    return -(sim.positions[tip, 2] - start[tip, 2]).mean()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--measured-sag-mm", type=float, default=None,
                        help="the measured tip sag [mm] (default: the sag of a 1500 N/m beam)")
    args = parser.parse_args()
    measured = args.measured_sag_mm * 1e-3 if args.measured_sag_mm is not None else sag(1500.0)

    trials = []

    def residual(log10_k):
        s = sag(10 ** log10_k)
        trials.append((10 ** log10_k, s))
        return s - measured

    log10_k = optimize.brentq(residual, 2.0, 4.0, xtol=1e-5)
    k = 10 ** log10_k
    print(f"measured sag {measured * 1e3:.4f} mm -> fitted stiffness {k:.2f} N/m "
          f"({len(trials)} simulations, sag there {sag(k) * 1e3:.4f} mm)")


if __name__ == "__main__":
    main()
