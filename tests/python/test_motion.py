"""Prescribed motion from Python: fixed, translate, rotate and keyframes follow their formulas,
match `qbond run` of the same scene bit for bit, and can start between steps."""
import json
import math
import os

import numpy as np
import pytest

import qbond
from conftest import SOURCE_DIR, write_json


def bar(size=(6, 2, 2)):
    w = qbond.World()
    w.add_body("bar")
    w.add_cubic_lattice(size, spacing=0.01, quanta_mass=1e-3, stiffness=1000, damping=0.1)
    return w


def test_translate_follows_x0_plus_v_t():
    w = bar()
    grip = w.select_box((0.049, -1, -1), (1, 1, 1))
    x0 = w.positions[grip]
    w.prescribe(grip, "translate", velocity=(0.05, 0, 0))
    sim = qbond.Simulation(w, 1e-3)
    sim.step(50)
    assert np.allclose(sim.positions[grip], x0 + [0.05 * sim.time, 0, 0], rtol=0, atol=1e-15)
    assert np.allclose(sim.velocities[grip], [0.05, 0, 0], rtol=0, atol=0)
    assert np.all(sim.inverse_masses[grip] == 0)


def test_rotate_turns_at_its_rate_about_the_axis():
    w = bar()
    ends = w.select_box((0.049, -1, -1), (1, 1, 1))
    x0 = w.positions[ends]
    c = np.array([0.05, 0.005, 0.005])
    w.prescribe(ends, "rotate", axis=(1, 0, 0), center=c, rate=2.0)
    sim = qbond.Simulation(w, 1e-3)
    sim.step(100)
    a = 2.0 * sim.time
    r = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    assert np.allclose(sim.positions[ends], (x0 - c) @ r.T + c, rtol=0, atol=1e-15)


def test_keyframes_match_qbond_run_of_the_same_scene_bit_for_bit(run_cli, tmp_path):
    doc = json.load(open(os.path.join(SOURCE_DIR, "scenes", "twist_and_hold.json")))
    doc["duration"] = 0.08
    doc["output"] = {"vtk": False}
    out = tmp_path / "out"
    r = run_cli("run", write_json(tmp_path / "twist.json", doc), "--out", str(out))
    assert r.returncode == 0, r.stderr
    ck = qbond.read_checkpoint(str(out / "checkpoint.qbc"))

    w = qbond.World()
    w.add_body("bar")
    w.add_cubic_lattice((20, 4, 4), spacing=0.01, quanta_mass=0.001, stiffness=1e4, damping=1.0,
                        shells="body_diagonal")
    w.anchor(w.select_box((-0.001, -1, -1), (0.001, 1, 1)))
    w.prescribe(w.select_box((0.189, -1, -1), (1, 1, 1)), "keyframes", axis=(1, 0, 0),
                center=(0.19, 0.015, 0.015), interpolation="smooth",
                keyframes=[{"time": 0.5, "angle": 0.5235987755982988}])
    w.renumber_for_locality()
    sim = qbond.Simulation(w, 0.001)
    sim.run(0.08)
    assert sim.step_count == ck["step"] == 80
    assert np.array_equal(sim.positions, ck["positions"])
    assert np.array_equal(sim.velocities, ck["velocities"])


def test_keyframes_reach_each_pose_and_hold_after_the_last():
    w = qbond.World()
    i = w.add_quanta((0.1, 0, 0), mass=1e-3)
    w.prescribe([i], "keyframes", axis=(0, 0, 1), center=(0, 0, 0),
                keyframes=[(0.1, (0, 0, 0.02)), (0.2, (0, 0, 0.02), math.pi / 2)])
    sim = qbond.Simulation(w, 0.01)
    sim.step(10)  # t = 0.1: the first pose, shifted up, not turned
    assert np.allclose(sim.positions[i], (0.1, 0, 0.02), atol=1e-15)
    sim.step(5)  # halfway to the second (linear): a quarter turn's half
    assert np.allclose(sim.positions[i], (0.1 * math.cos(math.pi / 4), 0.1 * math.sin(math.pi / 4), 0.02), atol=1e-15)
    sim.step(15)  # past the last: held there
    assert np.allclose(sim.positions[i], (0, 0.1, 0.02), atol=1e-15)
    assert np.allclose(sim.velocities[i], 0, atol=1e-15)


def test_prescribe_between_steps_starts_from_where_the_quanta_are():
    w = bar()
    w.gravity = (0, 0, -9.81)
    w.anchor(w.select_box((-0.001, -1, -1), (0.001, 1, 1)))
    sim = qbond.Simulation(w, 1e-3)
    sim.step(20)
    tip = np.flatnonzero(sim.positions[:, 0] > 0.049)
    x_then, t_then = sim.positions[tip].copy(), sim.time
    assert np.all(sim.inverse_masses[tip] > 0)
    numerical, total = sim.ledger()["dissipated_numerical"], sim.energies()["total"]
    sim.prescribe(tip, "translate", velocity=(0, 0, 0.1))
    # The tip's energy left the total as the anchors' work: the budget's residual is unchanged.
    assert abs(sim.energies()["total"] - total) > 1e-6
    assert sim.ledger()["dissipated_numerical"] == pytest.approx(numerical, abs=1e-15)
    sim.step(30)
    assert np.allclose(sim.positions[tip], x_then + [0, 0, 0.1 * (sim.time - t_then)], rtol=0, atol=1e-15)
    assert np.all(sim.inverse_masses[tip] == 0)


def test_bad_motions_raise_value_errors():
    w = bar()
    w.prescribe([0], "fixed")
    with pytest.raises(ValueError, match="quanta 0 already follows a prescribed motion"):
        w.prescribe([0, 1], "translate", velocity=(1, 0, 0))
    with pytest.raises(ValueError, match="motion: must be one of fixed, translate, rotate, keyframes"):
        w.prescribe([1], "wobble")
    with pytest.raises(ValueError, match=r"keyframes\[1\].time: must be after the previous keyframe's"):
        w.prescribe([1], "keyframes", keyframes=[(0.2, (0, 0, 0)), (0.1, (0, 0, 0))])
    with pytest.raises(ValueError, match="keyframes: must hold at least one keyframe"):
        w.prescribe([1], "keyframes")
    with pytest.raises(ValueError, match="axis: must be non-zero"):
        w.prescribe([1], "rotate", axis=(0, 0, 0), rate=1)
    with pytest.raises(IndexError, match="quanta 99 does not exist"):
        w.prescribe([99], "fixed")


def test_the_ledger_closes_with_backward_eulers_own_loss():
    """ledger() holds every account (integrators.md, "Energy accounts"): for the default
    integrator, backward Euler's own loss in closed form (numerical_damping, positive for a bar
    sagging under gravity) and the rest (dissipated_numerical: with a direct solver only the
    bonds' nonlinearity over a step, third order in its small motion), and the budget closes."""
    w = bar()
    w.gravity = (0, 0, -9.81)
    w.anchor(w.select_box((-0.001, -1, -1), (0.001, 1, 1)))
    sim = qbond.Simulation(w, 1e-3, solver="ldlt")
    sim.step(50)
    b = sim.ledger()
    change = b["total"] + b["contact_stored"] - b["initial_total"]
    books = (b["work_loads"] + b["work_anchors"] - b["dissipated_damping"] - b["dissipated_heuristics"] -
             b["dissipated_contact"] - b["numerical_damping"] - b["dissipated_numerical"])
    assert change == pytest.approx(books, abs=1e-12 * abs(b["initial_total"] - b["total"]))
    assert b["numerical_damping"] > 0
    assert abs(b["dissipated_numerical"]) < 1e-3 * b["numerical_damping"]
