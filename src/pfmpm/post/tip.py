"""The crack tip: where it is, how fast it runs, when it starts and when it branches."""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..output import read_csv
from ..scene import Crack, Scene

__all__ = ["CrackTip", "INITIATION_ADVANCE", "BRANCH_OFFSET", "BRANCH_AFTER", "initiation_time",
           "branch_time", "tip_report", "read_columns"]

INITIATION_ADVANCE = 0.5
"""Crack initiation: the tip has moved this far (mm) past its position at t = 0."""
BRANCH_OFFSET = 1.0
"""Branching: the tip lies this far (mm) off the notch line ..."""
BRANCH_AFTER = 5.0
"""... while this far (mm) ahead of the notch tip."""


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
        Phase-field value below which a point is cracked (a scene's
        ``output.crack_threshold``).
    samples : int
        Records in the speed fit, at least 2.
    """

    def __init__(self, origin, direction, threshold: float, samples: int):
        self.origin = np.asarray(origin, dtype=float)
        norm = math.hypot(*direction)
        if not norm > 0:
            raise ValueError(f"direction = {tuple(direction)}: must be nonzero")
        self.direction = np.asarray(direction, dtype=float) / norm
        self.threshold = threshold
        self._history: deque[tuple[float, float]] = deque(maxlen=samples)

    @classmethod
    def for_scene(cls, scene: Scene) -> "CrackTip":
        """A tracker for the tip at the last point of the scene's first initial
        crack, with the scene's ``output.crack_threshold`` and ``crack_speed_samples``."""
        origin, direction = scene.cracks[0].tip()
        return cls(origin, direction, scene.output.crack_threshold, scene.output.crack_speed_samples)

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


def read_columns(csv_or_columns) -> Mapping[str, np.ndarray]:
    """Columns of an ``energies.csv`` given as a path or already read."""
    if isinstance(csv_or_columns, Mapping):
        return csv_or_columns
    return read_csv(Path(csv_or_columns))


def initiation_time(e, advance: float = INITIATION_ADVANCE) -> float:
    """First time ``crack_tip_x`` exceeds its value at t = 0 by ``advance``.

    Parameters
    ----------
    e : path or mapping of str -> ndarray
        An ``energies.csv`` with crack-tip columns, or its columns.
    advance : float
        Distance the tip has to move, in the units of the scene (mm).

    Returns
    -------
    float
        The time, or NaN if the tip never gets that far.
    """
    e = read_columns(e)
    moved = e["crack_tip_x"] > e["crack_tip_x"][0] + advance
    return float(e["t"][np.argmax(moved)]) if moved.any() else math.nan


def branch_time(e, crack: Crack, offset: float = BRANCH_OFFSET, after: float = BRANCH_AFTER) -> float:
    """First time the crack tip leaves the notch line: when the crack branches.

    The notch line is the continuation of the last segment of ``crack``.
    The tip counts as off the line when it is more than ``offset`` from it
    and more than ``after`` ahead of the notch tip (along the line).  The
    tip of ``energies.csv`` is the cracked point farthest from the notch tip
    (:class:`CrackTip`): it stays on the line while a single crack runs
    along it, and jumps onto one of the branches once two diverge.  For the
    Borden plate (notch from (0, 20) to (50, 20)) with the defaults: the
    first time ``|crack_tip_y - 20| > 1`` while ``crack_tip_x > 55``.

    Parameters
    ----------
    e : path or mapping of str -> ndarray
        An ``energies.csv`` with crack-tip columns, or its columns.
    crack : Crack
        The initial crack whose tip is tracked (the scene's first).
    offset, after : float
        Distances in the units of the scene (mm).

    Returns
    -------
    float
        The time, or NaN if the tip never leaves the line.
    """
    e = read_columns(e)
    (bx, by), direction = crack.tip()
    d = np.asarray(direction) / math.hypot(*direction)
    rx, ry = e["crack_tip_x"] - bx, e["crack_tip_y"] - by
    along, across = rx * d[0] + ry * d[1], np.abs(rx * d[1] - ry * d[0])
    off = (along > after) & (across > offset)
    return float(e["t"][np.argmax(off)]) if off.any() else math.nan


def tip_report(scene: Scene, e) -> dict:
    """The crack-tip measures of a run of ``scene`` with an initial crack.

    Parameters
    ----------
    scene : Scene
    e : path or mapping of str -> ndarray
        The run's ``energies.csv``, or its columns.

    Returns
    -------
    dict
        ``initiation_us`` (:func:`initiation_time`), ``branch_us``
        (:func:`branch_time`), ``tip_x_end``, ``tip_y_end``, the largest
        smoothed ``max_speed`` and its ratio ``max_speed_over_rayleigh`` to
        the Rayleigh speed of the crackable material.
    """
    e = read_columns(e)
    speed = float(np.max(e["crack_tip_speed"]))
    return {
        "initiation_us": initiation_time(e),
        "branch_us": branch_time(e, scene.cracks[0]),
        "tip_x_end": float(e["crack_tip_x"][-1]),
        "tip_y_end": float(e["crack_tip_y"][-1]),
        "max_speed": speed,
        "max_speed_over_rayleigh": speed / scene.crack_rayleigh_speed(),
    }
