"""NumPy arrays of a simulation: views without copies, read-only where writing breaks invariants,
writable velocities and external forces whose writes the next step uses."""
import numpy as np
import pytest

import qbond


def free_quanta(n=4, integrator="symplectic_euler"):
    w = qbond.World()
    for k in range(n):
        w.add_quanta((0.1 * k, 0.2, -0.3 * k), (0.5, -1.0 * k, 0.25), mass=0.5 + k)
    return qbond.Simulation(w, 1e-3, integrator)


def test_positions_are_views_of_the_state_not_copies():
    sim = free_quanta()
    a, b = sim.positions, sim.positions
    assert a.shape == (4, 3) and a.dtype == np.float64
    assert np.shares_memory(a, b)
    assert a.flags.c_contiguous


def test_positions_and_masses_are_read_only():
    sim = free_quanta()
    with pytest.raises(ValueError):
        sim.positions[0, 0] = 1.0
    with pytest.raises(ValueError):
        sim.masses[0] = 1.0
    with pytest.raises(ValueError):
        sim.quanta_id[0] = 3


def test_masses_and_ids_round_trip_from_the_builder():
    sim = free_quanta()
    assert sim.masses.tolist() == [0.5, 1.5, 2.5, 3.5]
    assert sim.inverse_masses.tolist() == [1 / 0.5, 1 / 1.5, 1 / 2.5, 1 / 3.5]
    assert sim.quanta_id.tolist() == [0, 1, 2, 3]


def test_positions_round_trip_from_the_builder_bit_for_bit():
    w = qbond.World()
    xs = np.random.default_rng(3).normal(size=(5, 3))
    for x in xs:
        w.add_quanta(x)
    assert np.array_equal(w.positions, xs)
    assert np.array_equal(qbond.Simulation(w, 1e-3).positions, xs)


def test_written_velocities_move_the_quanta_at_the_next_step():
    # Symplectic Euler without forces: x1 = x0 + h v, in the same floating-point operations.
    sim = free_quanta()
    x0 = sim.positions.copy()
    v = sim.velocities
    v[:] = [[1, 2, 3], [-1, 0, 0.5], [0, 0, 0], [4, -4, 1e-3]]
    sim.step()
    assert np.array_equal(sim.positions, x0 + 1e-3 * v)


def test_external_forces_stay_applied_until_changed():
    # Symplectic Euler: v_k = v_0 + k h F/m; the force applies to every step until reset.
    sim = free_quanta(1)
    v0 = sim.velocities.copy()[0]
    f = sim.external_forces
    assert f.shape == (1, 3) and not f.any()
    f[0] = (0.0, 0.0, 3.0)
    sim.step(10)
    dv = sim.velocities[0] - v0
    assert dv[2] == pytest.approx(10 * 1e-3 * 3.0 / 0.5, rel=1e-12)
    assert dv[0] == 0 and dv[1] == 0
    sim.external_forces[:] = 0
    before = sim.velocities.copy()
    sim.step(5)
    assert np.array_equal(sim.velocities, before)


def test_bond_arrays_tensions_and_forces():
    # Two quanta 1 m apart with rest length 0.5 m: tension k (r - L) = 100 × 0.5 = 50 N, strain 1,
    # and the bond pulls each toward the other with 50 N.
    w = qbond.World()
    w.add_quanta((0, 0, 0))
    w.add_quanta((1, 0, 0))
    b = w.add_bond(0, 1, stiffness=100.0, rest_length=0.5)
    assert b == 0
    sim = qbond.Simulation(w, 1e-3)
    assert sim.bond_ends.tolist() == [[0, 1]]
    assert sim.bond_alive.tolist() == [True]
    assert sim.bond_rest_lengths.tolist() == [0.5]
    tension, strain = sim.bond_tension_strain()
    assert tension.tolist() == [50.0] and strain.tolist() == [1.0]
    assert sim.bond_forces.tolist() == [[50.0, 0, 0], [-50.0, 0, 0]]


def test_views_stay_valid_after_a_checkpoint_restore(tmp_path):
    sim = free_quanta()
    path = str(tmp_path / "a.qbc")
    sim.save_checkpoint(path)
    v = sim.velocities
    sim.restore_checkpoint(path)
    assert np.shares_memory(v, sim.velocities)
