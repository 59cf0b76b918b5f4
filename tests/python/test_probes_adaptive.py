"""Probes and adaptive steps from Python: a scene's probes read what `qbond run` writes to
diagnostics.csv, and an adaptive scene steps to `qbond run`'s bits."""
import csv
import json
import os

import numpy as np
import pytest

import qbond
from conftest import SOURCE_DIR, write_json


def scene_doc(name, **changes):
    doc = json.load(open(os.path.join(SOURCE_DIR, "scenes", name + ".json")))
    doc.update(changes)
    doc["output"] = {**doc.get("output", {}), "vtk": False}
    doc["output"].pop("dir", None)
    return doc


def run_scene(run_cli, tmp_path, doc):
    out = tmp_path / "out"
    r = run_cli("run", write_json(tmp_path / "scene.json", doc), "--out", str(out))
    assert r.returncode == 0, r.stderr
    with open(out / "diagnostics.csv") as f:
        rows = list(csv.DictReader(f))
    return qbond.read_checkpoint(str(out / "checkpoint.qbc")), rows[-1]


def test_scene_probes_read_what_qbond_run_writes(run_cli, tmp_path):
    doc = scene_doc("twist_and_hold", duration=0.05)
    doc["output"]["every"] = 1
    _, last = run_scene(run_cli, tmp_path, doc)
    sim = qbond.Simulation(qbond.Scene.parse(doc))
    sim.run(0.05)
    probes = sim.probes()
    assert set(probes) == {"held_end", "twisted_end"}
    for name, p in probes.items():
        for k, axis in enumerate("xyz"):
            assert p["mean"][k] == float(last[f"{name}_{axis}"])
            assert p["force"][k] == float(last[f"{name}_f{axis}"])
            assert p["torque"][k] == float(last[f"{name}_t{axis}"])
        assert p["von_mises_max"] == float(last[f"{name}_von_mises_max"])
    # The twisted end's support turns the bar: a torque about x, balanced at the held end.
    assert abs(probes["twisted_end"]["torque"][0]) > 1e-4


def test_probe_reaction_balances_gravity_at_rest():
    # A chain hanging from an anchored top quanta, at rest in its stretched equilibrium: the
    # anchor holds the free quanta's weight.
    w = qbond.World()
    w.gravity = (0, 0, -9.81)
    ids = w.add_chain(5, start=(0, 0, 0), end=(0, 0, -0.4), quanta_mass=0.01, stiffness=1e4, damping=2.0)
    w.anchor([ids[0]])
    sim = qbond.Simulation(w, 1e-3)
    sim.run(3.0)
    sim.add_probe("top", [ids[0]])
    p = sim.probes()["top"]
    assert p["force"] == pytest.approx([0, 0, 4 * 0.01 * 9.81], abs=1e-6)
    assert np.array_equal(p["mean"], sim.positions[ids[0]])
    free = sim.probe(ids[1:])
    assert "force" not in free  # free quanta: no support, no reaction
    assert np.allclose(free["mean"], sim.positions[ids[1:]].mean(axis=0), atol=1e-15)
    with pytest.raises(ValueError, match="a probe named 'top' exists already"):
        sim.add_probe("top", [ids[0]])


def test_adaptive_scene_matches_qbond_run_bit_for_bit(run_cli, tmp_path):
    doc = scene_doc("adaptive_pendulum", duration=0.3)
    ck, last = run_scene(run_cli, tmp_path, doc)
    scene = qbond.Scene.parse(doc)
    assert scene.adaptive["error"] == 1e-4
    sim = qbond.Simulation(scene)
    assert sim.adaptive["enabled"] and sim.end_time == scene.steps * scene.timestep
    sim.run(scene.steps * scene.timestep)
    assert sim.time == ck["time"] == sim.end_time
    assert sim.step_count == ck["step"]
    assert np.array_equal(sim.positions, ck["positions"])
    assert np.array_equal(sim.velocities, ck["velocities"])
    # The steps adapted: the scene's 3 ms is three times velocity Verlet's stability limit.
    assert sim.step_count > 2 * scene.steps
    assert sim.last_step_size == float(last["timestep"])
    sim.step()  # at the scene's end: nothing left to step
    assert sim.step_count == ck["step"]


def test_adaptive_steps_from_python_finish_where_fixed_ones_blow_up():
    def pendulum():
        w = qbond.World()
        w.gravity = (0, 0, -9.81)
        ids = w.add_chain(11, start=(0, 0, 1.2), end=(0, 0, 0.2), quanta_mass=0.01, stiffness=2e4, damping=2.0,
                          velocity=(0.5, 0, 0))
        w.anchor([ids[0]])
        return w
    fixed = qbond.Simulation(pendulum(), 0.003, "velocity_verlet")
    with pytest.raises(qbond.BlowupError):
        fixed.run(0.3)
    sim = qbond.Simulation(pendulum(), 0.003, "velocity_verlet")
    sim.set_adaptive(error=1e-4, energy=0.01, horizon=0.3)
    calls = []
    sim.set_force_callback(lambda x, v, f: calls.append(1))
    sim.run(0.3)
    assert sim.time == 0.3
    assert len(calls) >= sim.step_count + sim.rejected_steps  # forces again for every retry
    assert sim.last_step_size < 0.003
    sim.set_adaptive(False)
    assert not sim.adaptive["enabled"] and sim.adaptive["error"] == 1e-4


def test_adaptive_options_are_checked():
    sim = qbond.Simulation(qbond.World(), 1e-3)
    with pytest.raises(ValueError, match="unknown adaptive option 'tolerance'"):
        sim.set_adaptive(tolerance=1e-3)
    with pytest.raises(ValueError, match="error: must be > 0"):
        sim.set_adaptive(error=0)
    with pytest.raises(ValueError, match="max_step: must be >= min_step"):
        sim.set_adaptive(min_step=1e-3, max_step=1e-4)
    assert sim.adaptive["enabled"] is False


def test_break_rule_from_python_breaks_an_overstretched_bond():
    w = qbond.World()
    ids = w.add_chain(3, start=(0, 0, 0), end=(0.02, 0, 0), quanta_mass=1e-3, stiffness=100)
    w.anchor([ids[0]])
    w.prescribe([ids[2]], "translate", velocity=(1, 0, 0))
    sim = qbond.Simulation(w, 1e-4)
    sim.add_break_rule(max_strain=0.1)
    sim.step(5)
    assert sim.bond_alive.all()
    sim.step(40)  # 4.5 mm pulled over 20 mm: past 10 % in at least one of the two bonds
    assert not sim.bond_alive.all()
    with pytest.raises(ValueError, match="probability: must be in"):
        sim.add_break_rule(max_strain=0.1, probability=0)
