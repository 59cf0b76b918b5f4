"""Builders of irregular bodies from Python: meshes (OBJ, STL) voxelised, point packings, FCC
lattices, gases and placement build the worlds the same scenes build, and step to `qbond run`'s bits."""
import math
import os

import numpy as np
import pytest

import qbond
from conftest import SOURCE_DIR, write_json

MESHES = os.path.join(SOURCE_DIR, "scenes", "meshes")


def same_world(a, b):
    assert a.num_quanta == b.num_quanta and a.num_bonds == b.num_bonds
    assert np.array_equal(a.positions, b.positions)
    assert np.array_equal(a.velocities, b.velocities)
    assert np.array_equal(a.masses, b.masses)
    assert np.array_equal(a.bond_ends, b.bond_ends)


TORUS = {
    "name": "torus", "timestep": 2e-4, "steps": 40, "gravity": [0, 0, -9.81],
    "materials": {"rubber": {"law": "linear", "stiffness": 5000, "damping": 1}},
    "bodies": [{"name": "torus", "type": "mesh", "file": os.path.join(MESHES, "torus.obj"), "scale": 0.001,
                "spacing": 0.005, "neighbors": "face_diagonal", "material": "rubber", "quanta_mass": 0.002,
                "origin": [0, 0, 0.12], "rotation": {"axis": [1, 0, 0], "angle": 0.6}, "velocity": [0, 0, -1]}],
    "output": {"vtk": False},
}


def torus_world():
    w = qbond.World()
    w.gravity = (0, 0, -9.81)
    b = w.add_body("torus")
    ids = w.add_mesh(os.path.join(MESHES, "torus.obj"), spacing=0.005, quanta_mass=0.002, stiffness=5000,
                     damping=1, shells="face_diagonal", scale=0.001, body=b)
    w.place(ids, origin=(0, 0, 0.12), axis=(1, 0, 0), angle=0.6, velocity=(0, 0, -1))
    w.renumber_for_locality()
    return w


def test_obj_mesh_builds_the_scene_world_and_steps_to_qbond_run_bits(run_cli, tmp_path):
    w = torus_world()
    assert w.num_quanta > 100  # a real body, not a handful of sites
    same_world(w, qbond.Scene.parse(TORUS).world)
    out = tmp_path / "out"
    r = run_cli("run", write_json(tmp_path / "torus.json", TORUS), "--out", str(out))
    assert r.returncode == 0, r.stderr
    ck = qbond.read_checkpoint(str(out / "checkpoint.qbc"))
    sim = qbond.Simulation(w, 2e-4)
    sim.step(40)
    assert np.array_equal(sim.positions, ck["positions"])
    assert np.array_equal(sim.velocities, ck["velocities"])


def test_stl_mesh_builds_the_scene_world():
    doc = {"timestep": 1e-3, "steps": 1,
           "materials": {"m": {"law": "linear", "stiffness": 100}},
           "bodies": [{"name": "blob", "type": "mesh", "file": os.path.join(MESHES, "blob.stl"), "spacing": 0.005,
                       "neighbors": "nearest", "material": "m", "quanta_mass": 0.001}]}
    w = qbond.World()
    w.add_body("blob")
    ids = w.add_mesh(os.path.join(MESHES, "blob.stl"), spacing=0.005, quanta_mass=0.001, stiffness=100,
                     shells="nearest")
    assert len(ids) == w.num_quanta > 10
    # Nearest shell only: every bond is one spacing long.
    ends = w.bond_ends
    lengths = np.linalg.norm(w.positions[ends[:, 0]] - w.positions[ends[:, 1]], axis=1)
    assert np.allclose(lengths, 0.005, rtol=1e-12)
    w.renumber_for_locality()
    same_world(w, qbond.Scene.parse(doc).world)


def test_a_broken_mesh_raises_with_file_and_line(tmp_path):
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n")
    with pytest.raises(RuntimeError, match=r"bad\.obj:4: "):
        qbond.World().add_mesh(str(bad), spacing=0.1, quanta_mass=1e-3, stiffness=1)
    open_mesh = tmp_path / "open.obj"
    open_mesh.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(RuntimeError, match="open.obj"):
        qbond.World().add_mesh(str(open_mesh), spacing=0.1, quanta_mass=1e-3, stiffness=1)
    with pytest.raises(ValueError, match="isolated: must be one of drop, keep, error"):
        qbond.World().add_mesh(os.path.join(MESHES, "torus.obj"), spacing=5, quanta_mass=1e-3, stiffness=1,
                               isolated="lose")


PACKING = {"seed": 12, "timestep": 5e-4, "steps": 1,
           "materials": {"bond": {"law": "linear", "stiffness": 3000, "damping": 0.2}},
           "bodies": [{"name": "asymmetric", "type": "packing", "points": "poisson", "size": [0.12, 0.03, 0.03],
                       "min_distance": 0.008, "bond_radius": 0.014, "quanta_mass": 0.001, "material": "bond",
                       "origin": [0, 0.08, 0]}]}


def test_poisson_packing_builds_the_scene_world():
    w = qbond.World()
    w.add_body("asymmetric")
    ids = w.add_point_packing((0.12, 0.03, 0.03), min_distance=0.008, bond_radius=0.014, quanta_mass=0.001,
                              stiffness=3000, damping=0.2, seed=12)
    w.place(ids, origin=(0, 0.08, 0))
    x = w.positions
    # Poisson-disk: no two points closer than min_distance; every bond within the radius.
    d = np.linalg.norm(x[:, None, :] - x[None, :, :], axis=2) + np.eye(len(x))
    assert d.min() >= 0.008
    ends = w.bond_ends
    lengths = np.linalg.norm(x[ends[:, 0]] - x[ends[:, 1]], axis=1)
    assert lengths.max() <= 0.014
    assert len(ends) == np.count_nonzero(np.triu(d <= 0.014, 1))  # every pair within the radius, once
    w.renumber_for_locality()
    same_world(w, qbond.Scene.parse(PACKING).world)


def test_packings_are_deterministic_for_a_seed():
    def points(seed, kind="random"):
        w = qbond.World()
        w.add_point_packing((0.1, 0.1, 0), min_distance=0.005, bond_radius=0.03, quanta_mass=1e-3, stiffness=1,
                            points=kind, count=40, seed=seed, isolated="keep")
        return w.positions
    assert np.array_equal(points(3), points(3))
    assert not np.array_equal(points(3), points(4))
    p = points(3)
    assert p.shape == (40, 3) and np.all(p[:, 2] == 0)  # flat: size z = 0
    with pytest.raises(ValueError, match="points: must be poisson or random"):
        points(3, kind="hexagonal")


def test_fcc_lattice_builds_the_scene_world_with_bonds_a_over_root_two():
    doc = {"timestep": 1e-3, "steps": 1, "materials": {"m": {"law": "linear", "stiffness": 10}},
           "bodies": [{"name": "fcc", "type": "lattice", "cell": "fcc", "neighbors": "nearest", "size": [2, 2, 2],
                       "spacing": 0.01, "quanta_mass": 0.001, "material": "m"}]}
    w = qbond.World()
    w.add_body("fcc")
    w.add_fcc_lattice((2, 2, 2), spacing=0.01, quanta_mass=0.001, stiffness=10)
    # Corners (n+1)³ and face centres 3 n² (n+1) of n = 2 cells a side.
    assert w.num_quanta == 27 + 36
    ends = w.bond_ends
    lengths = np.linalg.norm(w.positions[ends[:, 0]] - w.positions[ends[:, 1]], axis=1)
    assert np.allclose(lengths, 0.01 / math.sqrt(2), rtol=1e-12)
    w.renumber_for_locality()
    same_world(w, qbond.Scene.parse(doc).world)


def test_gas_has_exactly_its_temperature_and_no_momentum():
    w = qbond.World()
    ids = w.add_gas((0.1, 0.1, 0.1), count=200, min_distance=0.004, quanta_mass=2e-3, kT=1e-3, seed=5)
    assert len(ids) == 200 and w.num_bonds == 0
    v, m = w.velocities, w.masses
    kinetic = 0.5 * np.sum(m[:, None] * v * v)
    assert kinetic == pytest.approx(1.5 * 200 * 1e-3, rel=1e-12)
    assert np.abs((m[:, None] * v).sum(axis=0)).max() < 1e-15
    with pytest.raises(ValueError):
        qbond.World().add_gas((0.01, 0.01, 0.01), count=1000, min_distance=0.005, quanta_mass=1e-3, kT=1e-3)


def test_place_rotates_rigidly_and_sets_the_rigid_velocity_field():
    w = qbond.World()
    ids = w.add_cubic_lattice((3, 2, 2), spacing=0.01, quanta_mass=1e-3, stiffness=10)
    before = w.positions
    w.place(ids, origin=(1, 2, 3), axis=(0, 0, 2), angle=math.pi / 2, angular_velocity=(0, 0, 1))
    after = w.positions
    rot = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    assert np.allclose(after, before @ rot.T + [1, 2, 3], atol=1e-15)
    cm = after.mean(axis=0)
    # x − x_cm of positions near 1 m: a few ulps of 1 m apart from the library's own sum.
    assert np.allclose(w.velocities, np.cross([0, 0, 1], after - cm), rtol=0, atol=1e-14)
    with pytest.raises(ValueError, match="axis: must be non-zero"):
        w.place(ids, axis=(0, 0, 0))
