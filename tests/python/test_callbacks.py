"""A Python force callback: called before every step with the state, its forces applied."""
import numpy as np
import pytest

import qbond


def two_quanta():
    w = qbond.World()
    w.add_quanta((0, 0, 0), mass=0.5)
    w.add_quanta((1, 0, 0), mass=2.0)
    w.add_bond(0, 1, stiffness=10.0)
    return w


def test_callback_force_equals_the_same_external_force_bit_for_bit():
    force = np.array([[0.0, 0.3, -1.0], [2.0, 0.0, 0.0]])
    a = qbond.Simulation(two_quanta(), 1e-3)
    a.external_forces[:] = force
    a.step(25)

    b = qbond.Simulation(two_quanta(), 1e-3)
    seen = []

    def push(x, v, f):
        seen.append(x.copy())
        assert not x.flags.writeable and not v.flags.writeable
        f[:] = force

    b.set_force_callback(push)
    b.step(25)
    assert len(seen) == 25
    assert np.array_equal(b.positions, a.positions)
    assert np.array_equal(b.velocities, a.velocities)


def test_callback_sees_the_state_of_each_step():
    # A spring to the origin, F = -c x, on a free quanta, by symplectic Euler:
    # v1 = v0 - h c x0 / m, x1 = x0 + h v1, checked against the same recurrence in NumPy.
    w = qbond.World()
    w.add_quanta((1.0, 0.0, 0.0), mass=2.0)
    sim = qbond.Simulation(w, 1e-2, "symplectic_euler")
    c, h, m = 50.0, 1e-2, 2.0
    sim.set_force_callback(lambda x, v, f: np.multiply(x, -c, out=f))
    sim.step(100)
    x, v = np.array([1.0, 0, 0]), np.zeros(3)
    for _ in range(100):
        v = v + h * (-c * x) * (1 / m)
        x = x + h * v
    assert sim.positions[0] == pytest.approx(x, rel=1e-12, abs=1e-15)
    sim.set_force_callback(None)
    sim.step(1)


def test_callback_exception_propagates():
    sim = qbond.Simulation(two_quanta(), 1e-3)

    def broken(x, v, f):
        raise KeyError("from the callback")

    sim.set_force_callback(broken)
    with pytest.raises(KeyError, match="from the callback"):
        sim.step(3)
    assert sim.step_count == 0
