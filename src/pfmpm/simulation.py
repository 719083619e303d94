"""Set a scene up on the C++ core and run it (the run loop is :mod:`pfmpm.run`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import _core
from .crack import initial_history
from .output import ParticleSeries, vtk_values
from .post.tip import CrackTip
from .run import CRACK_COLUMNS, ENERGY_COLUMNS, RunResult, Snapshots, run_to_end
from .scene import Scene, SceneError
from .scene.validation import at

CONTACT_COLUMNS = ["friction_dissipation"]
"""Extra ``energies.csv`` columns of scenes with contact: the energy the friction forces took
out since t = 0, then ``fracture_<body>`` per body."""
DAMAGE_COLUMNS = ["damage_dissipation"]
"""Extra ``energies.csv`` column of scenes whose models dissipate by damage (a core column
``dissipated``): the work dissipated since t = 0, part of ``total``."""


def core_materials(scene: Scene) -> tuple[list, list]:
    """The core objects of a scene's materials: each one's constitutive model
    and, if it can crack, its fracture parameters (else ``None``).

    The one place where the material entries of a scene become C++ objects.

    Raises
    ------
    SceneError
        For a material model of the scene registry that the core does not have.
    """
    core = _core.material_models()
    materials, fracture = [], []
    for i, m in enumerate(scene.materials):
        if m.model not in core:
            raise SceneError(f"materials[{i}].model", "the core has no such model (it has "
                             + ", ".join(core) + ")", m.model)
        materials.append(_core.material(m.model, m.core_parameters(scene)))
        f = m.fracture
        fracture.append(_core.Fracture(f.Gc, f.l0, f.k_f, f.gamma().tolist(),
                                       _core.Model.__members__[f.model], f.bound) if f else None)
    return materials, fracture


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

    comm = None
    """No MPI communicator: the MPM path runs in one process (on OpenMP threads)."""
    checkpoints = True
    """The MPM path writes checkpoints and resumes from them."""

    def __init__(self, scene: Scene):
        self.scene = scene
        g = scene.grid
        self.grid = _core.Grid(g.degree, list(g.cells), g.h, list(g.origin))
        for wall in scene.walls:
            self.grid.set_wall(_core.Side.__members__[wall.side], _core.Wall.__members__[wall.type])
        arrays = scene.particles()
        self.particles = _core.Particles(len(arrays["mass"]))
        core = {c["name"] for c in self.particles.columns()}
        for name in core & arrays.keys():
            getattr(self.particles, name)[...] = arrays[name]
        materials, fracture = core_materials(scene)
        self.cracks = any(fracture)
        pf = scene.phase_field
        names = tuple(b.name for b in scene.bodies)
        self.contact = scene.contact is not None and len(names) > 1
        friction = scene.contact.friction_matrix(names).ravel() if self.contact else []
        # The solver adds the models' columns; then their initial values.
        self.solver = _core.Solver(self.grid, self.particles, materials, scene.dt(), fracture,
                                   pf.tol, pf.max_iterations, friction,
                                   _core.ShapeFunctions.__members__[g.shape], g.scale_failed,
                                   g.failed_c)
        self.solver.set_phase_field_preconditioner(_core.Preconditioner.__members__[pf.preconditioner])
        columns = {c["name"] for c in self.particles.columns()}
        for name in (columns - core) & arrays.keys():
            getattr(self.particles, name)[...] = arrays[name]
        self._initial_columns(arrays["volume"])
        self.damage = "dissipated" in columns
        self._crackable = np.zeros(len(self.particles), dtype=bool)
        for b, body in enumerate(scene.bodies):
            if scene.fracture_of(body) is not None:
                self._crackable |= self.particles.body == b
        self._impose_cracks()
        self.solver.set_stability_length(scene.critical_length())
        self.crack_tip = CrackTip.for_scene(scene) if scene.cracks else None
        if self.cracks:
            self.solver.prepare()  # the phase field of the initial cracks

    def _initial_columns(self, volume: np.ndarray) -> None:
        """Set each material's initial column values on its particles
        (``MaterialSpec.initial_columns``: a Weibull strength field)."""
        for i, m in enumerate(self.scene.materials):
            sel = np.flatnonzero(self.particles.material == i)
            with at(f"materials[{i}]"):
                values = m.initial_columns(self.scene, volume[sel])
            for name, value in values.items():
                getattr(self.particles, name)[sel] = value

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
        if self.damage:
            columns += DAMAGE_COLUMNS
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
        dissipated = e.pop("dissipated")
        e["total"] = e["kinetic"] + e["elastic"] + e["fracture"] - e["external_work"] + friction
        if self.damage:
            e["damage_dissipation"] = dissipated
            e["total"] += dissipated
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
        """The particle columns that declare an output name, under that name
        (see :func:`pfmpm.output.vtk_values` for how tensors are written)."""
        return {c["output"]: vtk_values(getattr(self.particles, c["name"]), c["layout"])
                for c in self.particles.columns() if c["output"]}

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
        if self.damage:
            active.append("damage")
        return active

    def run(self, out_dir: Path | str, progress: bool = True, checkpoint_every: int = 0,
            keep: int = 3, resume=None) -> RunResult:
        """Run to ``scene.time.end``, writing output to ``out_dir``: see
        :func:`pfmpm.run.run_to_end`, which takes the same parameters.

        The field series is ``particles.pvd`` with a VTU file per output
        step (with ``output.particles``).
        """
        return run_to_end(self, out_dir, progress, checkpoint_every, keep, resume)

    # -- what the run loop of pfmpm.run asks of a simulation -----------------

    @property
    def dt(self) -> float:
        """The time step."""
        return self.solver.dt

    def open_frames(self, out: Path, resume=None) -> "_ParticleFrames | None":
        """The particle series of a run in ``out`` (continuing that of ``resume``),
        or ``None`` without ``output.particles``."""
        if not self.scene.output.particles:
            return None
        return _ParticleFrames(self, ParticleSeries(out, resume.series if resume else ()))

    def new_snapshots(self) -> Snapshots | None:
        """Phase-field images of the crackable particles at ``output.snapshots``,
        a pixel per particle spacing; ``None`` if nothing can crack or no time is given."""
        if not (self.cracks and self.scene.output.snapshots):
            return None
        g = self.scene.grid
        pixel = g.h / max(b.particles_per_cell for b in self.scene.bodies)
        return Snapshots(self.scene, pixel, g.origin, tuple(int(round(s / pixel)) for s in g.size))

    def offer_snapshot(self, snapshots: Snapshots | None) -> None:
        """Hand the crackable particles' phase field now to ``snapshots``."""
        if snapshots is not None:
            snapshots.take(self.time, self.dt, self.particles.x[self._crackable],
                           self.particles.c[self._crackable])

    def summary_fields(self, result: RunResult) -> dict:
        """The MPM entries of ``summary.json``: sizes, speed, the parts of the method
        switched on, phase-field and contact statistics."""
        fields = {
            "dt": self.solver.dt,
            "t_end": self.time,
            "particles": len(self.particles),
            "particle_steps_per_s": len(self.particles) * result.steps / max(result.wall_s, 1e-12),
            "threads": _core.num_threads(),
            "modules": self.modules(),
            "grid": {"cells": list(self.scene.grid.cells), "h": self.scene.grid.h, "degree": self.scene.grid.degree,
                     "shape": self.scene.grid.shape},
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
        return fields


class _ParticleFrames:
    """The particle series of a run: ``write()`` adds the particles now."""

    def __init__(self, sim: Simulation, series: ParticleSeries):
        self._sim = sim
        self._series = series

    @property
    def entries(self) -> list[tuple[float, str]]:
        """(time, file name) of each VTU file so far, for a checkpoint."""
        return self._series.entries

    def write(self) -> None:
        sim = self._sim
        self._series.write(sim.step, sim.time, sim.particles.x, sim.point_data())

    def close(self) -> None:
        """Nothing to close: every VTU file and the index are complete when written."""
