"""The set-up report: what a scene becomes once seeded, which its file does not show.

Each body's extent as its particles fill it (an outline snaps to the particle
lattice), the gap between every two bodies that start apart and when they
meet at their initial speeds (or that they touch from the start), what sets
the time step, and warnings where
the run will not do what the scene seems to ask (snapshots after its end,
bodies that meet only after it).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING

import numpy as np

from . import seeding, stability
from .units import UnitSystem

if TYPE_CHECKING:
    from .scene import Scene

__all__ = ["Extent", "Gap", "SetupReport", "setup_report", "snapshot_warnings"]

_TOL = 1e-9
"""Lengths below this fraction of a spacing are round-off: bodies that close
to touch, corners that close to their shape's."""


@dataclass(frozen=True)
class Extent:
    """Where a body's seeded material lies.

    Attributes
    ----------
    body, material : str
        Its name and its material's.
    particles : int
    spacing : float
        Its particle spacing ``h / particles_per_cell``.
    lo, hi : tuple of float
        The lower-left and upper-right corners of its particles' bounding box
        widened by half a spacing: each particle stands for a square (a cube
        in 3D) of side ``spacing``, so this is the box of the material the run has.
    shape : tuple of float
        The bounds of its shape as declared, ``(xmin, ymin, xmax, ymax)``
        (``(xmin, ymin, zmin, xmax, ymax, zmax)`` in 3D).
    """

    body: str
    material: str
    particles: int
    spacing: float
    lo: tuple[float, float]
    hi: tuple[float, float]
    shape: tuple[float, float, float, float]


@dataclass(frozen=True)
class Gap:
    """Two bodies that start apart.

    Attributes
    ----------
    bodies : (str, str)
    gap : float
        The narrowest gap between their seeded material: the shortest
        distance between a square that a particle of one stands for and a
        square of the other (squares of side ``spacing``, centred on the
        particles).
    closing_speed : float
        The initial relative velocity of the two particles across that gap,
        along it: > 0 where they approach.
    meet : float or None
        ``gap / closing_speed``: when they meet at their initial speeds
        (without the forces on them); ``None`` if they do not approach.
    """

    bodies: tuple[str, str]
    gap: float
    closing_speed: float
    meet: float | None


@dataclass(frozen=True)
class SetupReport:
    """The set-up report of a scene (:func:`setup_report`).

    Attributes
    ----------
    extents : list of Extent
        One per body, in order.
    gaps : list of Gap
        Every two bodies whose material starts apart, in body order.
    touching : list of (str, str)
        Every two bodies whose material touches or overlaps at t = 0 (a
        shape's outline may lie apart from another's and its particles'
        squares still touch), in body order.
    step : pfmpm.scene.stability.StepLimit
        The stability limit and the bodies that set it.
    dt : float
        The time step: ``time.dt`` if the scene fixes it, else the limit.
    end : float
        The time the run ends: its steps times ``dt``.
    warnings : list of str
        One line each.
    units : pfmpm.scene.units.UnitSystem
    """

    extents: list[Extent]
    gaps: list[Gap]
    touching: list[tuple[str, str]]
    step: stability.StepLimit
    dt: float
    end: float
    warnings: list[str]
    units: UnitSystem

    def lines(self) -> list[str]:
        """The report as lines of text, warnings apart."""
        length, speed, time = (_unit(self.units, u) for u in ("length", "speed", "time"))
        lines = []
        for e in self.extents:
            tol = _TOL * e.spacing
            line = (f"body {e.body} ({e.material}): {e.particles} particles {e.spacing:g}{length} apart,"
                    f" from {_point(e.lo, tol)} to {_point(e.hi, tol)}{length}")
            if not np.allclose((*e.lo, *e.hi), e.shape, rtol=0, atol=tol):
                dim = len(e.lo)
                line += f"; its shape spans {_point(e.shape[:dim], tol)} to {_point(e.shape[dim:], tol)}"
            lines.append(line)
        for g in self.gaps:
            a, b = g.bodies
            if g.meet is None:
                lines.append(f"bodies {a} and {b}: {g.gap:.6g}{length} apart, not approaching")
            else:
                lines.append(f"bodies {a} and {b}: {g.gap:.6g}{length} apart, approaching at"
                             f" {g.closing_speed:.6g}{speed}: they meet at t = {g.meet:.6g}{time}")
        lines += [f"bodies {a} and {b}: touching at t = 0" for a, b in self.touching]
        s = self.step
        limit = (f"dt = {s.limit:.6g}{time} = cfl {s.cfl:g} x kappa {s.kappa:g} x h {s.h:g}{length} /"
                 f" (P-wave speed {s.wave_speed:.6g}{speed} of body {s.wave_body}"
                 f" ({self._material(s.wave_body)}) + speed {s.speed:.6g}{speed}"
                 + (f" of body {s.speed_body})" if s.speed_body else ")"))
        if s.lone:
            limit += "; kappa: a particle alone on its nodes (a body's corner), below the grid's"
        elif s.side_body is not None:
            limit += f"; kappa < 1: body {s.side_body} starts within grid.degree cells of a grid side"
        if self.dt == s.limit:
            lines.append(f"time step {limit}")
        else:
            lines.append(f"time step dt = {self.dt:.6g}{time} (time.dt), {100 * self.dt / s.limit:.3g} %"
                         f" of the default step {limit}")
        return lines

    def to_dict(self) -> dict:
        """The report as plain values (for ``summary.json``)."""
        return {"extents": [asdict(e) for e in self.extents], "gaps": [asdict(g) for g in self.gaps],
                "touching": [list(pair) for pair in self.touching], "step": asdict(self.step),
                "dt": self.dt, "end": self.end, "warnings": list(self.warnings)}

    def _material(self, body: str) -> str:
        return next(e.material for e in self.extents if e.body == body)


def setup_report(scene: "Scene") -> SetupReport:
    """The set-up report of ``scene``: its seeding (:mod:`~pfmpm.scene.seeding`)
    looked at body by body, and its stability limit."""
    from scipy.spatial import cKDTree

    h, end = scene.grid.h, scene.steps() * scene.dt()
    length, time = (_unit(scene.unit_system(), u) for u in ("length", "time"))
    xs = seeding.positions(scene)
    extents = []
    for body, x in zip(scene.bodies, xs):
        spacing = body.spacing(h)
        extents.append(Extent(body=body.name, material=body.material, particles=len(x), spacing=spacing,
                              lo=tuple((x.min(axis=0) - 0.5 * spacing).tolist()),
                              hi=tuple((x.max(axis=0) + 0.5 * spacing).tolist()),
                              shape=tuple(body.shape.bounds())))
    gaps, touching, warnings = [], [], []
    for a, first in enumerate(scene.bodies):
        tree = cKDTree(xs[a]) if a < len(scene.bodies) - 1 else None
        for b in range(a + 1, len(scene.bodies)):
            second = scene.bodies[b]
            gap, ia, ib, across = _narrowest(tree, xs[b], 0.5 * (first.spacing(h) + second.spacing(h)))
            if gap <= _TOL * h:  # touching (to round-off) or overlapping
                touching.append((first.name, second.name))
                continue
            pa, pb = xs[a][ia], xs[b][ib]
            closing = -float(np.dot(_velocity(second, pb) - _velocity(first, pa), across)) / gap
            meet = gap / closing if closing > 0 else None
            gaps.append(Gap(bodies=(first.name, second.name), gap=gap, closing_speed=closing, meet=meet))
            if meet is not None and meet > end:
                warnings.append(f"bodies {first.name} and {second.name} are {gap:.6g}{length} apart and meet"
                                f" at t = {meet:.6g}{time} at their initial speeds, after the run ends"
                                f" (t = {end:.6g}{time})")
    warnings += _idle_regions(scene, np.concatenate(xs), length)
    warnings += snapshot_warnings(scene)
    return SetupReport(extents=extents, gaps=gaps, touching=touching, step=stability.step_limit(scene),
                       dt=scene.dt(), end=end, warnings=warnings, units=scene.unit_system())


def _idle_regions(scene: "Scene", x: np.ndarray, length: str) -> list[str]:
    """A warning for each prescribed box whose nodes reach no particle at
    t = 0: none lies within it widened by the reach of a node's basis
    function, (degree + 1) h / 2, so it moves nothing until material comes.
    A region of a body's particles holds them by construction."""
    reach = 0.5 * (scene.grid.degree + 1) * scene.grid.h
    warnings = []
    for region in scene.prescribed:
        if region.min is None:
            continue
        lo, hi = np.subtract(region.min, reach), np.add(region.max, reach)
        if not np.any(np.all((x > lo) & (x < hi), axis=1)):
            warnings.append(f"prescribed region {region.name} reaches no particle at t = 0 (none within"
                            f" {reach:.6g}{length} of its box, its nodes' reach): it moves nothing until"
                            " material comes within it")
    return warnings


def _narrowest(tree, xb: np.ndarray, reach: float) -> tuple[float, int, int, np.ndarray]:
    """The narrowest gap between the squares of half side sum ``reach`` about
    the points of ``tree`` and those about ``xb``: its width, the two points
    and the vector across it (from the first to the second).

    A pair of centres ``d`` apart has squares (cubes in 3D) ``|g|`` apart
    with ``g_i = sign(d_i) max(|d_i| - reach, 0)``, between ``|d| - sqrt(dim)
    reach`` and ``|d| - reach``; so only pairs within ``sqrt(dim) - 1``
    reaches of the nearest centres can be narrowest."""
    from scipy.spatial import cKDTree

    distance, _ = tree.query(xb)
    within = distance.min() + (np.sqrt(float(xb.shape[1])) - 1.0) * reach
    close = np.flatnonzero(distance <= within)
    pairs = cKDTree(xb[close]).sparse_distance_matrix(tree, within, output_type="ndarray")
    ib, ia = close[pairs["i"]], pairs["j"]
    d = xb[ib] - tree.data[ia]
    across = np.sign(d) * np.maximum(np.abs(d) - reach, 0.0)
    width = np.hypot.reduce(across, axis=1)
    k = int(np.argmin(width))
    return float(width[k]), int(ia[k]), int(ib[k]), across[k]


def _point(p, tol: float) -> str:
    """``(x, y)`` (or ``(x, y, z)``), each to 6 digits, round-off about 0 written as 0."""
    return "(" + ", ".join(f"{0.0 if abs(v) < tol else v:.6g}" for v in p) + ")"


def _unit(units, quantity: str) -> str:
    """`` <unit>`` of a quantity in declared units, else nothing."""
    return f" {getattr(units, quantity)}" if units.declared else ""


def _velocity(body, x: np.ndarray) -> np.ndarray:
    """A body's initial velocity at ``x``, as :func:`~pfmpm.scene.seeding.fill` gives it."""
    return np.asarray(body.velocity) + np.asarray(body.velocity_gradient) @ x


def snapshot_warnings(scene: "Scene") -> list[str]:
    """A warning for the ``output.snapshots`` times after the run's end (its
    steps times ``dt``, within half a step): their phase-field panels would
    all show its last state."""
    dt = scene.dt()
    end = scene.steps() * dt
    late = [t for t in scene.output.snapshots if t > end + 0.5 * dt]
    if not late:
        return []
    time = _unit(scene.unit_system(), "time")
    return [f"output.snapshots = {', '.join(f'{t:g}' for t in late)}: after the run ends"
            f" (t = {end:.6g}{time}), so their panels show its last state"]
