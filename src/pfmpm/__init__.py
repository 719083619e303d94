"""pfmpm: phase-field material point method for dynamic brittle fracture.

A scene (:mod:`pfmpm.scene`) declares grid, bodies, materials and loads; a
:class:`~pfmpm.simulation.Simulation` sets it up on the C++ core
(:mod:`pfmpm._core`) and runs it.

OpenMP threads that wait at a barrier spin for a while before they sleep; on
a machine whose cores are busy with other work the spinning thread holds the
core the thread it waits for needs, and two threads ran 4-30 times slower than
one (docs/performance/threads.md). Unless the user chose
a waiting policy (``OMP_WAIT_POLICY`` or ``GOMP_SPINCOUNT``), importing pfmpm
sets ``GOMP_SPINCOUNT`` to :data:`SPIN_COUNT`: a short spin, then sleep. The
OpenMP runtime reads it when it is loaded, so it takes effect when pfmpm is
imported before anything else that loads OpenMP (numpy and scipy do): the
``pfmpm`` command does so; in a notebook, import pfmpm first or set the
variable before starting Python.
"""

import os

SPIN_COUNT = 1000
"""Spins of a waiting OpenMP thread before it sleeps, unless the user set a policy."""
if "OMP_WAIT_POLICY" not in os.environ and "GOMP_SPINCOUNT" not in os.environ:
    os.environ["GOMP_SPINCOUNT"] = str(SPIN_COUNT)

from ._core import SimulationError  # noqa: E402 (after the waiting policy)
from .scene import Scene, SceneError  # noqa: E402
from .simulation import Simulation  # noqa: E402

__all__ = ["Scene", "SceneError", "Simulation", "SimulationError"]
__version__ = "0.1.0"
