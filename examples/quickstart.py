#!/usr/bin/python3
"""A chain anchored at one end falls and swings: build a world, step it, read its arrays."""
import numpy as np

import qbond

world = qbond.World()
world.gravity = (0.0, 0.0, -9.81)
ids = world.add_chain(10, start=(0, 0, 0), end=(0.9, 0, 0), quanta_mass=0.01, stiffness=500.0, damping=0.1)
world.anchor([ids[0]])

sim = qbond.Simulation(world, timestep=1e-3, integrator="coupled_implicit", tolerance=1e-8)
sim.run(0.5)  # 500 steps, the GIL released
x = sim.positions  # (10, 3) read-only view of the state: valid until the next step
print(f"qbond {qbond.__version__}: t = {sim.time:.3f} s, lowest quanta at z = {x[:, 2].min():.4f} m")
print("energies [J]:", {k: round(v, 6) for k, v in sim.energies().items()})

saved = sim.state_bytes()  # the exact state
sim.step(100)
after = sim.positions.copy()
sim.set_state_bytes(saved)
sim.step(100)
assert np.array_equal(sim.positions, after)  # the same bits again
