"""What watches a run while it goes: the observers of the run loop
(:func:`pfmpm.run.run_to_end`), the one place where what a run records is
defined.

An :class:`Observer` is called at every record of the run: it may add columns
to the row of ``energies.csv``, keeps what it needs in checkpoints, and
writes its files and figures when the run ends. :func:`default_observers`
gives a scene's standard set:

:class:`CrackObserver`
    with an initial crack in 2D: the crack tips (:class:`CrackTip`, their columns)
    and where and when each point cracked (:class:`CrackPath`), written to
    :data:`CRACK_PATH` with the plots ``crack_tip.png`` and ``crack_path.png``;
:class:`CrackFrontObserver`
    with an initial crack in 3D: the crack front along ``output.crack_direction``
    and the crack area (:class:`CrackFront`, their columns);
:class:`SnapshotObserver`
    with ``output.snapshots``: the phase-field images (:class:`Snapshots`)
    of ``phase_field.png``;
:class:`FrameObserver`
    the field series (``particles.pvd`` of the MPM, ``fields.xdmf`` of the
    FEM) every ``output.every`` steps.

A user's own observer subclasses :class:`Observer` and is passed with the
standard ones: ``sim.run(out, observers=default_observers(sim) + [mine])``.
The measures of :mod:`pfmpm.post` read what these leave; they do not run.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from functools import partial
from pathlib import Path

import numpy as np

from .scene import Scene

__all__ = ["Observer", "CrackObserver", "CrackFrontObserver", "SnapshotObserver", "FrameObserver",
           "default_observers", "CrackTip", "CrackFront", "CrackPath", "Snapshots", "CRACK_PATH", "BRANCH_OFFSET", "speed_fit",
           "write_crack_path", "read_crack_path", "nearest_image"]

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
        crack, looking along ``output.crack_direction`` (by default along that
        crack's last segment), with the scene's ``output.crack_threshold`` and
        ``crack_speed_samples``."""
        origin, direction = scene.cracks[0].tip()
        if scene.output.crack_direction is not None:
            direction = scene.output.crack_direction
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


class CrackFront:
    """The crack front of a 3D scene: the farthest extent of the cracked points
    (phase field below ``threshold``) along ``direction``, with its smoothed
    speed, and the crack surface area; the 3D forms of the crack tip
    (:class:`CrackTip`) and of the crack length.

    The extent is ``max x . e`` over the cracked points ``x``, ``e`` the unit
    ``direction``, the coordinate of the front along it (the initial crack
    counts: before it grows the front is the initial patch's edge, as the
    phase field makes it); with no cracked point it is ``start``.  Its speed
    is the least-squares slope over the last ``samples`` records
    (:func:`speed_fit`).  The area is the run's ``int Z dV``
    (``sim.crack_area()``; :func:`pfmpm.post.tip.crack_area` of particle data).

    Parameters
    ----------
    direction : sequence of float
        The direction the crack runs in (``output.crack_direction``), nonzero.
    threshold : float
        Phase-field value below which a point is cracked.
    samples : int
        Records in the speed fit, at least 2.
    start : float
        The front when no point is cracked: the farthest corner of the first
        initial crack along ``direction``.
    """

    COLUMNS = ("crack_front", "crack_front_x", "crack_front_y", "crack_front_z", "crack_front_speed",
               "crack_area")
    """The ``energies.csv`` columns of :meth:`record`."""

    def __init__(self, direction, threshold: float, samples: int, start: float = 0.0):
        direction = np.asarray(direction, dtype=float)
        norm = float(np.sqrt(direction @ direction))
        if not norm > 0:
            raise ValueError(f"direction = {tuple(direction)}: must be nonzero")
        self.direction = direction / norm
        self.threshold = threshold
        self.start = float(start)
        self._history: deque[tuple[float, float]] = deque(maxlen=samples)

    @classmethod
    def for_scene(cls, scene: Scene) -> "CrackFront":
        """A tracker along the scene's ``output.crack_direction``, starting at
        the farthest corner of its first initial crack."""
        direction = np.asarray(scene.output.crack_direction, dtype=float)
        corners = np.asarray(scene.cracks[0].points, dtype=float)
        start = float(np.max(corners @ (direction / np.sqrt(direction @ direction))))
        return cls(direction, scene.output.crack_threshold, scene.output.crack_speed_samples, start)

    def farthest(self, x: np.ndarray, c: np.ndarray) -> tuple[float, ...] | None:
        """``(extent, *point)`` of the cracked point of ``x`` (N, dim) with phase
        field ``c`` farthest along the direction (of equals, the least in
        reverse coordinate order, ``(z, y, x)``), or ``None`` if none is cracked."""
        cracked = np.asarray(x, dtype=float)[np.asarray(c) < self.threshold]
        if not len(cracked):
            return None
        along = cracked @ self.direction
        far = cracked[along == along.max()]
        point = far[np.lexsort(far.T)[0]]
        return (float(along.max()), *map(float, point))

    @staticmethod
    def merge(parts: list) -> tuple[float, ...] | None:
        """The :meth:`farthest` of all points from those of parts of them (the
        ranks of a distributed mesh): the same whatever the partition."""
        found = [p for p in parts if p is not None]
        if not found:
            return None
        far = max(p[0] for p in found)
        return min((p for p in found if p[0] == far), key=lambda p: p[:0:-1])

    def records(self) -> list[tuple[float, float]]:
        """The records in the speed fit, oldest first: (time, extent)."""
        return list(self._history)

    def set_records(self, records) -> None:
        """Replace the records in the speed fit (from :meth:`records`)."""
        self._history.clear()
        self._history.extend((float(t), float(e)) for t, e in records)

    def record(self, t: float, found: tuple[float, ...] | None, area: float) -> dict[str, float]:
        """Record time ``t`` with the front ``found`` (as :meth:`farthest`
        gives it) and the crack area; return the :data:`COLUMNS`."""
        if found is None:
            found = (self.start, *(self.start * self.direction))
        extent, *point = found
        point = list(point) + [0.0] * (3 - len(point))
        self._history.append((t, extent))
        history = np.array(self._history)
        return {"crack_front": extent, "crack_front_x": point[0], "crack_front_y": point[1],
                "crack_front_z": point[2], "crack_front_speed": speed_fit(history[:, 0], history[:, 1]),
                "crack_area": float(area)}


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
    crack-path plot and the crack arms (:mod:`pfmpm.post.cracks`).

    It keeps the points by id (a particle's global id, an FEM vertex's global
    index), not by their place in the arrays: the ids of the cracked points
    only, ascending, with the time and position of each, since a crack is a
    thin band of a body's points.

    Parameters
    ----------
    threshold : float
        The scene's ``output.crack_threshold``.
    """

    def __init__(self, threshold: float):
        self.threshold = threshold
        self._id = np.empty(0, dtype=np.int64)
        self._time = np.empty(0)
        self._xy = np.empty((0, 2))

    def update(self, t: float, c: np.ndarray, xy: np.ndarray, ids: np.ndarray) -> None:
        """Note time ``t`` and the position in ``xy`` of the points that crack
        now, given the phase field ``c``, positions ``xy`` and ids ``ids`` of
        all, in any one order."""
        below = np.flatnonzero(c < self.threshold)
        found = np.asarray(ids)[below]
        at = np.searchsorted(self._id, found)
        new = at == len(self._id)
        new[~new] = self._id[at[~new]] != found[~new]
        if not new.any():
            return
        order = np.argsort(found[new], kind="stable")
        # where each goes in the ascending ids: its bisection above
        rows, found, at = below[new][order], found[new][order], at[new][order]
        self._id = np.insert(self._id, at, found)
        self._time = np.insert(self._time, at, t)
        self._xy = np.insert(self._xy, at, xy[rows], axis=0)

    @property
    def ids(self) -> np.ndarray:
        """(k,) the ids of the cracked points, ascending."""
        return self._id

    @property
    def times(self) -> np.ndarray:
        """(k,) the time each point of :attr:`ids` cracked."""
        return self._time

    @property
    def positions(self) -> np.ndarray:
        """(k, 2) where each point of :attr:`ids` cracked."""
        return self._xy

    def restore(self, ids: np.ndarray, times: np.ndarray, positions: np.ndarray) -> None:
        """Continue from the cracked points ``ids``, their :attr:`times` and
        :attr:`positions` (of a checkpoint), in any one order."""
        order = np.argsort(ids, kind="stable")
        self._id = np.asarray(ids, dtype=np.int64)[order]
        self._time = np.asarray(times, dtype=float)[order]
        self._xy = np.asarray(positions, dtype=float).reshape(-1, 2)[order]


CRACK_PATH = "crack_path.csv"
"""The file of a completed run with an initial crack: where and when each
point cracked (:class:`CrackPath`), one row per point, by time (of equal
times, by id)."""


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


class Observer:
    """Something that watches a run of :func:`pfmpm.run.run_to_end`.

    Subclass it and override what you need; each method here does nothing.
    The run calls, on every rank of a distributed run (``sim.comm``, where
    rank 0 writes the files):

    1. :meth:`columns`, once, for the header of ``energies.csv``;
    2. resuming from a checkpoint, :meth:`restore` with what :meth:`state`
       gave when the checkpoint was written;
    3. :meth:`start`, once, before the first record;
    4. :meth:`record` at every record: every ``output.energies_every`` steps,
       at every multiple of an observer's :attr:`every`, and at the start
       (not again when resuming) and the end;
    5. :meth:`state` at every checkpoint;
    6. :meth:`finish`, once, when the run ends, whether it completed, was
       interrupted or failed.

    An observer holds the simulation only while the run lasts: what
    :meth:`finish` returns to draw its figures must not refer to it, so
    that ``pfmpm run`` can release the simulation before it draws
    (:func:`~pfmpm.run.run_to_end` with ``draw=False``).

    Example: the largest particle speed at each row, as a column
    ``max_speed``::

        class MaxSpeed(Observer):
            def columns(self):
                return ["max_speed"]

            def record(self, sim, row, force):
                if row is not None:
                    row["max_speed"] = float(np.sqrt((sim.particles.v ** 2).sum(axis=1).max()))
    """

    every: int = 0
    """Steps between the records it needs besides the rows of
    ``energies.csv``: the run also stops at each multiple and calls
    :meth:`record` there (with no row); 0, none."""

    def columns(self) -> list[str]:
        """The columns it adds to ``energies.csv`` (after those of the simulation)."""
        return []

    def start(self, sim, out: Path) -> None:
        """The run of ``sim`` is about to take its first record, writing into ``out``."""

    def record(self, sim, row: dict | None, force: bool) -> None:
        """Record ``sim`` now.

        Parameters
        ----------
        sim : Simulation or FemSimulation
        row : dict or None
            The row of ``energies.csv`` about to be written (the
            simulation's energies): set a value for each of :meth:`columns`
            in it. ``None`` where this record writes no row (a stop of
            another observer's :attr:`every`).
        force : bool
            Whether this is the first or the last record of the run.
        """

    def state(self) -> dict[str, np.ndarray]:
        """What a checkpoint keeps of it, as arrays by name (the names unique
        among the run's observers; each becomes ``/output/<name>`` of the file)."""
        return {}

    def restore(self, sim, state: dict[str, np.ndarray]) -> None:
        """Continue from a checkpoint: ``state`` holds the arrays of every
        observer of the run that wrote it (with ``sim`` restored to that
        step); those of :meth:`state` may be missing from a checkpoint
        written without this observer or by an older pfmpm."""

    def finish(self, out: Path, completed: bool) -> Callable[[], None] | None:
        """The run has ended (``completed``: it reached its end): write the
        files that it leaves in ``out`` and return what draws its figures
        later (a function of no arguments that holds what they need), or None."""
        return None


class CrackObserver(Observer):
    """The crack tips and the crack path of a scene with an initial crack.

    At each row of ``energies.csv`` it adds the :meth:`CrackTip.columns` of
    the first initial crack's tips, and notes which points have cracked
    (:class:`CrackPath`), of the points that can crack of ``sim``
    (``sim.crack_points()``: the crackable particles, the FEM's vertices;
    on each rank its own, and :meth:`CrackTip.merge` puts the ranks' tips
    together). At the end of a completed run it writes :data:`CRACK_PATH`,
    and draws ``crack_tip.png`` (each crack arm's length and speed,
    :mod:`pfmpm.post.cracks`) and ``crack_path.png``.

    Its checkpoint state: ``crack_tip``, the records behind the tips' speed
    fits (:meth:`CrackTip.records`), and ``crack_id``, ``crack_time`` and
    ``crack_xy`` (:attr:`CrackPath.ids`, :attr:`CrackPath.times`,
    :attr:`CrackPath.positions`), of the cracked points by id
    (``sim.crack_ids()``).
    """

    def __init__(self, sim):
        self.scene = sim.scene
        self.comm = sim.comm
        self.tip = CrackTip.for_scene(sim.scene)
        self.path = CrackPath(sim.scene.output.crack_threshold)

    def columns(self) -> list[str]:
        return CrackTip.columns()

    def record(self, sim, row: dict | None, force: bool) -> None:
        if row is None:
            return
        xy, c = sim.crack_points()
        self.path.update(sim.time, c, xy, sim.crack_ids())
        found = self.tip.farthest(xy, c)
        if self.comm is not None:
            found = CrackTip.merge(self.comm.allgather(found))
        row.update(self.tip.record(sim.time, found))

    def state(self) -> dict[str, np.ndarray]:
        records = np.asarray(self.tip.records(), dtype=float).reshape(-1, 1 + len(CrackTip.TRACKS))
        return {"crack_tip": records, "crack_id": self.path.ids, "crack_time": self.path.times,
                "crack_xy": self.path.positions}

    def restore(self, sim, state: dict[str, np.ndarray]) -> None:
        """Continue the tips' speed fits and the crack path.

        Files from before the path was kept by id (checkpoint version 7) have
        no ``crack_id``: their ``crack_time`` and ``crack_xy`` have a row per
        crackable particle, in the order of ``sim.crack_points()`` (a run
        keeps its rows), NaN while intact; from one without the crack's
        positions, the points' positions now stand in, and from one without
        its times, the checkpoint's time for the points cracked by then."""
        if "crack_tip" in state:
            self.tip.set_records(state["crack_tip"])
        xy, c = sim.crack_points()
        ids = sim.crack_ids()
        times = state.get("crack_time")
        if times is None:
            self.path.update(sim.time, c, xy, ids)
        elif "crack_id" in state:
            self.path.restore(state["crack_id"], times, state["crack_xy"])
        else:
            positions = state.get("crack_xy")
            cracked = np.isfinite(times)
            self.path.restore(ids[cracked], times[cracked], (xy if positions is None else positions)[cracked])

    def points(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Where each cracked point cracked and when (of all ranks, on rank 0;
        ``None`` on the others); collective."""
        times, xy = self.path.times, self.path.positions
        if self.comm is None:
            return xy, times
        xy, times = self.comm.gather(xy), self.comm.gather(times)
        return (np.concatenate(xy), np.concatenate(times)) if self.comm.rank == 0 else None

    def finish(self, out: Path, completed: bool) -> Callable[[], None] | None:
        if not completed:
            return None
        path = self.points()
        if path is None:
            return None
        write_crack_path(out / CRACK_PATH, *path)
        return partial(_draw_cracks, out, self.scene, *path)


class CrackFrontObserver(Observer):
    """The crack front and the crack area of a 3D scene with an initial crack.

    At each row of ``energies.csv`` it adds the :data:`CrackFront.COLUMNS` of
    the points that can crack of ``sim`` (``sim.crack_points()``, on each rank
    its own, merged with :meth:`CrackFront.merge`) and of ``sim.crack_area()``
    (collective). Its checkpoint state: ``crack_front``, the records behind
    the speed fit.
    """

    def __init__(self, sim):
        self.comm = sim.comm
        self.front = CrackFront.for_scene(sim.scene)

    def columns(self) -> list[str]:
        return list(CrackFront.COLUMNS)

    def record(self, sim, row: dict | None, force: bool) -> None:
        if row is None:
            return
        found = self.front.farthest(*sim.crack_points())
        if self.comm is not None:
            found = CrackFront.merge(self.comm.allgather(found))
        row.update(self.front.record(sim.time, found, sim.crack_area()))

    def state(self) -> dict[str, np.ndarray]:
        return {"crack_front": np.asarray(self.front.records(), dtype=float).reshape(-1, 2)}

    def restore(self, sim, state: dict[str, np.ndarray]) -> None:
        if "crack_front" in state:
            self.front.set_records(state["crack_front"])


def _draw_cracks(out: Path, scene: Scene, xy: np.ndarray, times: np.ndarray) -> None:
    """``crack_tip.png`` and ``crack_path.png`` of a run in ``out`` whose points ``xy`` cracked at ``times``."""
    from . import plots
    from .output import read_csv
    from .post.cracks import scene_cracks

    units = scene.unit_system()
    arms = scene_cracks(scene, xy, times, read_csv(out / "energies.csv")["t"])
    plots.crack_arms(arms, out / "crack_tip.png", scene.crack_rayleigh_speed(), units)
    plots.crack_path(arms, xy, times, out / "crack_path.png", _crackable_bounds(scene), units)


class SnapshotObserver(Observer):
    """The phase-field images (:class:`Snapshots`) at the scene's
    ``output.snapshots``, of ``sim.crack_points()`` on the pixels of
    ``sim.snapshot_pixels()``, drawn into ``phase_field.png`` (also when the
    run did not complete). In a distributed run the ranks gather their points
    to rank 0, which keeps the images, while an image is still due.

    Its checkpoint state: ``snapshot_times``, the times still due,
    ``snapshot_image_times``, those of the images taken, and the images
    ``snapshot_<k>``.
    """

    def __init__(self, sim):
        self.scene = sim.scene
        self.comm = sim.comm
        root = self.comm is None or self.comm.rank == 0
        pixel, origin, shape, reach = sim.snapshot_pixels()
        self.snapshots = Snapshots(sim.scene, pixel, origin, shape, reach) if root else None

    def record(self, sim, row: dict | None, force: bool) -> None:
        if self.comm is None:
            if self.snapshots.times:
                self.snapshots.take(sim.time, sim.dt, *sim.crack_points())
            return
        root = self.comm.rank == 0
        if not self.comm.bcast(bool(self.snapshots.times) if root else None):
            return
        xy, c = sim.crack_points()
        xy, c = self.comm.gather(xy), self.comm.gather(c)
        if root:
            self.snapshots.take(sim.time, sim.dt, np.concatenate(xy), np.concatenate(c))

    def state(self) -> dict[str, np.ndarray]:
        if self.snapshots is None:
            return {}
        images = self.snapshots.images
        state = {"snapshot_times": np.asarray(self.snapshots.times, dtype=float),
                 "snapshot_image_times": np.asarray([t for t, _ in images], dtype=float)}
        state.update({f"snapshot_{k}": image for k, (_, image) in enumerate(images)})
        return state

    def restore(self, sim, state: dict[str, np.ndarray]) -> None:
        if self.snapshots is None or "snapshot_times" not in state:
            return
        taken = state.get("snapshot_image_times", ())
        self.snapshots.restore(state["snapshot_times"],
                               [(t, state[f"snapshot_{k}"]) for k, t in enumerate(taken)])

    def finish(self, out: Path, completed: bool) -> Callable[[], None] | None:
        if self.snapshots is None or not self.snapshots.images:
            return None
        return partial(_draw_snapshots, out, self.scene, self.snapshots)


def _draw_snapshots(out: Path, scene: Scene, snapshots: "Snapshots") -> None:
    """``phase_field.png`` of the images of ``snapshots``."""
    from . import plots

    plots.phase_field(snapshots, out / "phase_field.png", _polar_overlay(scene), scene.unit_system())


class FrameObserver(Observer):
    """The field series of a run, ``sim.open_frames(out, entries)``: the
    particles (``particles.pvd``) of the MPM, the mesh fields
    (``fields.xdmf``) of the FEM, every ``output.every`` steps and at the
    start and the end. Its checkpoint state: the series' entries so far,
    ``series_time`` and ``series_file``."""

    def __init__(self, sim):
        self.every = sim.scene.output.every
        self._entries: list[tuple[float, str]] = []
        self._frames = None

    def start(self, sim, out: Path) -> None:
        self._frames = sim.open_frames(out, self._entries)

    def record(self, sim, row: dict | None, force: bool) -> None:
        if force or sim.step % self.every == 0:
            self._frames.write()

    def state(self) -> dict[str, np.ndarray]:
        entries = self._frames.entries
        return {"series_time": np.array([t for t, _ in entries], dtype=float),
                "series_file": np.array([name for _, name in entries], dtype="S")}

    def restore(self, sim, state: dict[str, np.ndarray]) -> None:
        if "series_time" in state:
            self._entries = [(float(t), bytes(name).decode())
                             for t, name in zip(state["series_time"], state["series_file"])]

    def finish(self, out: Path, completed: bool) -> None:
        if self._frames is not None:
            self._frames.close()
        return None


def default_observers(sim) -> list[Observer]:
    """The standard observers of a run of ``sim``, the set that
    :func:`~pfmpm.run.run_to_end` takes unless given others: a
    :class:`CrackObserver` with an initial crack (in 3D a :class:`CrackFrontObserver`), a :class:`SnapshotObserver`
    with ``output.snapshots`` (both where something can crack,
    ``sim.cracks``) and a :class:`FrameObserver` where ``sim`` writes a
    field series (``sim.field_series``)."""
    scene = sim.scene
    observers: list[Observer] = []
    if sim.cracks and scene.cracks:
        observers.append(CrackObserver(sim) if scene.dim == 2 else CrackFrontObserver(sim))
    if sim.cracks and scene.output.snapshots:
        observers.append(SnapshotObserver(sim))
    if sim.field_series:
        observers.append(FrameObserver(sim))
    return observers


def _crackable_bounds(scene: Scene) -> tuple[float, float, float, float]:
    """The bounding box of the bodies that can crack."""
    boxes = np.array([b.shape.bounds() for b in scene.bodies if scene.fracture_of(b) is not None])
    return (*boxes[:, :2].min(axis=0), *boxes[:, 2:].max(axis=0))


def _polar_overlay(scene: Scene):
    """``1/G_c(theta)`` of the first anisotropic body, drawn at the initial
    crack tips (or the body's centre) on the phase-field snapshots; or None."""
    from .anisotropy import polar_table

    for body in scene.bodies:
        f = scene.fracture_of(body)
        if f is not None and f.anisotropy is not None and f.anisotropy.fourth_order:
            x0, y0, x1, y1 = body.shape.bounds()
            h = scene.grid.h
            tips = [p for crack in scene.cracks if crack.body in (None, body.name)
                    for p in (crack.points[0], crack.points[-1])
                    if x0 + h <= p[0] <= x1 - h and y0 + h <= p[1] <= y1 - h]
            if not tips:
                tips = [(0.5 * (x0 + x1), 0.5 * (y0 + y1))]
            return tips, polar_table(f.gamma(), f.Gc, body.orientation)
    return None


_QUERY_PIXELS = 1 << 14  # pixel centres per nearest-point query (and tree of their points)


class Snapshots:
    """Phase-field images at the scene's ``output.snapshots`` times.

    Each pixel takes the phase field of the point nearest its centre, or NaN
    when no point lies within ``reach``: the body as the points fill it,
    without the gaps that binning points into pixels of their own spacing
    leaves wherever they have moved. Each image is taken at the first record
    at or after the requested time (the last record for times past the end).

    Parameters
    ----------
    scene : Scene
    pixel : float
        Pixel side.
    origin : (float, float)
        Lower-left corner of the image.
    shape : (int, int)
        Pixels in x and y.
    reach : float
        Largest distance from a pixel centre to the point it shows: the
        points' spacing, so that no pixel inside a body is empty and none
        farther than half a spacing outside it is filled.
    """

    def __init__(self, scene: Scene, pixel: float, origin, shape: tuple[int, int], reach: float):
        self.times = sorted(scene.output.snapshots)
        self.pixel = pixel
        self.origin = np.asarray(origin, dtype=float)
        self.shape = shape
        self.reach = reach
        self.images: list[tuple[float, np.ndarray]] = []
        self._end = scene.steps() * scene.dt()

    def restore(self, times, images) -> None:
        """Continue from a checkpoint: the times still due and the images taken."""
        self.times = [float(t) for t in times]
        self.images = [(float(t), np.asarray(image)) for t, image in images]

    def take(self, t: float, dt: float, xy: np.ndarray, c: np.ndarray) -> None:
        """Offer the state at time ``t``; keep an image if a snapshot time is due."""
        while self.times and (t >= self.times[0] - 0.5 * dt or t >= self._end - 0.5 * dt):
            self.times.pop(0)
            self.images.append((t, self.rasterize(xy, c)))

    def rasterize(self, xy: np.ndarray, c: np.ndarray) -> np.ndarray:
        """``c`` of the nearest point within ``reach`` of each pixel centre, NaN
        where there is none; shape (ny, nx)."""
        return nearest_image(xy, c, self.origin, self.pixel, self.shape, self.reach)


def nearest_image(xy: np.ndarray, values: np.ndarray, origin, pixel: float, shape: tuple[int, int],
                  reach: float) -> np.ndarray:
    """An image of point values: each pixel the value of the point nearest its
    centre, NaN where none lies within ``reach``.

    Parameters
    ----------
    xy : (N, 2) ndarray
        The points.
    values : (N,) ndarray
    origin : (float, float)
        Lower-left corner of the image.
    pixel : float
        Pixel side.
    shape : (int, int)
        Pixels in x and y.
    reach : float

    Returns
    -------
    (ny, nx) ndarray
        Row 0 at the bottom (``imshow(..., origin="lower")``).
    """
    from scipy.spatial import cKDTree

    nx, ny = shape
    image = np.full((ny, nx), np.nan)
    xy, values = np.asarray(xy), np.asarray(values)
    gx = origin[0] + (np.arange(nx) + 0.5) * pixel
    gy = origin[1] + (np.arange(ny) + 0.5) * pixel
    rows = max(1, _QUERY_PIXELS // nx)  # rows of pixels per query, to bound its arrays
    for r in range(0, ny, rows):
        cy = gy[r:r + rows]
        # Only points within reach of the band's centres can be shown in it: a
        # tree over those alone holds a band's share of the points, not all.
        near = np.flatnonzero((xy[:, 1] >= cy[0] - reach) & (xy[:, 1] <= cy[-1] + reach))
        if not len(near):
            continue
        _, nearest = cKDTree(xy[near]).query(np.column_stack((np.tile(gx, len(cy)), np.repeat(cy, nx))),
                                             distance_upper_bound=reach)
        found = nearest < len(near)
        image[r:r + len(cy)].reshape(-1)[found] = values[near[nearest[found]]]
    return image
