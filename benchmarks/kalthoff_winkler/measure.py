"""Kalthoff-Winkler (Homel & Herbold 2017, section 3.2): the crack that leaves
the notch tip, its angle, its tip's speed and whether it branched; checks
K1-K4 of ``shared/benchmarks-homel-herbold.md`` section 4.

A particle has failed when its damage is full (``D >= 1 - 1e-4``, the
damage-gradient partition's own test,
:data:`pfmpm.post.fragments.FULL_DAMAGE`). The crack of the
paper leaves the tip of the notch on the side away from the impacted
ligament (the left of the notch's direction, +y in the half model), so its
angle and its tip are measured among the failed particles on that side;
other cracks show up as extra arms crossing the circles about the tip.
"""

from __future__ import annotations

import math

import numpy as np

from pfmpm.post.arms import crack_arms, propagation_angle
from pfmpm.post.fragments import LINK, failed, linked_sets
from pfmpm.scene import Rectangle, Scene

__all__ = ["BAND_DAMAGE", "ANGLE_RING", "ARM_RADII", "notch_tip", "from_face", "crack_angles",
           "CrackRecord", "run_crack", "speed", "report"]

BAND_DAMAGE = 0.5
"""Damage of the band that joins a crack's failed particles. A crack is a row
of failed particles, often about one per cell and farther apart where its
faces have parted (H&H section 3.3), inside a continuous band of partial
damage: the crack is the failed particles of the band's linked set (at
:data:`~pfmpm.post.fragments.LINK` particle spacings) that reaches the notch tip."""
ANGLE_RING = (5.0, 30.0)
"""Distances (mm) from the notch tip of the failed particles whose line is the crack angle (K1)."""
ARM_RADII = (10.0, 20.0, 30.0)
"""Radii (mm) of the circles about the notch tip whose crossings count the crack's arms (K3)."""


def notch_tip(scene: Scene, body: str = "target") -> tuple[np.ndarray, np.ndarray, float]:
    """(tip, unit direction, half-width) of the notch: the rectangular hole of
    ``body`` that reaches its edge; its tip is the middle of the hole's far
    side, which is ``2 half-width`` long."""
    b = scene.body(body)
    x0, _, x1, _ = b.shape.bounds()
    for hole in b.holes:
        if isinstance(hole, Rectangle):
            (a, lo), (c, hi) = hole.min, hole.max
            if a <= x0 < c:  # from the left edge, pointing +x
                return np.array([c, 0.5 * (lo + hi)]), np.array([1.0, 0.0]), 0.5 * (hi - lo)
            if a < x1 <= c:
                return np.array([a, 0.5 * (lo + hi)]), np.array([-1.0, 0.0]), 0.5 * (hi - lo)
    raise ValueError(f"bodies.{body}: no rectangular hole reaching its left or right edge")


def from_face(x: np.ndarray, tip, direction, half_width: float) -> np.ndarray:
    """Distance of the points ``x`` from the notch's tip face: the segment of
    length ``2 half_width`` across the notch at ``tip``."""
    d = np.asarray(x, dtype=float) - tip
    along = d @ np.asarray(direction)
    across = np.abs(d @ np.array([-direction[1], direction[0]]))
    return np.hypot(along, np.maximum(across - half_width, 0.0))


def _left(x: np.ndarray, tip, direction) -> tuple[np.ndarray, np.ndarray]:
    """Offsets from ``tip`` and which points lie on the left of the notch's line."""
    d = np.asarray(x, dtype=float) - tip
    return d, d @ np.array([-direction[1], direction[0]]) > 0.0


def crack_angles(x: np.ndarray, damage: np.ndarray, tip, direction,
                 ring: tuple[float, float] = ANGLE_RING) -> tuple[float, float]:
    """The direction of the crack that left ``tip``, from the failed particles
    on the left of the notch's line whose distance from it lies in ``ring``:
    (bearing, line), in degrees counter-clockwise from the notch's direction.

    ``bearing`` is their mean direction seen from the tip
    (:func:`~pfmpm.post.arms.propagation_angle`, as for the phase-field
    cracks); ``line`` the principal axis of their positions (a total
    least-squares line, check K1 as the benchmark card words it), pointing
    away from the tip. A crack whose row of failed particles steps sideways
    on its way (en echelon) turns the line more than the bearing. NaN with
    fewer than 3 particles.
    """
    d, left = _left(x, tip, direction)
    r = np.hypot(d[:, 0], d[:, 1])
    mine = failed(damage) & left
    pts = d[mine & (r >= ring[0]) & (r <= ring[1])]
    if len(pts) < 3:
        return math.nan, math.nan
    bearing = propagation_angle(x, np.where(mine, 0.0, 1.0), tip, direction, *ring, 0.5)
    centred = pts - pts.mean(axis=0)
    axis = np.linalg.eigh(centred.T @ centred)[1][:, -1]
    if axis @ pts.mean(axis=0) < 0.0:
        axis = -axis
    turn = math.degrees(math.atan2(direction[1], direction[0]))
    return ((bearing - turn) % 360.0, (math.degrees(math.atan2(axis[1], axis[0])) - turn) % 360.0)


class CrackRecord:
    """The crack from the notch tip, sampled during a run.

    The crack's band is the particles of damage at least :data:`BAND_DAMAGE`
    whose linked set reaches within ``2 h`` of the notch's tip face
    (:func:`from_face`); damage elsewhere
    (spalls) is not part of it. Each :meth:`sample` adds the time, the tip's
    distance from the notch tip (the failed particle of the band on the left
    of the notch's line farthest from it), the number of the band's arms
    crossing each circle of :data:`ARM_RADII` ahead of the notch tip, the
    crack angles (:func:`crack_angles`) and the x momentum. It keeps when each
    particle first failed, the time and distance from the tip face of the
    first failure (``first``), and the time at which the tip first reached
    the outer radius of :data:`ANGLE_RING` with the crack angles then
    (``passed``: the crack's direction before any later crack reaches the ring).

    Parameters
    ----------
    scene : Scene
        A Kalthoff-Winkler scene (the ``target`` body with its notch).
    n : int
        Number of particles.
    """

    def __init__(self, scene: Scene, n: int):
        self.tip, self.direction, self.half_width = notch_tip(scene)
        self.h = scene.grid.h
        self.link = LINK * min(b.spacing(self.h) for b in scene.bodies)
        self.failed_at = np.full(n, math.nan)
        self.first = {"t": math.nan, "distance": math.nan}
        self.passed = {"t": math.nan, "angle": math.nan, "line": math.nan}
        self.rows: list[dict] = []

    def sample(self, t: float, x: np.ndarray, damage: np.ndarray, momentum_x: float) -> None:
        """Record the state at time ``t``."""
        broken = failed(damage)
        self.failed_at[broken & np.isnan(self.failed_at)] = t
        d, left = _left(x, self.tip, self.direction)
        r = np.hypot(d[:, 0], d[:, 1])
        face = from_face(x, self.tip, self.direction, self.half_width)
        idx = np.flatnonzero(broken)
        if len(idx) and math.isnan(self.first["t"]):
            self.first = {"t": t, "distance": float(face[idx].min())}
        band = np.zeros(len(x), dtype=bool)
        if len(idx):
            damaged = np.flatnonzero(np.asarray(damage) >= BAND_DAMAGE)
            labels = linked_sets(x[damaged], self.link)
            band[damaged[np.isin(labels, labels[face[damaged] <= 2.0 * self.h])]] = True
        crack = band & broken & left
        reach = float(r[crack].max()) if np.any(crack) else 0.0
        c = np.where(band & (d @ self.direction > -self.h), 0.0, 1.0)
        arms = [len(crack_arms(x, c, self.tip, radius, self.h, 0.5)) for radius in ARM_RADII]
        bearing, line = crack_angles(x, damage, self.tip, self.direction)
        if reach >= ANGLE_RING[1] and math.isnan(self.passed["t"]):
            self.passed = {"t": t, "angle": bearing, "line": line}
        self.rows.append({"t": t, "tip": reach, "arms": arms, "momentum_x": momentum_x,
                          "angle": bearing, "line": line})


def run_crack(scene: Scene, every: float = 0.5, progress=None) -> dict:
    """Run a Kalthoff-Winkler scene to its end, sampling a :class:`CrackRecord`
    every ``every`` us.

    Returns
    -------
    dict
        ``rows`` (the samples), ``failed_at`` (per particle, the first sample
        time at which it had failed; NaN if never), ``first`` (the first
        failure, :class:`CrackRecord`), ``passed`` (the crack angle when the
        tip passed the ring, :class:`CrackRecord`), ``x`` and ``damage`` at
        the end, ``body``, ``mass``, ``momentum_x0``, ``contact``
        (:meth:`~pfmpm.simulation.Simulation.contact_record`) and ``tip``,
        ``direction``, ``half_width`` (the notch, :func:`notch_tip`).
    """
    from pfmpm.simulation import Simulation

    sim = Simulation(scene)
    p = sim.particles
    record = CrackRecord(scene, len(p.x))
    chunk = max(1, int(round(every / sim.dt)))
    steps = scene.steps()
    momentum0 = sim.energies()["momentum_x"]
    record.sample(sim.time, p.x, p.damage, momentum0)
    while sim.step < steps:
        sim.advance(min(chunk, steps - sim.step))
        record.sample(sim.time, p.x, p.damage, sim.energies()["momentum_x"])
        if progress:
            progress(sim.step, steps)
    return {"rows": record.rows, "failed_at": record.failed_at, "first": record.first,
            "passed": record.passed,
            "x": p.x.copy(),
            "damage": p.damage.copy(), "body": p.body.copy(), "mass": p.mass.copy(),
            "momentum_x0": momentum0, "contact": sim.contact_record(),
            "tip": record.tip, "direction": record.direction, "half_width": record.half_width}


def speed(rows: list[dict], window: tuple[float, float]) -> float:
    """Least-squares slope (mm/us = km/s) of the tip's distance over the samples
    in ``window`` (us) where the crack has started; NaN with fewer than 2."""
    t = np.array([r["t"] for r in rows])
    tip = np.array([r["tip"] for r in rows])
    sel = (t >= window[0]) & (t <= window[1]) & (tip > 0.0)
    if np.count_nonzero(sel) < 2:
        return math.nan
    return float(np.polyfit(t[sel], tip[sel], 1)[0])


def report(run: dict, h: float, speed_window: tuple[float, float] = (40.0, 50.0),
           single_until: float = 60.0) -> dict:
    """Checks K1-K4 of a :func:`run_crack` result on a grid of cell side ``h``.

    Returns
    -------
    dict
        ``angle`` and ``line`` (K1: the bearing and the line of
        :func:`crack_angles`, degrees from +x, when the tip passed the outer
        radius of :data:`ANGLE_RING`, at ``angle_time``; ``angle_end`` and
        ``line_end`` at the end, when later cracks may have entered the
        ring), ``speed`` (K2, km/s over
        ``speed_window``), ``initiation`` (K3: the time of the first
        failure and its distance from the notch's tip face;
        ``initiation_near_tip`` whether within ``2 h``), ``single_until`` (K3: the
        last sample time up to which at most one arm crossed every circle of
        :data:`ARM_RADII`), ``arms_end`` (the arms at the end),
        ``single_crack`` (whether that holds to ``single_until``),
        ``momentum_drift`` (K4: the largest change of the x momentum over
        its initial value) and ``tip_end`` (mm from the notch tip).
    """
    rows = run["rows"]
    initiation = run["first"]
    single = 0.0
    for r in rows:
        if max(r["arms"]) > 1:
            break
        single = r["t"]
    p0 = run["momentum_x0"]
    drift = max(abs(r["momentum_x"] - p0) for r in rows) / abs(p0)
    passed = run["passed"]
    return {"angle": passed["angle"], "line": passed["line"], "angle_time": passed["t"],
            "angle_end": rows[-1]["angle"], "line_end": rows[-1]["line"],
            "speed": speed(rows, speed_window),
            "initiation": initiation, "initiation_near_tip": initiation["distance"] <= 2.0 * h,
            "single_until": single, "single_crack": single >= single_until,
            "arms_end": rows[-1]["arms"], "momentum_drift": drift, "tip_end": rows[-1]["tip"]}
