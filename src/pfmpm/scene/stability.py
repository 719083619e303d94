"""The explicit step's stability limit: wave speeds, the stable ``dt`` and the
critical length the core checks after every step (docs/method.md, "Time step")."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from .bodies import Body
from .seeding import cell_range
from .validation import WHOLE_TOL

if TYPE_CHECKING:
    from .scene import Scene

__all__ = ["CRITICAL_FACTOR", "LONE_PARTICLE_FACTOR", "CRITICAL_FACTOR_3D", "LONE_PARTICLE_FACTOR_3D",
           "StepLimit", "step_limit", "stable_dt", "grid_dt", "critical_length", "steps"]

#: Critical time step of the lumped-mass B-spline grid in units of h / c, per
#: degree, as (bodies clear of the grid sides, bodies on a side). Each is the
#: 1D limit 2 / sqrt(max eig(M_L^-1 K)) of a grid filled with particles, of
#: interior functions only, or of all functions including the open-knot end
#: ones (degree 2: 1.634 and 0.862; degree 3: 1.929 and 0.653; degree 1: 1
#: and 1), over sqrt(2) for two directions and capped at 1, the CFL limit the
#: paper uses (K&T eq. 84). A fixed ``time.dt`` may go up to it.
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

#: :data:`CRITICAL_FACTOR` of a 3D grid: the same 1D limits over sqrt(3) for
#: three directions (capped at 1).
CRITICAL_FACTOR_3D = {1: (0.577, 0.577), 2: (0.943, 0.497), 3: (1.0, 0.377)}

#: :data:`LONE_PARTICLE_FACTOR` of a 3D grid: the largest sum over a lone
#: particle's nodes is three times the 1D one, so 2 / sqrt(18) = 0.471 for
#: degree 2 and 0.652 for degree 3.
LONE_PARTICLE_FACTOR_3D = {2: 0.471, 3: 0.652}

_FACTORS = {2: (CRITICAL_FACTOR, LONE_PARTICLE_FACTOR), 3: (CRITICAL_FACTOR_3D, LONE_PARTICLE_FACTOR_3D)}
"""The grid's and a lone particle's factors by the scene's dimension."""


@dataclass(frozen=True)
class StepLimit:
    """The stability limit ``cfl * kappa * h / (c_max + v_max)`` and what sets it.

    Attributes
    ----------
    limit : float
        The stable step.
    cfl, kappa, h : float
        ``time.cfl``, the critical factor (the smaller of :data:`CRITICAL_FACTOR`
        and :data:`LONE_PARTICLE_FACTOR`) and the grid spacing.
    wave_speed : float
        ``c_max``, the largest P-wave speed of a body's material.
    wave_body : str
        The first body whose material has it.
    speed : float
        ``v_max``, the largest initial particle speed.
    speed_body : str or None
        The first body that has it; ``None`` if every body starts at rest.
    side_body : str or None
        The first body that starts within ``grid.degree`` cells of a grid side,
        which lowers the grid's ``kappa``; ``None`` if none does.
    lone : bool
        Whether ``kappa`` is a lone particle's, below the grid's.
    """

    limit: float
    cfl: float
    kappa: float
    h: float
    wave_speed: float
    wave_body: str
    speed: float
    speed_body: str | None
    side_body: str | None
    lone: bool


def step_limit(scene: "Scene") -> StepLimit:
    """The stability limit of :func:`stable_dt` and the bodies that set it."""
    waves = [scene.material_of(b).wave_speed(scene.plane) for b in scene.bodies]
    speeds = [b.max_speed() for b in scene.bodies]
    c_max, v_max = max(waves), max(speeds)
    grid, side = _kappa(scene)
    kappa = min(grid, _FACTORS[scene.dim][1].get(scene.grid.degree, grid))
    return StepLimit(limit=scene.time.cfl * (kappa * scene.grid.h) / (c_max + v_max), cfl=scene.time.cfl,
                     kappa=kappa, h=scene.grid.h, wave_speed=c_max,
                     wave_body=scene.bodies[waves.index(c_max)].name, speed=v_max,
                     speed_body=scene.bodies[speeds.index(v_max)].name if v_max > 0 else None,
                     side_body=side, lone=kappa < grid)


def stable_dt(scene: "Scene") -> float:
    """The default step ``cfl * kappa * h / (c_max + v_max)`` (K&T eqs. 83-84),
    ``kappa`` the smaller of the grid's factor (:data:`CRITICAL_FACTOR`) and a
    lone particle's (:data:`LONE_PARTICLE_FACTOR`).

    ``c_max`` is the largest wave speed (``MaterialSpec.wave_speed``) over
    the materials of the bodies and ``v_max`` the largest initial particle
    speed. So ``kappa`` is 0.577 for quadratic and 0.798 for cubic B-splines
    with the bodies clear of the grid's end functions (the paper's 1, a grid
    filled with particles, let a Borden plate's corner particle blow up),
    0.707 for degree 1, and 0.461 for cubic B-splines when bodies start within
    ``degree`` cells of a grid side, where the open knot vector's end
    functions carry little lumped mass. A 3D scene takes the 3D tables
    (:data:`CRITICAL_FACTOR_3D`, :data:`LONE_PARTICLE_FACTOR_3D`).
    :func:`step_limit` says which bodies set each.
    """
    return step_limit(scene).limit


def grid_dt(scene: "Scene") -> float:
    """The largest fixed ``time.dt``: :func:`stable_dt` with the grid's
    ``kappa`` alone (:data:`CRITICAL_FACTOR`), pfmpm's default step before
    issue 49 (above :func:`stable_dt` a lone particle may blow up)."""
    limit = step_limit(scene)
    return scene.time.cfl * critical_length(scene) / (limit.wave_speed + limit.speed)


def critical_length(scene: "Scene") -> float:
    """``kappa * h`` of the grid (:data:`CRITICAL_FACTOR`): a step is stable while
    ``dt (c + |v|)`` stays below it, the core's check after every step."""
    return _kappa(scene)[0] * scene.grid.h


def _kappa(scene: "Scene") -> tuple[float, str | None]:
    """``kappa`` of :data:`CRITICAL_FACTOR` (:data:`CRITICAL_FACTOR_3D` in 3D),
    and the first body near a grid side that lowers it (or ``None``)."""
    interior, boundary = _FACTORS[scene.dim][0][scene.grid.degree]
    side = next((b.name for b in scene.bodies if _near_side(scene, b)), None)
    return (boundary if side is not None else interior), side


def _near_side(scene: "Scene", body: Body) -> bool:
    """Whether the body's bounding box reaches the end functions of the grid."""
    p = scene.grid.degree
    return any(a < p or b > n - p for (a, b), n in zip(cell_range(body, scene.grid), scene.grid.cells))


def steps(end: float, dt: float) -> int:
    """Number of steps of ``dt`` to reach ``end`` (round-off tolerant)."""
    n = end / dt
    return max(1, math.ceil(n - WHOLE_TOL * n))
