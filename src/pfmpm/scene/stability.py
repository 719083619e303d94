"""The explicit step's stability limit: wave speeds, the stable ``dt`` and the
critical length the core checks after every step (docs/method.md, "Time step")."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from .bodies import Body
from .seeding import cell_range
from .validation import WHOLE_TOL

if TYPE_CHECKING:
    from .scene import Scene

__all__ = ["CRITICAL_FACTOR", "LONE_PARTICLE_FACTOR", "stable_dt", "grid_dt", "critical_length", "steps"]

#: Critical time step of the lumped-mass B-spline grid in units of h / c, per
#: degree, as (bodies clear of the grid sides, bodies on a side). Each is the
#: 1D limit 2 / sqrt(max eig(M_L^-1 K)) of a grid filled with particles, of
#: interior functions only, or of all functions including the open-knot end
#: ones (degree 2: 1.634 and 0.862; degree 3: 1.929 and 0.653; degree 1: 1
#: and 1), over sqrt(2) for two directions and capped at 1, the CFL limit the
#: paper uses (eq. 84). A fixed ``time.dt`` may go up to it.
#: tests/test_elastic.py recomputes these from the basis.
CRITICAL_FACTOR = {1: (0.707, 0.707), 2: (1.0, 0.609), 3: (1.0, 0.461)}

#: The critical time step of a particle alone on its nodes (a body's corner,
#: a fragment), in units of h / c: whatever the other particles, max
#: eig(M_L^-1 K) <= c^2 max_p sum_I |grad N_I(x_p)|^2 / N_I(x_p), with
#: equality for a lone particle; in 2D the largest sum is twice the 1D one,
#: 6 / h^2 (degree 2) and 3.137 / h^2 (degree 3), at a cell's ends, so
#: 2 / sqrt(12) = 0.577 and 0.798 (unbounded for degree 1: the cell-crossing
#: instability of linear shape functions). The default step keeps below it
#: (docs/method.md, "Time step"). tests/test_elastic.py recomputes these.
LONE_PARTICLE_FACTOR = {2: 0.577, 3: 0.798}


def stable_dt(scene: "Scene") -> float:
    """The default step ``cfl * kappa * h / (c_max + v_max)`` (eqs. 83-84),
    with ``kappa`` the smaller of the grid's factor (:data:`CRITICAL_FACTOR`)
    and a lone particle's (:data:`LONE_PARTICLE_FACTOR`).

    ``c_max`` is the largest wave speed (``MaterialSpec.wave_speed``) over
    the materials used by bodies and ``v_max`` the largest initial particle
    speed. So ``kappa`` is 0.577 for quadratic and 0.798 for cubic B-splines
    with the bodies clear of the grid's end functions (the paper's 1, a grid
    filled with particles, let a Borden plate's corner particle blow up), 0.707
    for degree 1, and 0.461 for cubic B-splines when bodies start within
    ``degree`` cells of a grid side, where the open knot vector's end
    functions carry little lumped mass.
    """
    lone = LONE_PARTICLE_FACTOR.get(scene.grid.degree, math.inf) * scene.grid.h
    return scene.time.cfl * min(critical_length(scene), lone) / _speed(scene)


def grid_dt(scene: "Scene") -> float:
    """The largest fixed ``time.dt``: ``cfl * kappa * h / (c_max + v_max)``
    with the grid's ``kappa`` alone (:data:`CRITICAL_FACTOR`), the default
    step of pfmpm before issue 49 (a lone particle may blow up above
    :func:`stable_dt`)."""
    return scene.time.cfl * critical_length(scene) / _speed(scene)


def _speed(scene: "Scene") -> float:
    """c_max + v_max of :func:`stable_dt`."""
    used = {body.material for body in scene.bodies}
    c_max = max(m.wave_speed(scene.plane) for m in scene.materials if m.name in used)
    v_max = max(body.max_speed() for body in scene.bodies)
    return c_max + v_max


def critical_length(scene: "Scene") -> float:
    """``kappa * h`` of the grid (:data:`CRITICAL_FACTOR`): a step is stable
    while ``dt (c + |v|)`` stays below it, the core's check after every step."""
    interior, boundary = CRITICAL_FACTOR[scene.grid.degree]
    kappa = boundary if any(_near_side(scene, b) for b in scene.bodies) else interior
    return kappa * scene.grid.h


def _near_side(scene: "Scene", body: Body) -> bool:
    """Whether the body's bounding box reaches the end functions of the grid."""
    (i0, i1), (j0, j1) = cell_range(body, scene.grid)
    p, (nx, ny) = scene.grid.degree, scene.grid.cells
    return i0 < p or j0 < p or i1 > nx - p or j1 > ny - p


def steps(end: float, dt: float) -> int:
    """Number of steps of ``dt`` to reach ``end`` (round-off tolerant)."""
    n = end / dt
    return max(1, math.ceil(n - WHOLE_TOL * n))
