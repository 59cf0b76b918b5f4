"""Python heuristics: called between a step's projection and its application, their edits applied."""
import numpy as np
import pytest

import qbond


def falling_pair():
    w = qbond.World()
    w.gravity = (0, 0, -9.81)
    w.add_quanta((0, 0, 0.0), mass=1e-3)
    w.add_quanta((0.1, 0, 0.0), mass=1e-3)
    return w


def test_a_heuristic_that_cancels_a_quanta_projection_holds_it_in_place():
    sim = qbond.Simulation(falling_pair(), 1e-3)
    calls = []

    def hold_first(x, dx, dv):
        assert not x.flags.writeable and dx.flags.writeable and dv.flags.writeable
        assert dx.shape == dv.shape == (2, 3)
        calls.append(dv[0, 2])
        dx[0] = 0
        dv[0] = 0

    sim.add_heuristic(hold_first)
    sim.step(50)
    assert len(calls) == 50
    assert all(c < 0 for c in calls)  # gravity pulled the first quanta down in every projection
    assert sim.positions[0].tolist() == [0.0, 0.0, 0.0]
    assert sim.velocities[0].tolist() == [0.0, 0.0, 0.0]
    assert sim.positions[1, 2] < -1e-3  # the other one fell
    sim.clear_heuristics()
    sim.step(1)
    assert sim.positions[0, 2] < 0


def test_a_floor_heuristic_keeps_quanta_above_it():
    # A ground at z = -0.01: a projection that would cross it is cut to land on it, at rest.
    sim = qbond.Simulation(falling_pair(), 1e-3)

    def floor(x, dx, dv):
        below = x[:, 2] + dx[:, 2] < -0.01
        dx[below, 2] = -0.01 - x[below, 2]
        dv[below] = -sim_velocities()[below]

    sim_velocities = lambda: sim.velocities  # noqa: E731
    sim.add_heuristic(floor)
    sim.run(0.2)
    assert np.allclose(sim.positions[:, 2], -0.01, rtol=0, atol=1e-15)
    assert np.abs(sim.velocities).max() == 0


def test_an_exception_in_a_heuristic_is_raised_after_its_step():
    sim = qbond.Simulation(falling_pair(), 1e-3)

    def broken(x, dx, dv):
        raise ArithmeticError("from the heuristic")

    sim.add_heuristic(broken)
    with pytest.raises(ArithmeticError, match="from the heuristic"):
        sim.step(10)
    assert sim.step_count == 1
