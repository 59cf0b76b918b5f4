"""Errors raise Python exceptions carrying the messages the qbond program prints."""
import os

import pytest

import qbond
from conftest import SOURCE_DIR

BAD = os.path.join(SOURCE_DIR, "tests", "bad_scenes")


def expected_messages():
    out = {}
    for line in open(os.path.join(BAD, "expected.txt")):
        if line.strip() and not line.startswith("#"):
            name, text = line.rstrip("\n").split("\t", 1)
            out[name] = text
    return out


def test_every_bad_scene_raises_the_programs_message(run_cli):
    expected = expected_messages()
    assert len(expected) >= 25
    for name, text in sorted(expected.items()):
        path = os.path.join(BAD, name)
        with pytest.raises(qbond.SceneError) as info:
            qbond.Scene.load(path)
        message = str(info.value)
        assert text in message, name
        r = run_cli("validate", path)
        assert r.returncode == 2
        assert message in r.stderr, name


def test_scene_error_carries_path_and_rule():
    doc = {"timestep": 0.001, "steps": 1, "materials": {"m": {"law": "linear", "stiffness": 1.0}},
           "bodies": [{"name": "a", "type": "lattice", "cell": "cubic", "size": [2, 2, 2], "spacing": 0.01, "quanta_mass": 1e-3,
                       "material": "m"},
                      {"name": "b", "type": "lattice", "cell": "cubic", "size": [2, 2, 2], "spacing": -0.01, "quanta_mass": 1e-3,
                       "material": "m"}]}
    with pytest.raises(qbond.SceneError) as info:
        qbond.Scene.parse(doc, source="mine")
    e = info.value
    assert isinstance(e, ValueError)
    assert str(e).startswith("mine: ")
    assert str(e) == f"mine: {e.path}: {e.rule}"
    assert e.path == "bodies[1].spacing"
    assert e.rule.startswith("must be > 0")


def test_bad_arguments_raise_value_and_index_errors():
    w = qbond.World()
    w.add_quanta((0, 0, 0))
    w.add_quanta((1, 0, 0))
    with pytest.raises(IndexError, match="quanta 5 does not exist"):
        w.add_bond(0, 5, stiffness=1.0)
    with pytest.raises(ValueError, match="stiffness: must be > 0"):
        w.add_bond(0, 1, stiffness=-1.0)
    with pytest.raises(ValueError, match="law: must be one of"):
        w.add_bond(0, 1, stiffness=1.0, law="rubber")
    with pytest.raises(ValueError, match="unknown integrator 'magic'"):
        qbond.Simulation(w, 1e-3, "magic")
    with pytest.raises(ValueError, match="unknown integrator option 'speed'"):
        qbond.Simulation(w, 1e-3, speed=2)
    with pytest.raises(ValueError, match="timestep: must be > 0"):
        qbond.Simulation(w, 0.0)
    with pytest.raises(ValueError, match="expected three numbers"):
        w.add_quanta((1, 2))


def test_unreadable_checkpoint_raises_checkpoint_error(tmp_path):
    path = tmp_path / "junk.qbc"
    path.write_bytes(b"not a checkpoint at all")
    with pytest.raises(qbond.CheckpointError, match="junk.qbc"):
        qbond.read_checkpoint(str(path))
    sim = qbond.Simulation(qbond.World(), 1e-3)
    with pytest.raises(qbond.CheckpointError):
        sim.restore_checkpoint(str(path))
    # A checkpoint of another world.
    other = qbond.World()
    other.add_quanta((0, 0, 0))
    saved = str(tmp_path / "other.qbc")
    qbond.Simulation(other, 1e-3).save_checkpoint(saved)
    with pytest.raises(qbond.CheckpointError, match="holds 1 quanta and 0 bonds, the simulation has 0 and 0"):
        sim.restore_checkpoint(saved)


def test_blowup_raises_and_keeps_the_last_good_state():
    # Explicit Euler far above its stability limit: the chain's energy grows until the check trips.
    w = qbond.World()
    w.add_chain(4, (0, 0, 0), (0.03, 0, 0), quanta_mass=1e-3, stiffness=1e6)
    w.add_quanta((0.2, 0, 0), v=(10, 0, 0))
    sim = qbond.Simulation(w, 1e-2, "explicit_euler")
    sim.velocities[1] = (0, 1, 0)
    with pytest.raises(qbond.BlowupError) as info:
        sim.step(1000)
    assert isinstance(info.value, RuntimeError)
    assert sim.step_count < 1000
    assert all(abs(x) < 1e6 for x in sim.positions.ravel())
