"""Checkpoint and restore continue a run bit for bit."""
import numpy as np
import pytest

import qbond
from test_scene_bits import SCENE


def fracture_scene(preconditioner="block_jacobi"):
    # A bar pulled hard enough at its tip for bonds to break: the state carries topology changes.
    # With multigrid, the kept hierarchy (not in the checkpoint) is dropped where one is saved.
    doc = dict(SCENE)
    doc["integrator"] = {"type": "coupled_implicit", "solver": "cg", "preconditioner": preconditioner}
    doc["loads"] = [{"select": {"box": [[0.049, -1, -1], [1, 1, 1]]}, "force": [3.0, 0, 0]}]
    doc["heuristics"] = [{"type": "break", "max_strain": 0.02}]
    return qbond.Scene.parse(doc)


@pytest.mark.parametrize("preconditioner", ["block_jacobi", "multigrid"])
def test_restore_continues_bit_for_bit(tmp_path, preconditioner):
    path = str(tmp_path / "mid.qbc")
    sim = qbond.Simulation(fracture_scene(preconditioner))
    sim.step(20)
    sim.save_checkpoint(path)
    sim.step(40)
    x, v, alive = sim.positions.copy(), sim.velocities.copy(), sim.bond_alive
    assert not alive.all(), "the test needs broken bonds"

    sim.restore_checkpoint(path)
    assert sim.step_count == 20
    sim.step(40)
    assert np.array_equal(sim.positions, x) and np.array_equal(sim.velocities, v)
    assert np.array_equal(sim.bond_alive, alive)

    fresh = qbond.Simulation(fracture_scene(preconditioner))
    fresh.restore_checkpoint(path)
    fresh.step(40)
    assert np.array_equal(fresh.positions, x) and np.array_equal(fresh.velocities, v)


@pytest.mark.parametrize("preconditioner", ["block_jacobi", "multigrid"])
def test_state_bytes_round_trip_bit_for_bit(preconditioner):
    sim = qbond.Simulation(fracture_scene(preconditioner))
    sim.step(10)
    saved = sim.state_bytes()
    sim.step(15)
    x = sim.positions.copy()
    sim.set_state_bytes(saved)
    assert sim.state_bytes() == saved
    sim.step(15)
    assert np.array_equal(sim.positions, x)


def test_checkpoint_reads_back_with_metadata(tmp_path):
    path = str(tmp_path / "a.qbc")
    sim = qbond.Simulation(fracture_scene())
    sim.step(3)
    sim.save_checkpoint(path)
    ck = qbond.read_checkpoint(path)
    assert ck["step"] == 3 and ck["time"] == sim.time
    assert ck["metadata"]["qbond_version"] == qbond.__version__
    assert np.array_equal(ck["positions"], sim.positions)
