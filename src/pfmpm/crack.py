"""Initial cracks as history fields, and crack-tip tracking.

Both the MPM and the FEM paths use these, so a crack is imposed and measured
the same way in each.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from .scene import Crack, Fracture

__all__ = ["distance_to_polyline", "initial_history", "propagation_angle", "crack_arms", "CrackTip"]


def distance_to_polyline(xy: np.ndarray, points) -> np.ndarray:
    """Distance from each row of ``xy`` (N, 2) to the polyline through ``points``."""
    xy = np.asarray(xy, dtype=float)
    pts = np.asarray(points, dtype=float)
    d = np.full(len(xy), np.inf)
    for a, b in zip(pts[:-1], pts[1:]):
        ab = b - a
        t = np.clip(((xy - a) @ ab) / max(ab @ ab, np.finfo(float).tiny), 0.0, 1.0)
        d = np.minimum(d, np.hypot(*(xy - a - t[:, None] * ab).T))
    return d


def propagation_angle(xy: np.ndarray, c: np.ndarray, tip, direction, r_min: float,
                      r_max: float, threshold: float = 0.2) -> float:
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
               threshold: float = 0.2, gap_deg: float = 10.0) -> list[float]:
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


def initial_history(xy: np.ndarray, crack: Crack, fracture: Fracture) -> np.ndarray:
    """History field of an initial crack (Borden et al. 2012).

    ``H0 = B G_c / (4 l0) (1 - d / w)`` within the half width ``w`` of the
    crack polyline (``w = l0 / 2`` unless the crack sets it), 0 beyond.

    Parameters
    ----------
    xy : ndarray (N, 2)
        Points (particles or cell centroids).
    crack : Crack
    fracture : Fracture
        The material's parameters (G_c, l0).

    Returns
    -------
    ndarray (N,)
    """
    w = crack.half_width if crack.half_width is not None else 0.5 * fracture.l0
    d = distance_to_polyline(xy, crack.points)
    return np.where(d <= w, crack.B * fracture.Gc / (4 * fracture.l0) * (1 - d / w), 0.0)


class CrackTip:
    """The crack tip and its smoothed speed, following Borden et al. (2012).

    The tip is the cracked point (phase field below ``threshold``) farthest
    from the initial notch tip ``origin``, among points ahead of it (positive
    projection on ``direction``); with none, the tip is ``origin``. The speed
    is the least-squares slope of the tip's distance from ``origin`` over the
    last ``samples`` records, so it lags the tip by about half that window.

    Parameters
    ----------
    origin : (float, float)
        Initial notch tip.
    direction : (float, float)
        Direction in which the notch points (need not be unit length).
    threshold : float
        Phase-field value below which a point is cracked.
    samples : int
        Records in the speed fit, at least 2.
    """

    def __init__(self, origin, direction, threshold: float = 0.2, samples: int = 9):
        self.origin = np.asarray(origin, dtype=float)
        norm = math.hypot(*direction)
        if not norm > 0:
            raise ValueError(f"direction = {tuple(direction)}: must be nonzero")
        self.direction = np.asarray(direction, dtype=float) / norm
        self.threshold = threshold
        self._history: deque[tuple[float, float]] = deque(maxlen=samples)

    @classmethod
    def for_crack(cls, crack: Crack, threshold: float, samples: int) -> "CrackTip":
        """A tracker for the tip at the last point of an initial crack."""
        (ax, ay), (bx, by) = crack.points[-2], crack.points[-1]
        return cls((bx, by), (bx - ax, by - ay), threshold, samples)

    def locate(self, xy: np.ndarray, c: np.ndarray) -> tuple[float, float, float]:
        """Tip ``(x, y)`` and its distance from the origin for points ``xy`` with phase field ``c``."""
        rel = xy - self.origin
        ahead = (c < self.threshold) & (rel @ self.direction > 0)
        if not ahead.any():
            return float(self.origin[0]), float(self.origin[1]), 0.0
        dist = np.hypot(rel[ahead, 0], rel[ahead, 1])
        k = int(np.argmax(dist))
        tip = xy[ahead][k]
        return float(tip[0]), float(tip[1]), float(dist[k])

    def records(self) -> list[tuple[float, float]]:
        """The (time, distance) records in the speed fit, oldest first."""
        return list(self._history)

    def set_records(self, records) -> None:
        """Replace the records in the speed fit (from :meth:`records`, e.g. in a checkpoint)."""
        self._history.clear()
        self._history.extend((float(t), float(d)) for t, d in records)

    def update(self, t: float, xy: np.ndarray, c: np.ndarray) -> tuple[float, float, float]:
        """Record time ``t``; return the tip ``(x, y)`` and its smoothed speed."""
        x, y, dist = self.locate(xy, c)
        self._history.append((t, dist))
        ts, ds = np.array(self._history).T
        if len(ts) < 2 or np.ptp(ts) == 0:
            return x, y, 0.0
        tc = ts - ts.mean()
        return x, y, float(tc @ (ds - ds.mean()) / (tc @ tc))
