"""Every crack of a run and the tip of each of its arms over time, from where
and when each point cracked (:data:`~pfmpm.observe.CRACK_PATH`), for cracks
of any direction and for cracks that start away from the notch.

At each record time the cracked points are linked to those within
``link`` of them; each connected set is a crack. A crack is named by its
first point (the earliest to crack), so when two cracks meet the older one
goes on and the younger one ends, merged. The crack that holds a point
within ``link`` of the initial notch's tip grows from the notch: its path
lengths are measured from the notch's own band (the points cracked at the
first record), so that the band's thickening is not growth; any other crack
starts at its first point. A path length is the shortest distance through
the linked points (Dijkstra, from scipy). A tip is a point farther along
than every point within ``separation`` / ``link`` links of it, and tips
closer than ``separation`` to a farther one are one tip (half that for the
tip that carries on a known arm, so that an arm is not lost while another
passes near it); for the crack from the notch only points ahead of the
notch's band and a link or more from it count. Each tip is an *arm*: it
continues the arm of the same crack whose last tip lies nearest within
``2 separation`` (an arm without a tip for a few records, :data:`PATIENCE`,
still counts, as far as it may have run since), or else it is a new arm (a
branch, or the second side of a crack that grows both ways). So a tip never
jumps from one crack to another: a second crack is its own arms.

An arm's length is the path length of its tip, and its speed the
least-squares slope of that length over its last ``samples`` records, as
the tip speeds of :class:`~pfmpm.observe.CrackTip`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.spatial import cKDTree

from .. import plots
from ..scene import Scene
from ..scene.units import unit_system
from ..observe import CRACK_PATH, read_crack_path, speed_fit
from ..output import CsvLog
from .tip import INITIATION_ADVANCE, read_columns

__all__ = ["Arm", "Crack", "Cracks", "LINK", "SEPARATION", "PATIENCE", "MAX_RECORDS", "track_cracks", "spacing_of",
           "scene_cracks", "run_cracks"]

LINK = 3.2
"""Points within this many point spacings of each other are one crack. Above
sqrt(10), so that the path lengths through a lattice of points miss the
straight length by at most 1.3 % in any direction."""
SEPARATION = 8.0
"""Tips closer than this many point spacings to a farther one are one tip."""
PATIENCE = 12
"""An arm without a tip for more records than this has ended; until
then a tip near its last one carries it on (the two corners of a blunt band
come and go as tips while a crack widens before it branches)."""
MAX_RECORDS = 400
"""At most this many record times are analysed (evenly among those at which
points cracked): the cost of a long run's measure stays bounded."""


@dataclass
class Arm:
    """One arm of a crack: its tip at each analysed record from its birth."""

    crack: int
    """Index of its crack in :attr:`Cracks.cracks`."""
    born: float
    t: list[float] = field(default_factory=list)
    x: list[float] = field(default_factory=list)
    y: list[float] = field(default_factory=list)
    length: list[float] = field(default_factory=list)
    """Path length of the tip from the crack's start."""
    speed: list[float] = field(default_factory=list)
    """Least-squares slope of ``length`` over the last records."""
    ended: float = math.nan
    """The time of its last tip, once it has had none for more than
    :data:`PATIENCE` records or its crack has merged; NaN while it goes on."""


@dataclass
class Crack:
    """One crack: where and when it started."""

    origin: tuple[float, float]
    born: float
    from_notch: bool
    arms: list[int] = field(default_factory=list)
    """Indices of its arms in :attr:`Cracks.arms`, in order of birth."""
    merged: float = math.nan
    """When it met an older crack and became part of it."""
    start: int = -1
    """The point from which its path lengths are measured."""


@dataclass
class Cracks:
    """The cracks and arms of a run (:func:`track_cracks`)."""

    cracks: list[Crack]
    arms: list[Arm]
    spacing: float
    """The point spacing the lengths ``link`` and ``separation`` are in."""

    def initiation(self, advance: float = INITIATION_ADVANCE) -> float:
        """When an arm of the crack from the notch first reached ``advance``
        (scene units) from the notch tip; NaN if none did."""
        times = [t for a in self.arms if self.cracks[a.crack].from_notch
                 for t, length in zip(a.t, a.length) if length >= advance]
        return min(times, default=math.nan)

    def branching(self) -> float:
        """When the crack from the notch first had two arms at once; NaN if never."""
        for crack in self.cracks:
            if crack.from_notch and len(crack.arms) > 1:
                return self.arms[crack.arms[1]].born
        return math.nan


def spacing_of(xy: np.ndarray) -> float:
    """The median distance of each point to its nearest neighbour."""
    d, _ = cKDTree(xy).query(xy, k=2)
    return float(np.median(d[:, 1]))


def track_cracks(xy: np.ndarray, times: np.ndarray, record_times: np.ndarray, notch=None,
                 samples: int = 9, spacing: float | None = None, link: float = LINK,
                 separation: float = SEPARATION, max_records: int = MAX_RECORDS) -> Cracks:
    """The cracks and their arms (see the module's text).

    Parameters
    ----------
    xy : (N, 2) ndarray
        Where each point cracked.
    times : (N,) ndarray
        When each cracked (the record times at which it was first found cracked).
    record_times : (M,) ndarray
        The records of the run (``energies.csv``'s ``t``).
    notch : ((float, float), (float, float)) or None
        The initial notch's tip and the direction it points, or ``None``.
    samples : int
        Records in each speed fit, at least 2.
    spacing : float or None
        The point spacing (default :func:`spacing_of` the points).
    link, separation : float
        In point spacings.
    max_records : int
        At most this many of the records at which points cracked are analysed.
    """
    xy, times = np.asarray(xy, dtype=float).reshape(-1, 2), np.asarray(times, dtype=float)
    order = np.argsort(times, kind="stable")
    xy, times = xy[order], times[order]
    if spacing is None:
        spacing = spacing_of(xy) if len(xy) > 1 else 1.0
    records = np.unique(np.asarray(record_times, dtype=float))
    tracker = _Tracker(xy, times, records[0] if len(records) else 0.0, notch, link * spacing,
                       separation * spacing)
    counts = np.searchsorted(times, records, side="right")
    changed = np.flatnonzero(np.diff(counts, prepend=0) > 0)
    if len(changed) > max_records:
        changed = changed[np.linspace(0, len(changed) - 1, max_records).round().astype(int)]
    analysed = set(changed.tolist())
    for k, t in enumerate(records):
        if k in analysed:
            tracker.analyse(float(t), int(counts[k]))
        tracker.tick()
        for a in tracker.live:
            arm = tracker.arms[a]
            if arm.t[-1] != t:  # no new tip at this record: it holds
                for series in (arm.x, arm.y, arm.length):
                    series.append(series[-1])
                arm.t.append(float(t))
            arm.speed.append(speed_fit(arm.t[-samples:], arm.length[-samples:]))
    return Cracks(tracker.cracks, tracker.arms, spacing)


class _Tracker:
    """The cracks and arms found so far, and the arms alive."""

    def __init__(self, xy, times, first_record, notch, reach, apart):
        self.xy, self.reach, self.apart = xy, reach, apart
        self.hops = math.ceil(apart / reach)
        n = len(xy)
        pairs = cKDTree(xy).query_pairs(reach, output_type="ndarray")
        i, j = np.concatenate((pairs[:, 0], pairs[:, 1])), np.concatenate((pairs[:, 1], pairs[:, 0]))
        self.graph = csr_matrix((np.hypot(*(xy[i] - xy[j]).T), (i, j)), shape=(n, n))
        # The notch's own band: cracked at the first record; with the points
        # behind its tip, no tip of the crack from the notch lies there.
        self.tip = None
        self.initial = times <= first_record
        if notch is not None:
            self.tip = np.asarray(notch[0], dtype=float)
            heading = np.asarray(notch[1], dtype=float) / math.hypot(*notch[1])
            self.notch_band = self.initial | ((xy - self.tip) @ heading < -reach)
        self.cracks: list[Crack] = []
        self.arms: list[Arm] = []
        self.by_first: dict[int, int] = {}  # a crack's first point -> its index
        self.live: list[int] = []  # the arms with a tip now
        self.lost: dict[int, int] = {}  # arms without one: for how many records

    def analyse(self, t: float, m: int) -> None:
        """The cracks and tips at time ``t``, when the first ``m`` points have cracked."""
        xy, sub = self.xy[:m], self.graph[:m, :m]
        # The graph is symmetric: its strong components are its connected ones,
        # and its directed paths its paths (scipy then keeps the matrix as it is).
        _, label = connected_components(sub, directed=True, connection="strong")
        first = np.full(label.max() + 1, m)
        np.minimum.at(first, label, np.arange(m))
        now = {comp: self._crack(t, int(p), label == comp, xy) for comp, p in enumerate(first)}
        for first_point, index in self.by_first.items():
            crack = self.cracks[index]
            if index not in now.values() and math.isnan(crack.merged):
                crack.merged = t
        # Each crack's arms go on as arms of the crack it is part of now.
        part_of = {index: now[label[p]] for p, index in self.by_first.items()}
        # Path lengths from each crack's start: the crack from the notch's from
        # the notch's own band, so that the band's thickening is not growth.
        sources = np.zeros(m, dtype=bool)
        sources[[self.cracks[c].start for c in now.values()]] = True
        notched = np.zeros(m, dtype=bool)
        if self.tip is not None:
            notched = np.isin(label, [comp for comp, c in now.items() if self.cracks[c].from_notch])
            sources |= notched & self.initial[:m]
        length = dijkstra(sub, directed=True, indices=np.flatnonzero(sources), min_only=True)
        # A tip is no nearer its crack's start than any point within `hops`
        # links of it (as far as `apart`: a bulge of a band's side is not a
        # tip); of the crack from the notch, it lies ahead of the notch's
        # band and at least a link from it.
        farthest = length
        linked = sub.copy()
        for _ in range(self.hops):
            linked.data = farthest[linked.indices]
            farthest = np.maximum(farthest, linked.max(axis=1).toarray().ravel())
        candidate = length >= farthest
        if self.tip is not None:
            candidate &= ~(notched & (self.notch_band[:m] | (length < self.reach)))
        live = []
        for comp, c in now.items():
            points = np.flatnonzero(candidate & (label == comp))
            points = points[np.argsort(-length[points], kind="stable")]
            arms = {i for i, j in part_of.items() if j == c}
            live += self._follow(t, c, arms, self._tips(points, arms, xy), xy, length)
        for a in self.live:
            if a not in live:
                self.lost[a] = 0
        for a in live:
            self.lost.pop(a, None)
        self.live = sorted(live)

    def tick(self) -> None:
        """One record more: an arm without a tip for more than
        :data:`PATIENCE` records, or whose crack has merged, has ended."""
        for a in list(self.lost):
            self.lost[a] += 1
            if self.lost[a] > PATIENCE or not math.isnan(self.cracks[self.arms[a].crack].merged):
                self.arms[a].ended = self.arms[a].t[-1]
                del self.lost[a]

    def _tips(self, points: np.ndarray, cracks: set[int], xy: np.ndarray) -> list[int]:
        """The tips among the candidate ``points`` (farthest along first): each
        at least ``apart`` from every farther one, or half that for the
        candidate nearest a live arm's last tip of ``cracks``, so that an arm
        once found is not lost while another passes near it."""
        held = set()
        for a in self.live + list(self.lost):
            arm = self.arms[a]
            if arm.crack in cracks and len(points):
                d = np.hypot(xy[points, 0] - arm.x[-1], xy[points, 1] - arm.y[-1])
                if d.min() <= 2.0 * self.apart:
                    held.add(int(points[np.argmin(d)]))
        tips: list[int] = []
        for p in points:
            gap = 0.5 * self.apart if p in held else self.apart
            if all(math.hypot(*(xy[p] - xy[q])) > gap for q in tips):
                tips.append(int(p))
        return tips

    def _crack(self, t: float, first: int, members: np.ndarray, xy: np.ndarray) -> int:
        """The index of the crack whose first point is ``first``, new if it has none."""
        if first not in self.by_first:
            index = np.flatnonzero(members)
            from_notch = False
            if self.tip is not None:
                distance = np.hypot(*(xy[index] - self.tip).T)
                from_notch = bool(distance.min() <= self.reach)
            start = int(index[np.argmin(distance)]) if from_notch else first
            origin = self.tip if from_notch else xy[first]
            self.by_first[first] = len(self.cracks)
            self.cracks.append(Crack(origin=(float(origin[0]), float(origin[1])), born=t,
                                     from_notch=from_notch, start=start))
        return self.by_first[first]

    def _follow(self, t: float, c: int, cracks: set[int], tips: list[int], xy: np.ndarray,
                length: np.ndarray) -> list[int]:
        """Give each arm of ``cracks`` (crack ``c`` and those that merged
        into it) its nearest tip of ``c`` within 2 ``apart`` (for an arm
        without a tip since an earlier record, further by 1.5 times its last
        speed over the time since), nearest pairs first; the tips left start
        new arms of ``c``. Returns the arms with a tip."""
        def reach(a: int) -> float:  # 2 `apart`, and further by how far a lost arm may have run since
            arm = self.arms[a]
            return 2.0 * self.apart + 1.5 * abs(arm.speed[-1] if arm.speed else 0.0) * (t - arm.t[-1])

        pairs = sorted((math.hypot(self.arms[a].x[-1] - xy[p, 0], self.arms[a].y[-1] - xy[p, 1]), a, p)
                       for a in self.live + list(self.lost) if self.arms[a].crack in cracks for p in tips)
        taken: dict[int, int] = {}  # tip -> arm
        for d, a, p in pairs:
            if d <= reach(a) and a not in taken.values() and p not in taken:
                taken[p] = a
        for p in tips:
            if p not in taken:
                taken[p] = len(self.arms)
                self.cracks[c].arms.append(len(self.arms))
                self.arms.append(Arm(crack=c, born=t))
            arm = self.arms[taken[p]]
            arm.t.append(t)
            arm.x.append(float(xy[p, 0]))
            arm.y.append(float(xy[p, 1]))
            arm.length.append(float(length[p]))
        return list(taken.values())



def scene_cracks(scene: Scene, xy: np.ndarray, times: np.ndarray, record_times: np.ndarray) -> Cracks:
    """:func:`track_cracks` of a run of ``scene``: from the tip of its first
    initial crack, with its ``output.crack_speed_samples``."""
    return track_cracks(xy, times, record_times, notch=scene.cracks[0].tip(),
                        samples=scene.output.crack_speed_samples)


def run_cracks(scene: Scene, run_dir: Path | str) -> dict:
    """Write a completed run's ``crack_arms.csv`` (per arm and record: the
    tip, its path length and speed) and ``crack_arms.png``, from its
    :data:`~pfmpm.observe.CRACK_PATH` and ``energies.csv``.

    Returns
    -------
    dict
        ``initiation`` and ``branching`` of the crack from the notch (NaN if
        none), ``rayleigh`` speed, ``cracks`` (each with ``origin``, ``born``,
        ``from_notch``, ``merged`` and its ``arms``: ``born``, ``ended``,
        ``tip_end``, ``length_end``, ``max_speed``), ``csv``, ``png`` and
        ``units`` (length, time, speed).
    """
    run_dir = Path(run_dir)
    path = run_dir / CRACK_PATH
    if not path.is_file():
        raise FileNotFoundError(f"{run_dir}: no {CRACK_PATH} (the run did not complete, or a pfmpm"
                                " before 2026-12-07 ran it)")
    xy, times = read_crack_path(path)
    arms = scene_cracks(scene, xy, times, read_columns(run_dir / "energies.csv")["t"])
    csv, png = run_dir / "crack_arms.csv", run_dir / "crack_arms.png"
    log = CsvLog(csv, ["arm", "crack", "t", "x", "y", "length", "speed"])
    for a, arm in enumerate(arms.arms):
        for row in zip(arm.t, arm.x, arm.y, arm.length, arm.speed):
            log.write(dict(zip(log.columns, (a + 1, arm.crack + 1, *row))))
    log.close()
    units = unit_system(scene.units)
    rayleigh = scene.crack_rayleigh_speed()
    plots.crack_arms(arms, png, rayleigh, units)
    cracks = []
    for crack in arms.cracks:
        cracks.append({"origin": crack.origin, "born": crack.born, "from_notch": crack.from_notch,
                       "merged": crack.merged, "arms": [
                           {"arm": a + 1, "born": arms.arms[a].born, "ended": arms.arms[a].ended,
                            "tip_end": (arms.arms[a].x[-1], arms.arms[a].y[-1]),
                            "length_end": arms.arms[a].length[-1],
                            "max_speed": max(arms.arms[a].speed)} for a in crack.arms]})
    return {"initiation": arms.initiation(), "branching": arms.branching(), "rayleigh": rayleigh,
            "cracks": cracks, "csv": str(csv), "png": str(png),
            "units": {q: units.unit(q) for q in ("length", "time", "speed")}}
