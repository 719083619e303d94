"""The run loop shared by the MPM and FEM paths: stepping, ``energies.csv``,
the observers, signals, checkpoints and the summary.

:func:`run_to_end` drives a *simulation*, a
:class:`~pfmpm.simulation.Simulation` or a :class:`~pfmpm.fem.FemSimulation`.
What a run records besides ``energies.csv`` and ``summary.json`` (the crack
tips and path, the phase-field images, the field series, or a user's own
measure) is done by its observers (:mod:`pfmpm.observe`). A simulation
provides:

``scene``, ``step``, ``time``, ``dt``, ``advance(n)``
    The scene and the stepping.
``comm``
    The MPI communicator of a distributed run, or ``None`` (serial).  With
    one, every call below is collective and rank 0 writes the files.
``columns(observed)``, ``energies()``
    The columns of ``energies.csv``, with the observers' columns
    ``observed`` where the simulation puts them, and a row of its own
    columns now.
``summary_fields(result)``
    The method's own entries of ``summary.json``.
``checkpoints``
    Whether it can write and resume from checkpoints (:mod:`pfmpm.checkpoint`).

and, for the standard observers (:func:`~pfmpm.observe.default_observers`):

``cracks``, ``crack_points()``
    Whether anything can crack (it has a phase field), and the points that
    can, with their phase field: ``(xy, c)``, this rank's own.
``snapshot_pixels()``
    The pixels of the phase-field images: ``(pixel, origin, shape, reach)``
    of :class:`~pfmpm.observe.Snapshots`.
``field_series``, ``open_frames(out, entries)``
    Whether it writes a field series, and the series in ``out`` continuing
    ``entries`` (an object with ``write()``, ``close()`` and, for
    checkpoints, ``entries``).
"""

from __future__ import annotations

import json
import math
import signal
import threading
import time as _time
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import _core, run_folder
from .observe import Observer, default_observers
from .output import CsvLog
from .scene import Scene

__all__ = ["ENERGY_COLUMNS", "SIDES", "energy_columns", "wall_columns", "region_columns", "RunResult", "Figures",
           "run_to_end", "step_to_end"]

ENERGY_COLUMNS = ["step", "t", "kinetic", "elastic", "fracture", "external_work", "total",
                  "momentum_x", "momentum_y"]
"""Columns of ``energies.csv``; ``total = kinetic + elastic + fracture +
friction_dissipation + damage_dissipation - external_work - wall_work -
work of the prescribed regions``, the
energy balance: it keeps its value at t = 0 where energy is conserved.  The
friction dissipation is zero without a ``[contact]`` table, the damage
dissipation without a damage model, the wall work without walls."""
SIDES = ("left", "right", "bottom", "top", "back", "front")
"""The grid's sides, in the order of the core's ``Side`` (a 2D grid has the first four)."""


def energy_columns(dim: int = 2) -> list[str]:
    """The columns of ``energies.csv`` that every run of a ``dim``-dimensional
    scene has: :data:`ENERGY_COLUMNS`, and in 3D also ``momentum_z`` and the
    angular momentum about the origin, ``angular_momentum_x|y|z``."""
    if dim == 2:
        return list(ENERGY_COLUMNS)
    return ENERGY_COLUMNS + ["momentum_z", "angular_momentum_x", "angular_momentum_y", "angular_momentum_z"]


def wall_columns(walls, dim: int = 2) -> list[str]:
    """Extra ``energies.csv`` columns of a scene with ``walls``: ``wall_work``,
    the work the walls did on the bodies since t = 0 (<= 0: the kinetic energy
    they stopped), and per wall ``impulse_<side>_x`` and ``impulse_<side>_y``
    (and ``_z`` in 3D), the impulse of its reaction on the bodies since t = 0
    (force x time; at a corner a direction that two walls hold counts as the
    one it is normal to). :func:`pfmpm.post.forces.wall_forces` turns them
    into forces."""
    if not walls:
        return []
    return ["wall_work"] + [f"impulse_{w.side}_{d}" for w in walls for d in "xyz"[:dim]]


def region_columns(regions, dim: int = 2) -> list[str]:
    """Extra ``energies.csv`` columns of a scene's ``[[prescribed]]``
    regions, per region: ``work_<name>``, the work it did on the bodies
    since t = 0 (part of ``total``); ``impulse_<name>_x|y`` (``|z`` in 3D),
    the impulse of its reaction; ``displacement_<name>_x|y`` (``|z``), how
    far its nodes have moved along the components it holds."""
    axes = "xyz"[:dim]
    return [c for r in regions for c in (f"work_{r.name}", *(f"impulse_{r.name}_{d}" for d in axes),
                                         *(f"displacement_{r.name}_{d}" for d in axes))]

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
               keep: int = 3, resume=None, draw: bool = True, overwrite: bool = False,
               observers: list[Observer] | None = None) -> RunResult:
    """Run ``sim`` to ``scene.time.end``, writing its output to ``out_dir``.

    Writes ``scene.toml`` and ``summary.json`` (status ``"running"``) first
    (:mod:`pfmpm.run_folder`), ``energies.csv`` every
    ``output.energies_every`` steps (and at the start and the end), with
    the observers' columns, ``summary.json`` again at the end, and, once the
    run completes, ``energies.png``. The standard observers
    (:func:`~pfmpm.observe.default_observers`) add the field series every
    ``output.every`` steps, and with an initial crack the crack-tip columns,
    ``crack_path.csv`` (where and when each point cracked), ``crack_tip.png``
    (each crack arm's length and speed, :mod:`pfmpm.post.cracks`) and
    ``crack_path.png``, and ``phase_field.png`` (with ``output.snapshots``).

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
        and its output so far (``energies.csv`` and what the observers kept:
        the particle series, the crack-tip records, the phase-field images)
        are restored first. ``out_dir`` must be the checkpoint's run's
        folder or hold no run.
    draw : bool
        Draw the figures (:class:`Figures`) before returning; if not, the
        result's ``figures`` draws them when asked.
    overwrite : bool
        Without ``resume``: if ``out_dir`` holds another run, delete its
        files first (:data:`pfmpm.run_folder.RUN_FILES`) rather than refuse.
    observers : list of pfmpm.observe.Observer, optional
        What watches the run (:class:`~pfmpm.observe.Observer`), called in
        this order; by default :func:`~pfmpm.observe.default_observers`.
        To add one's own, pass ``default_observers(sim) + [mine]``.

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
    ValueError
        If two observers, or an observer and the simulation, give the same
        column of ``energies.csv``.

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
    observers = default_observers(sim) if observers is None else list(observers)
    columns = sim.columns([c for o in observers for c in o.columns()])
    if twice := sorted({c for c in columns if columns.count(c) > 1}):
        raise ValueError(f"energies.csv column {twice[0]} is given twice (by the simulation or its observers)")
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
        for o in observers:
            o.restore(sim, resume.observed)
        result.resumed_from = str(resume.path)
    if root:
        result.run_id = run_folder.start(out, sim.scene, overwrite, resume)
        result.write_summary(out / "summary.json", {"scene": sim.scene.name, "units": sim.scene.units})
    if comm is not None:
        comm.barrier()
    if resume is not None and root:
        tmp = out / "energies.csv.tmp"
        tmp.write_bytes(resume.energies_csv)
        tmp.replace(out / "energies.csv")
    log = CsvLog(out / "energies.csv", columns, append=resume is not None) if root else None
    for o in observers:
        o.start(sim, out)
    state = _OutputState(out, observers, result.run_id, run_folder.scene_digest(sim.scene.to_dict()))

    def record(force: bool) -> None:
        e = sim.energies()
        bad = [k for k, v in e.items() if not math.isfinite(v)]
        if bad:
            raise _core.SimulationError(f"{', '.join(bad)} not finite at step {sim.step} (t = {sim.time:g})")
        row = e if force or sim.step % cfg.energies_every == 0 else None
        for o in observers:
            o.record(sim, row, force)
        if row is not None and log is not None:
            log.write(row)

    def save(status: str = "ok", error: str | None = None) -> None:
        result.checkpoint = str(checkpoint.write(out / checkpoint.DIRECTORY, sim, state,
                                                 every=checkpoint_every, keep=keep,
                                                 status=status, error=error))

    start = _time.perf_counter()
    bar = tqdm(total=total, initial=sim.step, disable=not (progress and root), unit="step",
               desc=sim.scene.name)
    every = [cfg.energies_every] + [o.every for o in observers if o.every]
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
        if log is not None:
            log.close()
        completed = result.status == "completed"
        drawings = [o.finish(out, completed) for o in observers]
        result.wall_s = _longest(comm, _time.perf_counter() - start)
        result.steps = sim.step
        fields = sim.summary_fields(result)
        result.light_nodes = fields.get("light_nodes", 0)
        result.light_momentum = fields.get("light_momentum", 0.0)
        if root:
            result.write_summary(out / "summary.json", {"scene": sim.scene.name, "units": sim.scene.units,
                                                        **fields})
    result.figures = Figures(out, sim.scene, completed and root, [d for d in drawings if d is not None])
    if draw:
        result.figures.draw()
        result.figures = None
    return result


@dataclass
class Figures:
    """The plots of a run: ``energies.png`` once it completes, then those of
    its observers (:meth:`~pfmpm.observe.Observer.finish`: ``crack_tip.png``
    and ``crack_path.png`` of a completed run with an initial crack,
    ``phase_field.png`` with snapshots). It holds only what they need beyond
    the run's files (the cracked points, the phase-field images), so they
    can be drawn after the simulation is gone (:func:`run_to_end` with
    ``draw=False``), which ``pfmpm run`` does to keep its peak memory down."""

    out: Path
    scene: Scene
    completed: bool
    """Whether to draw the plots of a completed run (on the root rank)."""
    drawings: list[Callable[[], None]] = field(default_factory=list)
    """What draws each observer's figures."""

    def draw(self) -> None:
        """Write the figures into ``out``."""
        from . import plots

        if self.completed:
            plots.energies(self.out / "energies.csv", self.out / "energies.png", self.scene.unit_system())
        for drawing in self.drawings:
            drawing()


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


class _OutputState:
    """What a checkpoint needs of a run's output: the CSV so far, the
    observers' state, and the run's id and scene digest (:mod:`pfmpm.run_folder`)."""

    def __init__(self, out: Path, observers: list[Observer], run_id: str | None, scene_sha256: str):
        self._csv = out / "energies.csv"
        self._observers = observers
        self.run_id = run_id
        self.scene_sha256 = scene_sha256

    def energies_csv(self) -> bytes:
        return self._csv.read_bytes()

    def observed(self) -> dict[str, np.ndarray]:
        """The :meth:`~pfmpm.observe.Observer.state` of every observer, in one dict.

        Raises
        ------
        ValueError
            If two observers keep an array of the same name.
        """
        state: dict[str, np.ndarray] = {}
        for o in self._observers:
            for name, value in o.state().items():
                if name in state or name == "energies_csv":
                    raise ValueError(f"checkpoint output/{name} is kept by two observers of the run")
                state[name] = np.asarray(value)
        return state
