"""Which way cracks ran: the direction a crack leaves a notch tip, and the arms
crossing circles about it, against the weak directions of ``G_c(theta)``."""

from __future__ import annotations

import math

import numpy as np

from ..anisotropy import weak_directions
from ..scene import Scene

__all__ = ["ARM_RADII", "HISTORY_RINGS", "propagation_angle", "crack_arms", "new_crack", "notch_tips",
           "crack_directions", "direction_history", "run_directions"]

ARM_RADII = (5, 10, 20, 40)
"""Radii, in l0, of the circles whose crossings :func:`crack_directions` reports."""
HISTORY_RINGS = ((1, 4), (4, 8), (8, 16), (16, 28))
"""Rings, in l0, of the direction history of ``pfmpm post crack-directions --history``."""
_LEAVING = (2, 10)  # the ring, in l0, of the leaving direction


def propagation_angle(xy: np.ndarray, c: np.ndarray, tip, direction, r_min: float,
                      r_max: float, threshold: float) -> float:
    """Direction in which a crack left the tip of a notch, in degrees counter-clockwise from x.

    The direction of the mean unit vector from ``tip`` to the cracked points
    (``c < threshold``) ahead of it (positive projection on the notch
    ``direction``) at distances ``r_min`` to ``r_max``; NaN when there are none.
    """
    d = np.asarray(xy, dtype=float) - np.asarray(tip, dtype=float)
    r = np.hypot(d[:, 0], d[:, 1])
    ahead = d @ np.asarray(direction, dtype=float) > 0.0
    sel = (np.asarray(c) < threshold) & ahead & (r >= r_min) & (r <= r_max)
    if not np.any(sel):
        return math.nan
    u = (d[sel] / r[sel, None]).mean(axis=0)
    return math.degrees(math.atan2(u[1], u[0]))


def crack_arms(xy: np.ndarray, c: np.ndarray, centre, radius: float, width: float,
               threshold: float, gap_deg: float = 10.0) -> list[float]:
    """Directions (degrees in [0, 360)) of the crack arms crossing a circle.

    The cracked points (``c < threshold``) within ``width / 2`` of the circle
    of ``radius`` about ``centre`` are grouped by angle, a new group starting
    wherever consecutive angles differ by more than ``gap_deg``; each arm's
    direction is its group's mean. Two arms ahead of a notch tip mean the crack
    has branched.
    """
    d = np.asarray(xy, dtype=float) - np.asarray(centre, dtype=float)
    r = np.hypot(d[:, 0], d[:, 1])
    sel = (np.asarray(c) < threshold) & (np.abs(r - radius) <= 0.5 * width)
    if not np.any(sel):
        return []
    angles = np.sort(np.degrees(np.arctan2(d[sel, 1], d[sel, 0])) % 360.0)
    gaps = np.diff(np.concatenate([angles, angles[:1] + 360.0]))
    if gaps.max() <= gap_deg:
        return []  # the whole circle is cracked: no arms to tell apart
    start = int(np.argmax(gaps)) + 1  # begin after the widest gap, so no group wraps
    angles = np.roll(angles, -start)
    angles[angles < angles[0]] += 360.0
    groups = np.split(angles, np.flatnonzero(np.diff(angles) > gap_deg) + 1)
    return [float(g.mean() % 360.0) for g in groups]


def new_crack(c0: np.ndarray, c: np.ndarray, threshold: float) -> np.ndarray:
    """``c`` with the points cracked already in ``c0`` (the initial cracks' bands) set intact."""
    return np.where(np.asarray(c0) < threshold, 1.0, np.asarray(c))


def notch_tips(scene: Scene) -> list[tuple[np.ndarray, np.ndarray]]:
    """(tip, unit direction) of every end of an initial crack that lies inside the
    first crackable body's bounding box, the direction pointing out of the crack."""
    body = next(b for b in scene.bodies if scene.fracture_of(b) is not None)
    x0, y0, x1, y1 = body.shape.bounds()
    tips = []
    for crack in scene.cracks:
        pts = np.asarray(crack.points, dtype=float)
        for tip, behind in ((pts[-1], pts[-2]), (pts[0], pts[1])):
            if x0 < tip[0] < x1 and y0 < tip[1] < y1:
                tips.append((tip, (tip - behind) / np.linalg.norm(tip - behind)))
    return tips


def crack_directions(scene: Scene, xy: np.ndarray, c: np.ndarray) -> dict:
    """Where the cracks of a state of ``scene`` run from each notch tip.

    Parameters
    ----------
    scene : Scene
        With an initial crack and a crackable body (the first is measured).
    xy : ndarray (N, 2)
        Particle positions.
    c : ndarray (N,)
        Phase field, usually :func:`new_crack` of the run's first and last
        snapshots.  A point is cracked below the scene's ``output.crack_threshold``.

    Returns
    -------
    dict
        ``weak_directions``: the maxima of ``1/G_c(theta)`` in degrees
        (empty when isotropic); ``tips``: per notch tip (:func:`notch_tips`)
        its ``tip``, the ``angle`` in which the crack left it
        (:func:`propagation_angle` over 2-10 l0, degrees in [0, 360)), its
        distance ``off_weak`` from the nearest weak direction (NaN when
        isotropic), and ``arms``: per radius of :data:`ARM_RADII` l0, the
        arms ahead of the tip crossing that circle (:func:`crack_arms`).
    """
    threshold = scene.output.crack_threshold
    body = next(b for b in scene.bodies if scene.fracture_of(b) is not None)
    fracture = scene.fracture_of(body)
    l0 = fracture.l0
    weak = [float(w) for w in weak_directions(fracture.gamma(), body.orientation)]
    tips = []
    for tip, direction in notch_tips(scene):
        angle = propagation_angle(xy, c, tip, direction, _LEAVING[0] * l0, _LEAVING[1] * l0,
                                  threshold) % 360.0
        off = min(abs((w - angle + 180.0) % 360.0 - 180.0) for w in weak) if weak else math.nan
        arms = {}
        for k in ARM_RADII:
            crossing = crack_arms(xy, c, tip, k * l0, scene.grid.h, threshold)
            arms[k * l0] = [a for a in crossing
                            if np.dot([math.cos(math.radians(a)), math.sin(math.radians(a))], direction) > 0]
        tips.append({"tip": (float(tip[0]), float(tip[1])), "angle": angle, "off_weak": off, "arms": arms})
    return {"weak_directions": weak, "tips": tips}


def direction_history(scene: Scene, tip, direction, xy: np.ndarray, c: np.ndarray) -> list[float]:
    """Direction of the crack about ``tip`` in each ring of :data:`HISTORY_RINGS` (degrees; NaN where none)."""
    l0 = next(scene.fracture_of(b) for b in scene.bodies if scene.fracture_of(b) is not None).l0
    return [propagation_angle(xy, c, tip, direction, a * l0, b * l0, scene.output.crack_threshold)
            for a, b in HISTORY_RINGS]


def run_directions(scene: Scene, run_dir, history: bool = False) -> dict:
    """:func:`crack_directions` of a finished run: the crack that formed between
    its first and last particle snapshots.

    Returns
    -------
    dict
        That of :func:`crack_directions`, plus ``snapshot`` (the last VTU
        file's name), ``particles``, ``newly_cracked`` (points cracked at the
        end and not at the start) and ``threshold``; with ``history``, also
        ``history``: per snapshot its time and, per notch tip,
        :func:`direction_history` of the new crack.
    """
    from .frames import read_frame, series

    snaps = series(run_dir)
    first, last = read_frame(*snaps[0]), read_frame(*snaps[-1])
    threshold = scene.output.crack_threshold
    c0 = first.data["c"]
    c = new_crack(c0, last.data["c"], threshold)
    report = crack_directions(scene, last.x, c)
    report.update(snapshot=snaps[-1][1].name, particles=len(last.x),
                  newly_cracked=int(np.count_nonzero(c < threshold)), threshold=threshold)
    if history:
        tips = notch_tips(scene)
        report["history"] = []
        for t, path in snaps:
            frame = read_frame(t, path)
            cn = new_crack(c0, frame.data["c"], threshold)
            report["history"].append({"t": t, "rings": [direction_history(scene, tip, d, frame.x, cn)
                                                        for tip, d in tips]})
    return report
