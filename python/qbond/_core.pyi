"""Type stubs of qbond's compiled module (python/*.cpp): what an editor completes and documents."""
from typing import Any, Callable, Optional, Sequence, Tuple, overload

import numpy as np
import numpy.typing as npt

__version__: str

def version() -> str:
    """The version of the qbond library linked in."""

class SceneError(ValueError):
    """A scene that breaks a rule: str(e) is 'SOURCE: PATH: RULE'."""
    path: str
    """The JSON path, e.g. 'bodies[2].spacing' (empty for the document itself)."""
    rule: str
    """The rule broken."""

class CheckpointError(RuntimeError):
    """A checkpoint that cannot be read: not one, another version, truncated or corrupted."""

class BlowupError(RuntimeError):
    """A step that blew up; the world keeps the last good state."""

Vec3Like = Sequence[float] | npt.ArrayLike
IndicesLike = Sequence[int] | npt.ArrayLike

class World:
    """Quanta (point masses) and the bonds between them, with gravity, loads and anchors."""
    def __init__(self) -> None: ...
    @property
    def num_quanta(self) -> int: ...
    @property
    def num_bonds(self) -> int: ...
    gravity: Tuple[float, float, float]
    """Gravitational acceleration [m/s²]."""
    def add_body(self, name: str) -> int:
        """Adds a named body; returns its id."""
    def add_quanta(self, x: Vec3Like, v: Vec3Like = (0, 0, 0), mass: float = 1e-3, body: int = 0,
                   volume: float = 0.0) -> int:
        """Adds a quanta at x [m] with velocity v [m/s] and mass [kg] (0: kinematic); returns its index."""
    def add_bond(self, i: int, j: int, stiffness: float, law: str = "linear", damping: float = 0.0,
                 damping_model: str = "axial", rest_length: float = -1.0,
                 shape: Optional[Sequence[float]] = None) -> int:
        """Bonds quanta i and j (law: linear, inverse, morse, fene, cohesive); rest_length < 0: their distance."""
    def add_cubic_lattice(self, size: Sequence[int], spacing: float, quanta_mass: float, stiffness: float,
                          damping: float = 0.0, law: str = "linear", shells: str = "face_diagonal",
                          origin: Vec3Like = (0, 0, 0), velocity: Vec3Like = (0, 0, 0),
                          body: int = 0) -> npt.NDArray[np.int64]:
        """Adds a simple-cubic block (x fastest), shells nearest/face_diagonal/body_diagonal; returns its quanta."""
    def add_chain(self, count: int, start: Vec3Like, end: Vec3Like, quanta_mass: float, stiffness: float,
                  damping: float = 0.0, law: str = "linear", velocity: Vec3Like = (0, 0, 0),
                  body: int = 0) -> npt.NDArray[np.int64]:
        """Adds a straight chain of `count` quanta from start to end; returns their indices."""
    def add_square_lattice(self, size: Sequence[int], spacing: float, quanta_mass: float, stiffness: float,
                           damping: float = 0.0, diagonals: bool = True, bending: bool = False,
                           body: int = 0) -> npt.NDArray[np.int64]:
        """Adds a square sheet in the xy plane (x fastest); returns its quanta."""
    def add_fcc_lattice(self, cells: Sequence[int], spacing: float, quanta_mass: float, stiffness: float,
                        damping: float = 0.0, law: str = "linear", second_shell: bool = False,
                        body: int = 0) -> npt.NDArray[np.int64]:
        """Adds a face-centred cubic block of cubic cells of side `spacing`; returns its quanta."""
    def add_point_packing(self, size: Vec3Like, min_distance: float, bond_radius: float, quanta_mass: float,
                          stiffness: float, damping: float = 0.0, law: str = "linear", points: str = "poisson",
                          count: int = 0, seed: int = 1, isolated: str = "drop",
                          body: int = 0) -> npt.NDArray[np.int64]:
        """Adds Poisson-disk or random points in [0, size] bonded within bond_radius; returns its quanta."""
    def add_mesh(self, file: str, spacing: float, quanta_mass: float, stiffness: float, damping: float = 0.0,
                 law: str = "linear", shells: str = "face_diagonal", scale: float = 1.0, isolated: str = "drop",
                 body: int = 0) -> npt.NDArray[np.int64]:
        """Fills a closed OBJ or STL mesh (coordinates × scale [m]) with a simple-cubic lattice; returns its quanta."""
    def add_gas(self, size: Vec3Like, count: int, min_distance: float, quanta_mass: float, kT: float,
                speeds: str = "maxwell", seed: int = 1, body: int = 0) -> npt.NDArray[np.int64]:
        """Adds unbonded quanta in [0, size] with kinetic energy exactly 3/2 count kT [J]; returns them."""
    def place(self, quanta: IndicesLike, origin: Vec3Like = (0, 0, 0), axis: Vec3Like = (0, 0, 1),
              angle: float = 0.0, velocity: Vec3Like = (0, 0, 0), angular_velocity: Vec3Like = (0, 0, 0)) -> None:
        """Rotates (angle [rad] about axis) and translates a body built at the origin; sets its rigid velocity."""
    def prescribe(self, quanta: IndicesLike, motion: str = "fixed", velocity: Vec3Like = (0, 0, 0),
                  axis: Vec3Like = (0, 0, 1), center: Vec3Like = (0, 0, 0), rate: float = 0.0,
                  keyframes: Sequence[Any] = (), interpolation: str = "linear") -> None:
        """Makes the quanta follow a motion: fixed, translate, rotate or keyframes ((time, offset[, angle]) or dicts)."""
    def select_box(self, lo: Vec3Like, hi: Vec3Like) -> npt.NDArray[np.int64]:
        """Indices of the quanta inside the box [lo, hi]."""
    def anchor(self, quanta: IndicesLike) -> None:
        """Holds the quanta fixed where they are."""
    def add_load(self, quanta: IndicesLike, force: Vec3Like) -> None:
        """Adds a constant total force [N] spread evenly over the quanta."""
    def renumber_for_locality(self) -> None:
        """Renumbers quanta and bonds for memory locality, as scene loading does."""
    @property
    def positions(self) -> npt.NDArray[np.float64]:
        """(n, 3) positions [m] (a copy)."""
    @property
    def velocities(self) -> npt.NDArray[np.float64]:
        """(n, 3) velocities [m/s] (a copy)."""
    @property
    def masses(self) -> npt.NDArray[np.float64]:
        """(n,) masses [kg] (a copy)."""
    @property
    def bond_ends(self) -> npt.NDArray[np.int64]:
        """(nb, 2) end quanta of every bond (a copy)."""

class Scene:
    """A loaded scene: its world built, the step, integrator and heuristics it asks for."""
    @staticmethod
    def load(path: str) -> "Scene":
        """Loads a scene file. Raises SceneError."""
    @staticmethod
    def parse(doc: str | dict[str, Any], source: str = "<string>") -> "Scene":
        """Parses a scene from JSON text or a dict. Raises SceneError."""
    @property
    def name(self) -> str: ...
    @property
    def description(self) -> str: ...
    @property
    def seed(self) -> int: ...
    @property
    def timestep(self) -> float:
        """[s]"""
    @property
    def steps(self) -> int: ...
    @property
    def resolved(self) -> dict[str, Any]:
        """The scene with every default filled in."""
    @property
    def integrator(self) -> dict[str, Any]:
        """The integrator and its options."""
    @property
    def world(self) -> World:
        """A copy of the scene's world."""
    @property
    def adaptive(self) -> Optional[dict[str, Any]]:
        """The scene's adaptive step control (None when its steps are fixed)."""

def read_checkpoint(path: str) -> dict[str, Any]:
    """A checkpoint's metadata, step, time, positions and velocities. Raises CheckpointError."""

class Simulation:
    """A world stepped by an integrator. Array properties are views valid until the next step."""
    @overload
    def __init__(self, scene: Scene) -> None:
        """Steps a scene as `qbond run` does: its world, step, integrator, heuristics and limits."""
    @overload
    def __init__(self, world: World, timestep: float, integrator: Optional[str] = None, **options: Any) -> None:
        """Steps a copy of `world`; options as keywords (neighbours, solver, iterations, tolerance, threads, ...)."""
    def step(self, n: int = 1) -> None:
        """Takes n steps without the GIL. Raises BlowupError."""
    def run(self, duration: float) -> None:
        """Steps for ceil(duration / timestep) steps."""
    @property
    def time(self) -> float: ...
    @property
    def step_count(self) -> int: ...
    timestep: float
    def set_adaptive(self, enabled: bool = True, **options: float) -> None:
        """Adaptive step control on or off; options error, energy, min_step, max_step, safety, horizon."""
    @property
    def adaptive(self) -> dict[str, Any]:
        """The adaptive step control's settings (enabled: whether steps adapt)."""
    end_time: float
    """[s] where adaptive steps stop: a scene's horizon, else infinity."""
    @property
    def last_step_size(self) -> float:
        """[s] the step that led to the current state."""
    @property
    def rejected_steps(self) -> int:
        """Adaptive tries undone so far."""
    @property
    def num_quanta(self) -> int: ...
    @property
    def num_bonds(self) -> int: ...
    @property
    def world(self) -> World:
        """A copy of the world."""
    def set_integrator(self, type: Optional[str] = None, **options: Any) -> None:
        """Changes the integrator and/or its options."""
    @property
    def integrator(self) -> dict[str, Any]: ...
    @property
    def positions(self) -> npt.NDArray[np.float64]:
        """(n, 3) positions [m], read-only view."""
    @property
    def velocities(self) -> npt.NDArray[np.float64]:
        """(n, 3) velocities [m/s], writable view."""
    @property
    def masses(self) -> npt.NDArray[np.float64]: ...
    @property
    def inverse_masses(self) -> npt.NDArray[np.float64]: ...
    @property
    def quanta_id(self) -> npt.NDArray[np.uint32]: ...
    @property
    def external_forces(self) -> npt.NDArray[np.float64]:
        """(n, 3) forces [N] added at every step until changed, writable view."""
    @property
    def bond_forces(self) -> npt.NDArray[np.float64]: ...
    @property
    def bond_ends(self) -> npt.NDArray[np.int64]: ...
    @property
    def bond_alive(self) -> npt.NDArray[np.bool_]: ...
    @property
    def bond_rest_lengths(self) -> npt.NDArray[np.float64]: ...
    def bond_tension_strain(self) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def set_force_callback(
        self, fn: Optional[Callable[[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]], None]]
    ) -> None:
        """fn(x, v, f) before every step fills f [N] for that step; None removes it."""
    track_energy: bool
    """Whether each step updates the energy ledger and checks it for a runaway."""
    keep_last_good: bool
    """Whether each step keeps a copy of the state to roll an energy runaway back to."""
    def add_heuristic(
        self, fn: Callable[[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]], None]
    ) -> None:
        """fn(x, dx, dv) between each step's projection and its application edits the writable dx, dv."""
    def add_break_rule(self, max_strain: float = ..., max_compression: float = ..., max_tension: float = ...,
                       probability: float = 1.0, quanta: Optional[IndicesLike] = None) -> None:
        """Adds a fracture rule: bonds past a strain or tension [N] break (with `probability` per step)."""
    def clear_heuristics(self) -> None:
        """Removes every heuristic (the scene's and the Python ones)."""
    def prescribe(self, quanta: IndicesLike, motion: str = "fixed", velocity: Vec3Like = (0, 0, 0),
                  axis: Vec3Like = (0, 0, 1), center: Vec3Like = (0, 0, 0), rate: float = 0.0,
                  keyframes: Sequence[Any] = (), interpolation: str = "linear") -> None:
        """World.prescribe between steps: the motion starts now, from where the quanta are."""
    def add_probe(self, name: str, quanta: IndicesLike, about: Optional[Vec3Like] = None) -> None:
        """Adds a named probe measured by probes()."""
    def probes(self) -> dict[str, dict[str, Any]]:
        """name → mean [m]; force [N], torque [N·m] (kinematic quanta); stress [Pa], von_mises_max [Pa]."""
    def probe(self, quanta: IndicesLike, about: Optional[Vec3Like] = None) -> dict[str, Any]:
        """Measures the quanta once, as probes() does."""
    def energies(self) -> dict[str, float]: ...
    def ledger(self) -> dict[str, float]: ...
    def save_checkpoint(self, path: str) -> None: ...
    def restore_checkpoint(self, path: str) -> None: ...
    def state_bytes(self) -> bytes: ...
    def set_state_bytes(self, state: bytes) -> None: ...
