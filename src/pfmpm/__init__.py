"""pfmpm: phase-field material point method for dynamic brittle fracture.

A scene (:mod:`pfmpm.scene`) declares grid, bodies, materials and loads; a
:class:`~pfmpm.simulation.Simulation` sets it up on the C++ core
(:mod:`pfmpm._core`) and runs it.
"""

from ._core import SimulationError
from .scene import Scene, SceneError
from .simulation import Simulation

__all__ = ["Scene", "SceneError", "Simulation", "SimulationError"]
__version__ = "0.1.0"
