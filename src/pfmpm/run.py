"""The run loop shared by the MPM and FEM paths: stepping, output, signals,
checkpoints and the summary.

:func:`run_to_end` drives a *simulation*, a
:class:`~pfmpm.simulation.Simulation` or a :class:`~pfmpm.fem.FemSimulation`,
which provides:

``scene``, ``step``, ``time``, ``dt``, ``advance(n)``
    The scene and the stepping.
``comm``
    The MPI communicator of a distributed run, or ``None`` (serial).  With
    one, every call below is collective and rank 0 writes the files.
``columns``, ``energies()``
    The columns of ``energies.csv`` and a row of them now.
``crack_tip``, ``crack_tip_record()``, ``crack_path_points()``
    The :class:`~pfmpm.observe.CrackTip` of the first initial crack (or
    ``None``), the crack-tip columns of a row, and the points with the time
    each cracked (for the crack-path plot; collective, on the root).
``open_frames(out, resume)``
    The field series written every ``output.every`` steps (an object with
    ``write()`` and ``close()``), or ``None``.
``new_snapshots()``, ``offer_snapshot(snapshots)``
    The :class:`Snapshots` of the phase field (or ``None``) and handing it
    the state at a record.
``summary_fields(result)``
    The method's own entries of ``summary.json``.
``checkpoints``
    Whether it can write and resume from checkpoints (:mod:`pfmpm.checkpoint`).
"""

from __future__ import annotations

import json
import math
import signal
import threading
import time as _time
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import _core, run_folder
from .output import CsvLog, read_csv
from .post.cracks import scene_cracks
from .observe import CRACK_PATH, CrackTip, write_crack_path
from .scene import Scene

__all__ = ["ENERGY_COLUMNS", "SIDES", "wall_columns", "region_columns", "CRACK_COLUMNS", "RunResult", "Figures", "Snapshots",
           "nearest_image", "run_to_end", "step_to_end"]

ENERGY_COLUMNS = ["step", "t", "kinetic", "elastic", "fracture", "external_work", "total",
                  "momentum_x", "momentum_y"]
"""Columns of ``energies.csv``; ``total = kinetic + elastic + fracture +
friction_dissipation + damage_dissipation - external_work - wall_work -
work of the prescribed regions``, the
energy balance: it keeps its value at t = 0 where energy is conserved.  The
friction dissipation is zero without a ``[contact]`` table, the damage
dissipation without a damage model, the wall work without walls."""
SIDES = ("left", "right", "bottom", "top")
"""The grid's sides, in the order of the core's ``Side``."""


def wall_columns(walls) -> list[str]:
    """Extra ``energies.csv`` columns of a scene with ``walls``: ``wall_work``,
    the work the walls did on the bodies since t = 0 (<= 0: the kinetic energy
    they stopped), and per wall ``impulse_<side>_x`` and ``impulse_<side>_y``,
    the impulse of its reaction on the bodies since t = 0 (force x time; at a
    corner a direction that two walls hold counts as the one it is normal to).
    :func:`pfmpm.post.forces.wall_forces` turns them into forces."""
    if not walls:
        return []
    return ["wall_work"] + [f"impulse_{w.side}_{d}" for w in walls for d in "xy"]


def region_columns(regions) -> list[str]:
    """Extra ``energies.csv`` columns of a scene's ``[[prescribed]]``
    regions, per region: ``work_<name>``, the work it did on the bodies
    since t = 0 (part of ``total``); ``impulse_<name>_x|y``, the impulse of
    its reaction; ``displacement_<name>_x|y``, how far its nodes have moved
    along the components it holds."""
    return [c for r in regions for c in (f"work_{r.name}", f"impulse_{r.name}_x", f"impulse_{r.name}_y",
                                         f"displacement_{r.name}_x", f"displacement_{r.name}_y")]

CRACK_COLUMNS = CrackTip.columns()
"""Extra ``energies.csv`` columns of scenes with an initial crack: the crack tip
and the tip of each branch (see :class:`~pfmpm.observe.CrackTip`)."""


@dataclass
class RunResult:
    """What a run (:func:`run_to_end`) did."""

    out_dir: Path
    steps_planned: int
    run_id: str | None = None
    """The run's id (:mod:`pfmpm.run_folder`), which its checkpoints carry."""
    steps: int = 0
    status: str = "running"
    error: str | None = None
    wall_s: float = 0.0
    signal: int | None = None
    """The signal that interrupted the run, if one did."""
    checkpoint: str | None = None
    """The last checkpoint written."""
    resumed_from: str | None = None
    """The checkpoint the run continued from."""
    light_nodes: int = 0
    """Grid node-steps whose mass was too small to divide by (see ``Solver.light_nodes``)."""
    light_momentum: float = 0.0
    """The most momentum they held, over the total mass times the top speed
    (:meth:`~pfmpm.simulation.Simulation.light_momentum`)."""
    figures: "Figures | None" = None
    """The figures still to draw, from :func:`run_to_end` with ``draw=False``."""

    def write_summary(self, path: Path, fields: dict) -> None:
        """Write ``summary.json``: this result's status, steps and wall time, then ``fields``.

        Written to a temporary file and renamed, so a reader never sees half of it.
        """
        summary = {
            "run_id": self.run_id,
            "status": self.status,
            "error": self.error,
            "steps": self.steps,
            "steps_planned": self.steps_planned,
            "wall_s": self.wall_s,
            "checkpoint": self.checkpoint,
            "resumed_from": self.resumed_from,
            **fields,
        }
        tmp = path.with_suffix(".tmp")
        tmp.write_text(json.dumps(summary, indent=2) + "\n")
        tmp.replace(path)


def run_to_end(sim, out_dir: Path | str, progress: bool = True, checkpoint_every: int = 0,
               keep: int = 3, resume=None, draw: bool = True, overwrite: bool = False) -> RunResult:
    """Run ``sim`` to ``scene.time.end``, writing its output to ``out_dir``.

    Writes ``scene.toml`` and ``summary.json`` (status ``"running"``) first
    (:mod:`pfmpm.run_folder`), ``energies.csv`` every
    ``output.energies_every`` steps, the field series (:meth:`open_frames`)
    every ``output.every`` steps (and at the start and the end),
    ``summary.json`` again at the end, and, once the run completes,
    ``energies.png``, with an initial crack ``crack_path.csv`` (where and
    when each point cracked), ``crack_tip.png`` (each crack arm's length and
    speed, :mod:`pfmpm.post.cracks`) and ``crack_path.png``, and
    ``phase_field.png`` (with ``output.snapshots``).

    Parameters
    ----------
    sim : Simulation or FemSimulation
        See the module docstring.
    out_dir : path
        Output directory; checkpoints go to its ``checkpoints/``.
    progress : bool
        Show a progress bar.
    checkpoint_every : int
        Write a checkpoint (:mod:`pfmpm.checkpoint`) every this many steps; 0: none.
    keep : int
        How many of the newest checkpoints to keep (>= 1).
    resume : pfmpm.checkpoint.Checkpoint, optional
        Continue from this checkpoint of a run of the same scene: its state
        and its output so far (``energies.csv``, the particle series, the
        crack-tip records, the phase-field images) are restored first.
        ``out_dir`` must be the checkpoint's run's folder or hold no run.
    draw : bool
        Draw the figures (:class:`Figures`) before returning; if not, the
        result's ``figures`` draws them when asked.
    overwrite : bool
        Without ``resume``: if ``out_dir`` holds another run, delete its
        files first (:data:`pfmpm.run_folder.RUN_FILES`) rather than refuse.

    Returns
    -------
    RunResult

    Raises
    ------
    NotADirectoryError
        If ``out_dir`` or a folder above it is a file.
    pfmpm.run_folder.RunFolderError
        If ``out_dir`` holds another run (and not ``overwrite``), or, with
        ``resume``, a run of another scene or with another id than the checkpoint's.

    Notes
    -----
    SIGINT (Ctrl-C) and SIGTERM stop the run after the current chunk of
    steps (on every rank at the same step), write a checkpoint where the
    simulation has them and leave everything written so far intact; the
    summary says "interrupted". A :class:`~pfmpm._core.SimulationError` (a
    non-finite value, a particle off the grid, an unstable step) stops it
    with status "failed", after writing the state as it was to
    ``checkpoints/failed_step_*.h5`` for inspection where it can.
    """
    from tqdm import tqdm

    from . import checkpoint

    if checkpoint_every < 0 or keep < 1:
        raise ValueError(f"checkpoint_every = {checkpoint_every}, keep = {keep}: need >= 0 and >= 1")
    if (checkpoint_every or resume is not None) and not sim.checkpoints:
        raise ValueError(f"{type(sim).__name__} writes no checkpoints")
    comm = sim.comm
    root = comm is None or comm.rank == 0
    # Every rank checks the folder, so that a refusal stops them all; then rank 0 takes it.
    out = (run_folder.check_fresh(out_dir, overwrite) if resume is None
           else run_folder.check_resume(out_dir, resume))
    if comm is not None:
        comm.barrier()
    cfg = sim.scene.output
    total = sim.scene.steps()
    result = RunResult(out_dir=out, steps_planned=total)
    if resume is not None:
        checkpoint.restore(sim, resume)
        result.resumed_from = str(resume.path)
    if root:
        result.run_id = run_folder.start(out, sim.scene, overwrite, resume)
        result.write_summary(out / "summary.json", {"scene": sim.scene.name, "units": sim.scene.units})
    if comm is not None:
        comm.barrier()
    if resume is not None:
        tmp = out / "energies.csv.tmp"
        tmp.write_bytes(resume.energies_csv)
        tmp.replace(out / "energies.csv")
    log = CsvLog(out / "energies.csv", sim.columns, append=resume is not None) if root else None
    frames = sim.open_frames(out, resume)
    snapshots = sim.new_snapshots()
    if snapshots is not None and resume is not None:
        snapshots.restore(resume.snapshot_times, resume.snapshot_images)
    state = _OutputState(out, frames, snapshots, result.run_id,
                         run_folder.scene_digest(sim.scene.to_dict()))

    def record(force: bool) -> None:
        e = sim.energies()
        bad = [k for k, v in e.items() if not math.isfinite(v)]
        if bad:
            raise _core.SimulationError(f"{', '.join(bad)} not finite at step {sim.step} (t = {sim.time:g})")
        if force or sim.step % cfg.energies_every == 0:
            if sim.crack_tip is not None:
                e.update(sim.crack_tip_record())
            if log is not None:
                log.write(e)
        sim.offer_snapshot(snapshots)
        if frames is not None and (force or sim.step % cfg.every == 0):
            frames.write()

    def save(status: str = "ok", error: str | None = None) -> None:
        result.checkpoint = str(checkpoint.write(out / checkpoint.DIRECTORY, sim, state,
                                                 every=checkpoint_every, keep=keep,
                                                 status=status, error=error))

    start = _time.perf_counter()
    bar = tqdm(total=total, initial=sim.step, disable=not (progress and root), unit="step",
               desc=sim.scene.name)
    every = [cfg.energies_every] + ([cfg.every] if frames is not None else [])
    try:
        with _stop_on_signals() as caught:
            result.status, result.error = step_to_end(
                sim, total, every, record, bar, checkpoint=save if checkpoint_every else None,
                checkpoint_every=checkpoint_every, stop=lambda: _agree(comm, bool(caught)),
                first_record=resume is None)
            result.signal = caught[0] if caught else None
            if sim.checkpoints and result.status == "interrupted":
                save()
            elif sim.checkpoints and result.status == "failed":
                save("failed", result.error)
    finally:
        bar.close()
        if frames is not None:
            frames.close()
        if log is not None:
            log.close()
        result.wall_s = _longest(comm, _time.perf_counter() - start)
        result.steps = sim.step
        fields = sim.summary_fields(result)
        result.light_nodes = fields.get("light_nodes", 0)
        result.light_momentum = fields.get("light_momentum", 0.0)
        if root:
            result.write_summary(out / "summary.json", {"scene": sim.scene.name, "units": sim.scene.units,
                                                        **fields})
    completed = result.status == "completed"
    path = sim.crack_path_points() if completed and sim.crack_tip is not None else None
    if path is not None and root:
        write_crack_path(out / CRACK_PATH, *path)
    result.figures = Figures(out, sim.scene, completed and root, path, snapshots)
    if draw:
        result.figures.draw()
        result.figures = None
    return result


@dataclass
class Figures:
    """The plots of a run: ``energies.png``, ``crack_tip.png`` and
    ``crack_path.png`` once it completes (the last two with an initial
    crack), ``phase_field.png`` with snapshots. It holds only what they need
    beyond the run's files, the cracked points and the phase-field images, so
    they can be drawn after the simulation is gone (:func:`run_to_end` with
    ``draw=False``), which ``pfmpm run`` does to keep its peak memory down."""

    out: Path
    scene: Scene
    completed: bool
    """Whether to draw the plots of a completed run (on the root rank)."""
    crack_path: tuple[np.ndarray, np.ndarray] | None
    """The points and their crack times of :meth:`crack_path_points`."""
    snapshots: "Snapshots | None"

    def draw(self) -> None:
        """Write the figures into ``out``."""
        from . import plots

        out, scene, units = self.out, self.scene, self.scene.unit_system()
        if self.completed:
            plots.energies(out / "energies.csv", out / "energies.png", units)
        if self.completed and self.crack_path is not None:
            arms = scene_cracks(scene, *self.crack_path, read_csv(out / "energies.csv")["t"])
            plots.crack_arms(arms, out / "crack_tip.png", scene.crack_rayleigh_speed(), units)
            plots.crack_path(arms, *self.crack_path, out / "crack_path.png", _crackable_bounds(scene), units)
        if self.snapshots is not None and self.snapshots.images:
            plots.phase_field(self.snapshots, out / "phase_field.png", _polar_overlay(scene), units)


def step_to_end(sim, total: int, every: list[int], record, bar, *, checkpoint=None,
                checkpoint_every: int = 0, stop=None, first_record: bool = True) -> tuple[str, str | None]:
    """Advance ``sim`` to step ``total``, calling ``record(force)`` on the way.

    ``sim`` has ``step`` and ``advance(n)``. It stops at every multiple of
    each entry of ``every`` and calls ``record`` there, with ``force=True``
    at the start (unless not ``first_record``, for a resumed run whose first
    record exists) and the end; with ``checkpoint_every``, it also stops at
    its multiples and calls ``checkpoint()`` there. Those extra stops only
    split the calls to ``advance``, so the results do not depend on them.
    Before each chunk it asks ``stop()`` and ends the run if it says so.
    Returns ``(status, error)``: ``"completed"``, ``"interrupted"``
    (``stop()`` or Ctrl-C, after the current chunk) or ``"failed"`` with the
    :class:`~pfmpm._core.SimulationError` message.
    """
    stops = every + ([checkpoint_every] if checkpoint_every else [])
    try:
        if first_record:
            record(True)
        while sim.step < total:
            if stop is not None and stop():
                return "interrupted", None
            nxt = min([(sim.step // e + 1) * e for e in stops] + [total])
            before = sim.step
            sim.advance(nxt - before)
            bar.update(sim.step - before)
            if sim.step == total or any(sim.step % e == 0 for e in every):
                record(sim.step == total)
            if checkpoint_every and sim.step % checkpoint_every == 0:
                checkpoint()
        return "completed", None
    except KeyboardInterrupt:
        return "interrupted", None
    except _core.SimulationError as err:
        return "failed", str(err)


def _agree(comm, flag: bool) -> bool:
    """Whether ``flag`` holds on any rank (collective); ``flag`` itself in a serial run."""
    if comm is None:
        return flag
    from mpi4py import MPI

    return comm.allreduce(flag, op=MPI.LOR)


def _longest(comm, seconds: float) -> float:
    """The largest of ``seconds`` over the ranks (collective); ``seconds`` in a serial run."""
    if comm is None:
        return seconds
    from mpi4py import MPI

    return comm.allreduce(seconds, op=MPI.MAX)


@contextmanager
def _stop_on_signals():
    """Within the block, SIGINT and SIGTERM are noted in the yielded list
    instead of stopping the program, so a run can end between steps; a
    second SIGINT raises KeyboardInterrupt as usual. Outside the main thread
    (where handlers cannot be set) the list stays empty."""
    caught: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield caught
        return

    def note(signum, frame):
        if caught and signum == signal.SIGINT:
            raise KeyboardInterrupt
        caught.append(signum)

    previous = {s: signal.signal(s, note) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield caught
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


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


class _OutputState:
    """What a checkpoint needs of a run's output: the CSV so far, the particle
    series entries, the phase-field images, and the run's id and scene digest
    (:mod:`pfmpm.run_folder`)."""

    def __init__(self, out: Path, frames, snapshots: "Snapshots | None", run_id: str | None,
                 scene_sha256: str):
        self._csv = out / "energies.csv"
        self._frames = frames
        self._snapshots = snapshots
        self.run_id = run_id
        self.scene_sha256 = scene_sha256

    def energies_csv(self) -> bytes:
        return self._csv.read_bytes()

    def series_entries(self) -> list[tuple[float, str]]:
        return self._frames.entries if self._frames is not None else []

    def snapshot_state(self) -> tuple[list[float], list[tuple[float, np.ndarray]]]:
        if self._snapshots is None:
            return [], []
        return list(self._snapshots.times), list(self._snapshots.images)


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
