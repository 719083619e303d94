"""Set a scene up on the C++ core and drive a run with output."""

from __future__ import annotations

import json
import math
import time as _time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import _core
from .output import CsvLog, ParticleSeries
from .scene import Scene

ENERGY_COLUMNS = ["step", "t", "kinetic", "elastic", "external_work", "total", "momentum_x", "momentum_y"]


class Simulation:
    """A :class:`~pfmpm.scene.Scene` set up on the C++ core.

    Attributes
    ----------
    scene : Scene
    grid : pfmpm._core.Grid
    particles : pfmpm._core.Particles
        Particle arrays as zero-copy numpy views (``x``, ``v``, ``stress``, ...).
    solver : pfmpm._core.Solver
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
        materials = [_core.LinearElastic(m.E, m.nu, m.density, plane) for m in scene.materials]
        self.solver = _core.Solver(self.grid, self.particles, materials, scene.dt())

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
        e["step"] = self.step
        e["t"] = self.time
        e["total"] = e["kinetic"] + e["elastic"] - e["external_work"]
        return e

    def point_data(self) -> dict[str, np.ndarray]:
        """Particle fields for output; stress as a symmetric tensor (xx, yy, zz, xy, yz, xz)."""
        s = self.particles.stress
        stress = np.zeros((len(s), 6))
        stress[:, [0, 1, 2, 3]] = s[:, [0, 1, 3, 2]]
        return {
            "velocity": self.particles.v,
            "stress": stress,
            "body": self.particles.body,
            "material": self.particles.material,
        }

    def modules(self) -> list[str]:
        """The parts of the method this scene switches on."""
        active = ["explicit_mpm"]
        if self.scene.walls:
            active.append("walls")
        if self.scene.loads:
            active.append("external_loads")
        return active

    def run(self, out_dir: Path | str, progress: bool = True) -> "RunResult":
        """Run to ``scene.time.end``, writing output to ``out_dir``.

        Writes ``energies.csv`` every ``output.energies_every`` steps, particle
        snapshots every ``output.every`` steps (and at the start and end), and
        ``summary.json``. Ctrl-C stops the run after the current chunk of steps
        with everything written so far intact; the summary says so.
        """
        from tqdm import tqdm

        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        cfg = self.scene.output
        total = self.scene.steps()
        series = ParticleSeries(out) if cfg.particles else None
        log = CsvLog(out / "energies.csv", ENERGY_COLUMNS)
        result = RunResult(out_dir=out, steps_planned=total)
        start = _time.perf_counter()
        bar = tqdm(total=total, disable=not progress, unit="step", desc=self.scene.name)
        try:
            self._record(log, series, force=True)
            while self.step < total:
                nxt = min(_next_multiple(self.step, cfg.energies_every), total)
                if series is not None:
                    nxt = min(nxt, _next_multiple(self.step, cfg.every))
                before = self.step
                self.advance(nxt - before)
                bar.update(self.step - before)
                self._record(log, series, force=self.step == total)
            result.status = "completed"
        except KeyboardInterrupt:
            result.status = "interrupted"
        except _core.SimulationError as err:
            result.status = "failed"
            result.error = str(err)
        finally:
            bar.close()
            log.close()
            result.wall_s = _time.perf_counter() - start
            result.steps = self.step
            self._write_summary(out / "summary.json", result)
        if result.status == "completed":
            _plot_energies(out / "energies.csv", out / "energies.png")
        return result

    def _record(self, log: CsvLog, series: ParticleSeries | None, force: bool) -> None:
        cfg = self.scene.output
        e = self.energies()
        if not all(math.isfinite(v) for v in e.values()):
            bad = [k for k, v in e.items() if not math.isfinite(v)]
            raise _core.SimulationError(f"{', '.join(bad)} not finite at step {self.step} (t = {self.time:g})")
        if force or self.step % cfg.energies_every == 0:
            log.write(e)
        if series is not None and (force or self.step % cfg.every == 0):
            series.write(self.step, self.time, self.particles.x, self.point_data())

    def _write_summary(self, path: Path, result: "RunResult") -> None:
        summary = {
            "scene": self.scene.name,
            "status": result.status,
            "error": result.error,
            "steps": result.steps,
            "steps_planned": result.steps_planned,
            "dt": self.solver.dt,
            "t_end": self.time,
            "wall_s": result.wall_s,
            "particles": len(self.particles),
            "particle_steps_per_s": len(self.particles) * result.steps / max(result.wall_s, 1e-12),
            "threads": _core.num_threads(),
            "modules": self.modules(),
            "grid": {"cells": list(self.scene.grid.cells), "h": self.scene.grid.h, "degree": self.scene.grid.degree},
        }
        tmp = path.with_suffix(".tmp")
        tmp.write_text(json.dumps(summary, indent=2) + "\n")
        tmp.replace(path)


@dataclass
class RunResult:
    """What :meth:`Simulation.run` did."""

    out_dir: Path
    steps_planned: int
    steps: int = 0
    status: str = "running"
    error: str | None = None
    wall_s: float = 0.0


def _next_multiple(step: int, every: int) -> int:
    return (step // every + 1) * every


def _plot_energies(csv_path: Path, png_path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .output import read_csv

    e = read_csv(csv_path)
    fig, ax = plt.subplots(figsize=(6, 4))
    for name in ("kinetic", "elastic", "external_work", "total"):
        ax.plot(e["t"], e[name], label=name.replace("_", " "))
    ax.set_xlabel("t")
    ax.set_ylabel("energy")
    ax.legend()
    fig.tight_layout()
    fig.savefig(png_path, dpi=120)
    plt.close(fig)
