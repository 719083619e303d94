"""What watches a run while it goes: the run loop records, at every row of
``energies.csv``, the crack tips (:class:`CrackTip`, their columns) and where
and when each point cracked (:class:`CrackPath`), keeps both in checkpoints,
and writes the latter to :data:`CRACK_PATH` at the end. The measures of
:mod:`pfmpm.post` read what these leave; they do not run."""

from __future__ import annotations

import math
from collections import deque
from pathlib import Path

import numpy as np

from .scene import Scene

__all__ = ["CrackTip", "CrackPath", "CRACK_PATH", "BRANCH_OFFSET", "speed_fit", "write_crack_path",
           "read_crack_path"]

BRANCH_OFFSET = 1.0
"""A branch's tip (:class:`CrackTip`) lies on its side of the notch line or
within this distance (mm) of it; :func:`pfmpm.post.tip.branch_time` reads
branching where the tip lies this far off the line."""


class CrackTip:
    """The crack tip and the tip of each branch, with their smoothed speeds,
    following Borden et al. (2012).

    Three tips are tracked, each the cracked point (phase field below
    ``threshold``) farthest from the initial notch tip ``origin`` among the
    points ahead of it (positive projection on ``direction``) in its own set:

    ``crack_tip``
        all those points.  Once the crack branches this tip is on whichever
        branch is longer, so it jumps between branches as they race.
    ``left_tip``, ``right_tip``
        the points on the left (right) of the notch line, looking along
        ``direction``, or within :data:`BRANCH_OFFSET` of it.  Before the
        crack branches both are the tip of the one crack on the line; after
        it, each follows its own branch.  (A second branching on one side is
        followed by that side's farther arm.)

    With no point in a set its tip is ``origin``. Each speed is the
    least-squares slope of the tip's distance from ``origin`` over the last
    ``samples`` records, so it lags the tip by about half that window.

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

    TRACKS = ("crack_tip", "left_tip", "right_tip")
    """The tips tracked, the prefixes of their ``energies.csv`` columns."""

    def __init__(self, origin, direction, threshold: float, samples: int):
        self.origin = np.asarray(origin, dtype=float)
        norm = math.hypot(*direction)
        if not norm > 0:
            raise ValueError(f"direction = {tuple(direction)}: must be nonzero")
        self.direction = np.asarray(direction, dtype=float) / norm
        self.normal = np.array([-self.direction[1], self.direction[0]])  # to the left
        self.threshold = threshold
        self._history: deque[tuple[float, ...]] = deque(maxlen=samples)

    @classmethod
    def for_scene(cls, scene: Scene) -> "CrackTip":
        """A tracker for the tip at the last point of the scene's first initial
        crack, with the scene's ``output.crack_threshold`` and ``crack_speed_samples``."""
        origin, direction = scene.cracks[0].tip()
        return cls(origin, direction, scene.output.crack_threshold, scene.output.crack_speed_samples)

    @staticmethod
    def columns() -> list[str]:
        """The ``energies.csv`` columns of :meth:`record`: ``<track>_x``, ``_y``, ``_speed``."""
        return [f"{track}_{q}" for track in CrackTip.TRACKS for q in ("x", "y", "speed")]

    def locate(self, xy: np.ndarray, c: np.ndarray) -> tuple[float, float, float]:
        """Tip ``(x, y)`` and its distance from the origin for points ``xy`` with phase field ``c``."""
        found = self.farthest(xy, c)["crack_tip"]
        if found is None:
            return float(self.origin[0]), float(self.origin[1]), 0.0
        dist, x, y = found
        return x, y, dist

    def farthest(self, xy: np.ndarray, c: np.ndarray) -> dict[str, tuple[float, float, float] | None]:
        """Per track, ``(distance, x, y)`` of its farthest point among ``xy`` with
        phase field ``c`` (of equals, the least ``(y, x)``), or ``None`` if it has none."""
        # Only cracked points can be a tip: the arithmetic is on those alone.
        cracked = np.flatnonzero(c < self.threshold)
        xy = xy[cracked]
        rel = xy - self.origin
        ahead = rel @ self.direction > 0
        across = rel @ self.normal
        sets = {"crack_tip": ahead, "left_tip": ahead & (across >= -BRANCH_OFFSET),
                "right_tip": ahead & (across <= BRANCH_OFFSET)}
        found = {}
        for track, sel in sets.items():
            if not sel.any():
                found[track] = None
                continue
            dist = np.hypot(rel[sel, 0], rel[sel, 1])
            far = xy[sel][dist == dist.max()]
            x, y = far[np.lexsort((far[:, 0], far[:, 1]))[0]]
            found[track] = (float(dist.max()), float(x), float(y))
        return found

    @staticmethod
    def merge(parts: list[dict]) -> dict[str, tuple[float, float, float] | None]:
        """The tips of all points from the :meth:`farthest` of parts of them (of
        the ranks of a distributed mesh): the same whatever the partition."""
        merged = {}
        for track in CrackTip.TRACKS:
            found = [p[track] for p in parts if p[track] is not None]
            if not found:
                merged[track] = None
                continue
            far = max(d for d, _, _ in found)
            merged[track] = min(((d, x, y) for d, x, y in found if d == far), key=lambda t: (t[2], t[1]))
        return merged

    def records(self) -> list[tuple[float, ...]]:
        """The records in the speed fits, oldest first: (time, distance of each track)."""
        return list(self._history)

    def set_records(self, records) -> None:
        """Replace the records in the speed fits (from :meth:`records`, e.g. in a
        checkpoint).  Rows of (time, distance) from before the branch tips were
        tracked give each branch the distance of the one tip."""
        self._history.clear()
        for row in records:
            t, *dist = (float(v) for v in row)
            self._history.append((t, *(dist * len(self.TRACKS) if len(dist) == 1 else dist)))

    def update(self, t: float, xy: np.ndarray, c: np.ndarray) -> dict[str, float]:
        """Record time ``t`` with points ``xy`` of phase field ``c``: :meth:`record`
        of :meth:`farthest`."""
        return self.record(t, self.farthest(xy, c))

    def record(self, t: float, found: dict) -> dict[str, float]:
        """Record time ``t`` with the tips ``found`` (as :meth:`farthest` gives
        them); return the :meth:`columns` of each tip: position and smoothed speed."""
        row, out = [t], {}
        for track in self.TRACKS:
            dist, x, y = found[track] or (0.0, float(self.origin[0]), float(self.origin[1]))
            row.append(dist)
            out[f"{track}_x"], out[f"{track}_y"] = x, y
        self._history.append(tuple(row))
        history = np.array(self._history)
        for k, track in enumerate(self.TRACKS):
            out[f"{track}_speed"] = speed_fit(history[:, 0], history[:, k + 1])
        return out


def speed_fit(t, distance) -> float:
    """The least-squares slope of ``distance`` against ``t``: a tip's smoothed
    speed over the records given; 0 for fewer than two times or one time."""
    t, distance = np.asarray(t, dtype=float), np.asarray(distance, dtype=float)
    if len(t) < 2 or np.ptp(t) == 0:
        return 0.0
    tc = t - t.mean()
    return float(tc @ (distance - distance.mean()) / (tc @ tc))


class CrackPath:
    """When and where each point cracked: the time of the first record at which
    its phase field was below ``threshold``, and its position then, for the
    crack-path plot and the crack arms (:mod:`pfmpm.post.cracks`). It keeps a
    flag per point and the times and positions of the cracked ones only, since
    a crack is a thin band of a body's points.

    Parameters
    ----------
    n : int
        Number of points.
    threshold : float
        The scene's ``output.crack_threshold``.
    """

    def __init__(self, n: int, threshold: float):
        self.threshold = threshold
        self._cracked = np.zeros(n, dtype=bool)
        self._index = np.empty(0, dtype=np.int64)
        self._time = np.empty(0)
        self._xy = np.empty((0, 2))

    def update(self, t: float, c: np.ndarray, xy: np.ndarray) -> None:
        """Note time ``t`` and the position in ``xy`` of the points that crack
        now, given the phase field ``c`` and positions ``xy`` of all."""
        new = np.flatnonzero(~self._cracked & (c < self.threshold))
        if len(new):
            self._cracked[new] = True
            self._index = np.concatenate((self._index, new))
            self._time = np.concatenate((self._time, np.full(len(new), t)))
            self._xy = np.concatenate((self._xy, xy[new]))

    @property
    def times(self) -> np.ndarray:
        """(n,) the time each point cracked, NaN while intact."""
        times = np.full(len(self._cracked), np.nan)
        times[self._index] = self._time
        return times

    @property
    def positions(self) -> np.ndarray:
        """(n, 2) where each point cracked, NaN while intact."""
        xy = np.full((len(self._cracked), 2), np.nan)
        xy[self._index] = self._xy
        return xy

    def restore(self, times: np.ndarray, positions: np.ndarray) -> None:
        """Continue from :attr:`times` and :attr:`positions` (of a checkpoint)."""
        self._cracked = np.isfinite(times)
        self._index = np.flatnonzero(self._cracked)
        self._time = np.asarray(times)[self._index]
        self._xy = np.asarray(positions, dtype=float)[self._index]

    def cracked(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The indices of the cracked points, ascending, the time each cracked
        and where."""
        order = np.argsort(self._index)
        return self._index[order], self._time[order], self._xy[order]


CRACK_PATH = "crack_path.csv"
"""The file of a completed run with an initial crack: where and when each
point cracked (:meth:`CrackPath.cracked`), one row per point, by time."""


def write_crack_path(path: Path, xy: np.ndarray, times: np.ndarray) -> None:
    """Write the points ``xy`` and the times they cracked to the CSV ``path``
    (columns ``x``, ``y``, ``t``), in the order they cracked."""
    order = np.argsort(times, kind="stable")
    rows = np.column_stack((np.asarray(xy, dtype=float)[order], np.asarray(times, dtype=float)[order]))
    np.savetxt(path, rows, delimiter=",", header="x,y,t", comments="", fmt="%.17g")


def read_crack_path(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """The points and their crack times of :func:`write_crack_path`'s file."""
    rows = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2).reshape(-1, 3)
    return rows[:, :2], rows[:, 2]
