"""qbond: a quanta-bond physics engine (point masses, bonds, implicit integrators).

Load a scene and step it::

    import qbond
    sim = qbond.Simulation(qbond.Scene.load("scenes/cube_drop.json"))
    sim.run(0.5)
    print(sim.positions.mean(axis=0), sim.energies())
"""
from ._core import (  # noqa: F401
    BlowupError,
    CheckpointError,
    Scene,
    SceneError,
    Simulation,
    World,
    __version__,
    read_checkpoint,
    version,
)

__all__ = [
    "BlowupError",
    "CheckpointError",
    "Scene",
    "SceneError",
    "Simulation",
    "World",
    "__version__",
    "read_checkpoint",
    "version",
]
