"""Set a scene up on the C++ core and drive a run with output."""

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

from . import _core
from .crack import CrackTip, initial_history
from .output import CsvLog, ParticleSeries
from .scene import Scene

ENERGY_COLUMNS = ["step", "t", "kinetic", "elastic", "fracture", "external_work", "total",
                  "momentum_x", "momentum_y"]
"""Columns of ``energies.csv``;
``total = kinetic + elastic + fracture + friction_dissipation - external_work``, where the
friction dissipation is zero without a ``[contact]`` table."""
CONTACT_COLUMNS = ["friction_dissipation"]
"""Extra ``energies.csv`` columns of scenes with contact: the energy the friction forces took
out since t = 0, then ``fracture_<body>`` per body."""
CRACK_COLUMNS = ["crack_tip_x", "crack_tip_y", "crack_tip_speed"]
"""Extra ``energies.csv`` columns of scenes with an initial crack (see :class:`~pfmpm.crack.CrackTip`)."""


class Simulation:
    """A :class:`~pfmpm.scene.Scene` set up on the C++ core.

    Attributes
    ----------
    scene : Scene
    grid : pfmpm._core.Grid
    particles : pfmpm._core.Particles
        Particle arrays as zero-copy numpy views (``x``, ``v``, ``stress``, ...).
    solver : pfmpm._core.Solver
    crack_tip : CrackTip or None
        Tracks the tip of the first initial crack, if any.
    """

    def __init__(self, scene: Scene):
        self.scene = scene
        g = scene.grid
        self.grid = _core.Grid(g.degree, list(g.cells), g.h, list(g.origin))
        for wall in scene.walls:
            self.grid.set_wall(_core.Side.__members__[wall.side], _core.Wall.__members__[wall.type])
        arrays = scene.particles()
        self.particles = _core.Particles(len(arrays["mass"]))
        for name, values in arrays.items():
            getattr(self.particles, name)[...] = values
        plane = _core.Plane.__members__[scene.plane]
        materials, fracture = [], []
        for m in scene.materials:
            f = m.fracture
            split = _core.Split.__members__[f.split if f else "none"]
            materials.append(_core.LinearElastic(m.E, m.nu, m.density, plane, split))
            fracture.append(_core.Fracture(f.Gc, f.l0, f.k_f, f.gamma().tolist()) if f else None)
        self.cracks = any(fracture)
        self._crackable = np.zeros(len(self.particles), dtype=bool)
        for b, body in enumerate(scene.bodies):
            if scene.fracture_of(body) is not None:
                self._crackable |= self.particles.body == b
        self._impose_cracks()
        pf = scene.phase_field
        names = tuple(b.name for b in scene.bodies)
        self.contact = scene.contact is not None and len(names) > 1
        friction = scene.contact.friction_matrix(names).ravel() if self.contact else []
        self.solver = _core.Solver(self.grid, self.particles, materials, scene.dt(), fracture,
                                   pf.tol, pf.max_iterations, friction)
        self.solver.set_phase_field_preconditioner(_core.Preconditioner.__members__[pf.preconditioner])
        self.solver.set_stability_length(scene.critical_length())
        self.crack_tip = None
        if scene.cracks:
            out = scene.output
            self.crack_tip = CrackTip.for_crack(scene.cracks[0], out.crack_threshold,
                                                out.crack_speed_samples)
        if self.cracks:
            self.solver.prepare()  # the phase field of the initial cracks

    def _impose_cracks(self) -> None:
        """Set the initial history of every crack on the particles of its bodies."""
        bodies = {body.name: b for b, body in enumerate(self.scene.bodies)}
        for crack in self.scene.cracks:
            names = [crack.body] if crack.body else [
                body.name for body in self.scene.bodies if self.scene.fracture_of(body)]
            for name in names:
                body = self.scene.bodies[bodies[name]]
                sel = np.flatnonzero(self.particles.body == bodies[name])
                h0 = initial_history(self.particles.x[sel], crack, self.scene.fracture_of(body))
                self.particles.history[sel] = np.maximum(self.particles.history[sel], h0)

    @property
    def columns(self) -> list[str]:
        """Columns of ``energies.csv`` for this scene."""
        columns = ENERGY_COLUMNS + (CRACK_COLUMNS if self.crack_tip else [])
        if self.contact:
            columns += CONTACT_COLUMNS + [f"fracture_{b.name}" for b in self.scene.bodies]
        return columns

    @property
    def time(self) -> float:
        return self.solver.time

    @property
    def step(self) -> int:
        return self.solver.step_count

    def advance(self, steps: int) -> None:
        """Take ``steps`` explicit steps in C++."""
        self.solver.advance(steps)

    def energies(self) -> dict[str, float]:
        """Energies and momentum now, with the columns of ``energies.csv``."""
        e = self.solver.energies()
        by_body = e.pop("fracture_by_body")
        e["step"] = self.step
        e["t"] = self.time
        friction = -e.pop("friction_work")
        e["total"] = e["kinetic"] + e["elastic"] + e["fracture"] - e["external_work"] + friction
        if self.contact:
            e["friction_dissipation"] = friction
            for body, value in zip(self.scene.bodies, by_body):
                e[f"fracture_{body.name}"] = value
        return e

    def crack_tip_record(self) -> dict[str, float]:
        """Record the crack tip now: ``crack_tip_x``, ``crack_tip_y``, ``crack_tip_speed``."""
        sel = self._crackable
        x, y, speed = self.crack_tip.update(self.time, self.particles.x[sel], self.particles.c[sel])
        return {"crack_tip_x": x, "crack_tip_y": y, "crack_tip_speed": speed}

    def point_data(self) -> dict[str, np.ndarray]:
        """Particle fields for output; stress as a symmetric tensor (xx, yy, zz, xy, yz, xz)."""
        s = self.particles.stress
        stress = np.zeros((len(s), 6))
        stress[:, [0, 1, 2, 3]] = s[:, [0, 1, 3, 2]]
        data = {
            "velocity": self.particles.v,
            "stress": stress,
            "body": self.particles.body,
            "material": self.particles.material,
        }
        if self.cracks:
            data["c"] = self.particles.c
            data["history"] = self.particles.history
        return data

    def modules(self) -> list[str]:
        """The parts of the method this scene switches on."""
        active = ["explicit_mpm"]
        if self.scene.walls:
            active.append("walls")
        if self.scene.loads:
            active.append("external_loads")
        if self.cracks:
            active.append("phase_field")
        if self.cracks and self.solver.phase_field_stats()["fourth_order"]:
            active.append("fourth_order_phase_field")
        if self.scene.cracks:
            active.append("initial_cracks")
        if self.contact:
            active.append("contact")
        return active

    def run(self, out_dir: Path | str, progress: bool = True, checkpoint_every: int = 0,
            keep: int = 3, resume=None) -> "RunResult":
        """Run to ``scene.time.end``, writing output to ``out_dir``.

        Writes ``energies.csv`` every ``output.energies_every`` steps, particle
        snapshots every ``output.every`` steps (and at the start and end), and
        ``summary.json``.

        Parameters
        ----------
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

        Notes
        -----
        SIGINT (Ctrl-C) and SIGTERM stop the run after the current chunk of
        steps, write a checkpoint and leave everything written so far intact;
        the summary says "interrupted". A :class:`~pfmpm._core.SimulationError`
        (a non-finite value, a particle off the grid, an unstable step) stops
        it with status "failed" after writing the state as it was to
        ``checkpoints/failed_step_*.h5`` for inspection.
        """
        from tqdm import tqdm

        from . import checkpoint

        if checkpoint_every < 0 or keep < 1:
            raise ValueError(f"checkpoint_every = {checkpoint_every}, keep = {keep}: need >= 0 and >= 1")
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        cfg = self.scene.output
        total = self.scene.steps()
        if resume is not None:
            checkpoint.restore(self, resume)
            tmp = out / "energies.csv.tmp"
            tmp.write_bytes(resume.energies_csv)
            tmp.replace(out / "energies.csv")
        series = ParticleSeries(out, resume.series if resume else ()) if cfg.particles else None
        log = CsvLog(out / "energies.csv", self.columns, append=resume is not None)
        snapshots = Snapshots(self.scene) if self.cracks and cfg.snapshots else None
        if snapshots is not None and resume is not None:
            snapshots.restore(resume.snapshot_times, resume.snapshot_images)
        state = _OutputState(out, series, snapshots)

        def save(status: str = "ok", error: str | None = None) -> None:
            result.checkpoint = str(checkpoint.write(out / checkpoint.DIRECTORY, self, state,
                                                     every=checkpoint_every, keep=keep,
                                                     status=status, error=error))

        result = RunResult(out_dir=out, steps_planned=total)
        if resume is not None:
            result.resumed_from = str(resume.path)
        start = _time.perf_counter()
        bar = tqdm(total=total, initial=self.step, disable=not progress, unit="step", desc=self.scene.name)
        every = [cfg.energies_every] + ([cfg.every] if series is not None else [])
        try:
            with _stop_on_signals() as caught:
                result.status, result.error = step_to_end(
                    self, total, every, lambda force: self._record(log, series, snapshots, force), bar,
                    checkpoint=save, checkpoint_every=checkpoint_every, stop=lambda: bool(caught),
                    first_record=resume is None)
                result.signal = caught[0] if caught else None
                if result.status == "interrupted":
                    save()
                elif result.status == "failed":
                    save("failed", result.error)
        finally:
            bar.close()
            log.close()
            result.wall_s = _time.perf_counter() - start
            result.steps = self.step
            result.light_nodes = self.solver.light_nodes
            self._write_summary(out / "summary.json", result)
        if result.status == "completed":
            from . import plots

            plots.energies(out / "energies.csv", out / "energies.png")
            if self.crack_tip:
                plots.crack_tip(out / "energies.csv", out / "crack_tip.png",
                                self.scene.crack_rayleigh_speed())
        if snapshots is not None and snapshots.images:
            from . import plots

            plots.phase_field(snapshots, out / "phase_field.png", self._polar_overlay())
        return result

    def _polar_overlay(self):
        """``1/G_c(theta)`` of the first anisotropic body, drawn at the initial
        crack tips (or the body's centre) on the phase-field snapshots; or None."""
        from .anisotropy import polar_table

        for body in self.scene.bodies:
            f = self.scene.fracture_of(body)
            if f is not None and f.anisotropy is not None and f.anisotropy.fourth_order:
                x0, y0, x1, y1 = body.shape.bounds()
                h = self.scene.grid.h
                tips = [p for crack in self.scene.cracks if crack.body in (None, body.name)
                        for p in (crack.points[0], crack.points[-1])
                        if x0 + h <= p[0] <= x1 - h and y0 + h <= p[1] <= y1 - h]
                if not tips:
                    tips = [(0.5 * (x0 + x1), 0.5 * (y0 + y1))]
                return tips, polar_table(f.gamma(), f.Gc, body.orientation)
        return None

    def _record(self, log: CsvLog, series: ParticleSeries | None,
                snapshots: "Snapshots | None", force: bool) -> None:
        cfg = self.scene.output
        e = self.energies()
        if not all(math.isfinite(v) for v in e.values()):
            bad = [k for k, v in e.items() if not math.isfinite(v)]
            raise _core.SimulationError(f"{', '.join(bad)} not finite at step {self.step} (t = {self.time:g})")
        if force or self.step % cfg.energies_every == 0:
            if self.crack_tip:
                e.update(self.crack_tip_record())
            log.write(e)
        if snapshots is not None:
            snapshots.take(self.time, self.solver.dt, self.particles.x[self._crackable],
                           self.particles.c[self._crackable])
        if series is not None and (force or self.step % cfg.every == 0):
            series.write(self.step, self.time, self.particles.x, self.point_data())

    def _write_summary(self, path: Path, result: "RunResult") -> None:
        fields = {
            "scene": self.scene.name,
            "dt": self.solver.dt,
            "t_end": self.time,
            "particles": len(self.particles),
            "particle_steps_per_s": len(self.particles) * result.steps / max(result.wall_s, 1e-12),
            "threads": _core.num_threads(),
            "modules": self.modules(),
            "grid": {"cells": list(self.scene.grid.cells), "h": self.scene.grid.h, "degree": self.scene.grid.degree},
            "light_nodes": self.solver.light_nodes,
        }
        if self.cracks:
            stats = self.solver.phase_field_stats()
            stats["mean_iterations"] = stats["iterations"] / max(stats["solves"], 1)
            fields["phase_field"] = stats
        if self.contact:
            # Checks C.1-C.4 of Algorithm 1, counted over the whole run.
            stats = self.solver.contact_stats()
            fields["contact"] = {
                "contact_nodes_last_step": stats["nodes"],
                "node_pairs": stats["pairs"],
                "active_node_pairs": stats["active"],
                "sliding_node_pairs": stats["sliding"],
                "violations": {c: stats[c] for c in ("C1", "C2", "C3", "C4")},
                "friction_dissipation": -stats["friction_work"],
            }
        result.write_summary(path, fields)


@dataclass
class RunResult:
    """What :meth:`Simulation.run` did."""

    out_dir: Path
    steps_planned: int
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

    def write_summary(self, path: Path, fields: dict) -> None:
        """Write ``summary.json``: this result's status, steps and wall time, then ``fields``.

        Written to a temporary file and renamed, so a reader never sees half of it.
        """
        summary = {
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


def step_to_end(sim, total: int, every: list[int], record, bar, *, checkpoint=None,
                checkpoint_every: int = 0, stop=None, first_record: bool = True) -> tuple[str, str | None]:
    """Advance ``sim`` to step ``total``, calling ``record(force)`` on the way.

    ``sim`` has ``step`` and ``advance(n)`` (a :class:`Simulation` or a
    :class:`pfmpm.fem.FemSimulation`). It stops at every multiple of each
    entry of ``every`` and calls ``record`` there, with ``force=True`` at the
    start (unless not ``first_record``, for a resumed run whose first record
    exists) and the end; with ``checkpoint_every``, it also stops at its
    multiples and calls ``checkpoint()`` there. Those extra stops only split
    the calls to ``advance``, so the results do not depend on them. Before
    each chunk it asks ``stop()`` and ends the run if it says so. Returns
    ``(status, error)``: ``"completed"``, ``"interrupted"`` (``stop()`` or
    Ctrl-C, after the current chunk) or ``"failed"`` with the
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
    """What a checkpoint needs of a run's output: the CSV so far, the particle
    series entries and the phase-field images."""

    def __init__(self, out: Path, series: ParticleSeries | None, snapshots: "Snapshots | None"):
        self._csv = out / "energies.csv"
        self._series = series
        self._snapshots = snapshots

    def energies_csv(self) -> bytes:
        return self._csv.read_bytes()

    def series_entries(self) -> list[tuple[float, str]]:
        return self._series.entries if self._series is not None else []

    def snapshot_state(self) -> tuple[list[float], list[tuple[float, np.ndarray]]]:
        if self._snapshots is None:
            return [], []
        return list(self._snapshots.times), list(self._snapshots.images)


class Snapshots:
    """Phase-field images at the scene's ``output.snapshots`` times.

    Each image is the mean particle phase field per pixel of side
    ``h / particles_per_cell``, taken at the first record at or after the
    requested time (the last record for times past the end).
    """

    def __init__(self, scene: Scene):
        self.times = sorted(scene.output.snapshots)
        g = scene.grid
        self.pixel = g.h / max(b.particles_per_cell for b in scene.bodies)
        self.origin = np.asarray(g.origin, dtype=float)
        self.shape = tuple(int(round(s / self.pixel)) for s in g.size)
        self.images: list[tuple[float, np.ndarray]] = []
        self._last: tuple[float, np.ndarray, np.ndarray] | None = None
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
        """Mean of ``c`` per pixel, NaN where no particle lies; shape (ny, nx)."""
        ij = np.floor((xy - self.origin) / self.pixel).astype(np.int64)
        nx, ny = self.shape
        ij[:, 0] = np.clip(ij[:, 0], 0, nx - 1)
        ij[:, 1] = np.clip(ij[:, 1], 0, ny - 1)
        key = ij[:, 1] * nx + ij[:, 0]
        total = np.bincount(key, weights=c, minlength=nx * ny)
        count = np.bincount(key, minlength=nx * ny)
        with np.errstate(invalid="ignore", divide="ignore"):
            return (total / count).reshape(ny, nx)
