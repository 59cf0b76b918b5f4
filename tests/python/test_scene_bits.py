"""A world built in Python steps to the same bits as the same scene run by `qbond run`."""
import numpy as np

import qbond
from conftest import write_json

SCENE = {
    "name": "bar",
    "timestep": 0.001,
    "steps": 60,
    "gravity": [0, 0, -9.81],
    "materials": {"steel": {"law": "linear", "stiffness": 2000.0, "damping": 0.05}},
    "bodies": [{"name": "bar", "type": "lattice", "cell": "cubic", "neighbors": "face_diagonal",
                "size": [6, 2, 2], "spacing": 0.01, "quanta_mass": 0.001, "material": "steel"}],
    "anchors": [{"select": {"box": [[-0.001, -1, -1], [0.001, 1, 1]]}}],
    "loads": [{"select": {"box": [[0.049, -1, -1], [1, 1, 1]]}, "force": [0, 0, -0.2]}],
    "output": {"vtk": False},
}


def python_world():
    w = qbond.World()
    w.gravity = (0, 0, -9.81)
    w.add_body("bar")
    w.add_cubic_lattice((6, 2, 2), spacing=0.01, quanta_mass=0.001, stiffness=2000.0, damping=0.05)
    w.anchor(w.select_box((-0.001, -1, -1), (0.001, 1, 1)))
    w.add_load(w.select_box((0.049, -1, -1), (1, 1, 1)), (0, 0, -0.2))
    w.renumber_for_locality()
    return w


def cli_run(run_cli, tmp_path):
    scene = write_json(tmp_path / "bar.json", SCENE)
    out = tmp_path / "out"
    r = run_cli("run", scene, "--out", str(out))
    assert r.returncode == 0, r.stderr
    return qbond.read_checkpoint(str(out / "checkpoint.qbc"))


def test_python_built_world_matches_qbond_run_bit_for_bit(run_cli, tmp_path):
    ck = cli_run(run_cli, tmp_path)
    assert ck["step"] == 60
    sim = qbond.Simulation(python_world(), 0.001)
    sim.step(60)
    assert sim.step_count == 60
    assert np.array_equal(sim.positions, ck["positions"])
    assert np.array_equal(sim.velocities, ck["velocities"])
    # The bar moved: the comparison is not of two resting worlds.
    assert np.abs(sim.positions - python_world().positions).max() > 1e-4


def test_scene_dict_matches_qbond_run_bit_for_bit(run_cli, tmp_path):
    ck = cli_run(run_cli, tmp_path)
    sim = qbond.Simulation(qbond.Scene.parse(SCENE))
    sim.run(0.06)
    assert np.array_equal(sim.positions, ck["positions"])
    assert np.array_equal(sim.velocities, ck["velocities"])


def test_scene_file_json_text_and_dict_build_the_same_world(tmp_path):
    import json
    path = write_json(tmp_path / "bar.json", SCENE)
    a = qbond.Scene.load(path)
    b = qbond.Scene.parse(json.dumps(SCENE))
    c = qbond.Scene.parse(SCENE)
    assert a.name == b.name == c.name == "bar"
    assert a.steps == 60 and a.timestep == 0.001
    for s in (b, c):
        assert np.array_equal(s.world.positions, a.world.positions)
        assert np.array_equal(s.world.bond_ends, a.world.bond_ends)
    assert a.integrator["type"] == qbond.Simulation(a).integrator["type"] == "coupled_implicit"
