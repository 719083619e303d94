"""Set a scene up on the C++ core and run it (the run loop is :mod:`pfmpm.run`)."""

from __future__ import annotations

import hashlib
import math
import os
from collections.abc import Iterator
from functools import cached_property
from pathlib import Path

import numpy as np

from . import _core
from .crack import initial_history
from .post.tip import crack_area
from .output import ParticleSeries, Rows
from .run import SIDES, RunResult, energy_columns, region_columns, run_to_end, wall_columns
from .scene import Scene, SceneError, seeding
from .scene.report import SetupReport, setup_report
from .scene.validation import at

CONTACT_COLUMNS = ["friction_dissipation"]
"""Extra ``energies.csv`` columns of scenes with contact: the energy the friction forces took
out since t = 0, then ``fracture_<body>`` per body."""


def columns_sha256(columns: list[dict], values: dict[str, np.ndarray]) -> str:
    """The SHA-256 of particle columns (``Particles.columns()``) with these
    ``values`` (rows in ascending id order): each column's name, then its bytes."""
    digest = hashlib.sha256()
    for c in columns:
        digest.update(c["name"].encode())
        digest.update(np.ascontiguousarray(values[c["name"]]).tobytes())
    return digest.hexdigest()


def dissipation_columns(kinds) -> list[str]:
    """Extra ``energies.csv`` columns of scenes whose models dissipate work
    (a core column declared as the sum of a kind of dissipation: ``dissipated``
    of damage, ``plastic_work`` of plasticity): per kind, ``<kind>_dissipation``,
    the work dissipated since t = 0, part of ``total``."""
    return [f"{kind}_dissipation" for kind in kinds]



def adaptive_threads() -> bool:
    """Whether the solver adapts each step's thread count to the machine's load
    (the C++ ThreadGovernor; docs/performance/threads.md):
    yes unless the environment sets ``PFMPM_ADAPTIVE_THREADS=0``."""
    value = os.environ.get("PFMPM_ADAPTIVE_THREADS", "1")
    if value not in ("0", "1"):
        raise SceneError("PFMPM_ADAPTIVE_THREADS", "must be 0 or 1", value)
    return value == "1"


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


_BLOCK = 1 << 16  # particles per block where the set-up works on blocks
SNAPSHOT_PIXELS = 1 << 18
"""The most pixels of a phase-field image (``phase_field.png``): enough for
any figure, and a bound on what the images of a run hold."""


class Simulation:
    """A :class:`~pfmpm.scene.Scene` set up on the C++ core, in 2D or 3D.

    Attributes
    ----------
    scene : Scene
    grid : pfmpm._core.Grid or pfmpm._core.Grid3
    particles : pfmpm._core.Particles
        Particle arrays as zero-copy numpy views, one attribute per column
        (``x``, ``v``, ``stress``, ...: ``dir(sim.particles)`` lists them,
        ``sim.particles.columns()`` says what each holds); ``x`` and ``v``
        are (N, 2) or (N, 3), the stress (N, 4) or (N, 6) (xx, yy, xy, zz,
        then in 3D yz, xz).
    solver : pfmpm._core.Solver or pfmpm._core.Solver3
    cracks : bool
        Whether a body can crack (its material has a fracture table).
    """

    comm = None
    """No MPI communicator: one process, on OpenMP threads (a rank of many
    is a :class:`pfmpm.parallel.DistributedSimulation`)."""
    checkpoints = True
    """The MPM path writes checkpoints and resumes from them."""

    def __init__(self, scene: Scene):
        self.scene = scene
        g = scene.grid
        three = g.dim == 3
        self.grid = (_core.Grid3 if three else _core.Grid)(g.degree, list(g.cells), g.h, list(g.origin))
        for wall in scene.walls:
            self.grid.set_wall(_core.Side.__members__[wall.side], _core.Wall.__members__[wall.type])
        for i, region in enumerate(scene.prescribed):
            if not region.box:
                self.grid.add_particle_region(region.mask)
            else:
                try:
                    self.grid.add_region(list(region.min), list(region.max), region.mask, region.moving)
                except ValueError:
                    raise SceneError(f"prescribed[{i}].max", f"the box from min = {list(region.min)} holds"
                                                             f" no grid node (control point)",
                                     list(region.max)) from None
            if region.steady:
                self.grid.set_region_velocity(i, list(region.velocity))
        xs, ids = seeding.seed(scene)
        self.particles = _core.Particles(sum(len(x) for x in xs), g.dim)
        core = self._fill(xs, ids)
        # From here on each body's seeding ids are views of the id column they
        # were written to, in seeding order: no second array of them while the
        # models' columns are added.
        ids = np.split(self.particles.id, np.cumsum([len(x) for x in xs[:-1]]))
        materials, fracture = core_materials(scene)
        self.cracks = any(fracture)
        pf = scene.phase_field
        names = tuple(b.name for b in scene.bodies)
        contact = scene.contact
        self.damage_gradient = contact is not None and contact.damage_gradient
        self.contact = contact is not None and (len(names) > 1 or self.damage_gradient)
        friction = contact.friction_matrix(names).ravel() if self.contact else []
        partition = (_core.Partition.damage_gradient if self.damage_gradient
                     else _core.Partition.bodies if self.contact else _core.Partition.single)
        damage = _core.DamageGradient()
        if self.damage_gradient:
            damage = _core.DamageGradient(contact.group_indices(names), {
                "separability": contact.separability, "kernel_radius": contact.resolved_radius(g.h, g.dim),
                "skin": contact.skin, "phase_field_threshold": contact.phase_field_threshold,
                "parting": contact.parting})
        # The solver adds the models' columns; then their initial values.
        self.solver = (_core.Solver3 if three else _core.Solver)(
            self.grid, self.particles, materials, scene.dt(), fracture, pf.tol, pf.max_iterations, partition,
            friction, damage, _core.ShapeFunctions.__members__[g.shape], g.scale_failed, g.failed_c,
            _core.TransferScheme.__members__[scene.transfer.scheme])
        self.solver.adaptive_threads = adaptive_threads()
        self.solver.set_phase_field_preconditioner(_core.Preconditioner.__members__[pf.preconditioner])
        if self.contact:
            self.solver.set_touch_fill(contact.touch_fill)
        columns = self._fill(xs, done=core)  # the models' columns the seeding sets: orientation, CPDI domains
        self._amplified = self._amplified_loads(xs, ids)
        self._hold_particles(xs, ids)
        self._impose_damage(xs, ids)
        del xs, ids
        self._initial_columns()
        if scene.transfer.scheme == "apic":
            self._initial_affine()
        self.dissipation = sorted({kind for m in materials for kind in m.dissipation})
        """The kinds of work the scene's models dissipate (``"damage"``, ``"plastic"``)."""
        if self.damage_gradient:
            self._flag_surfaces()
        self._crackable = np.array([scene.fracture_of(body) is not None for body in scene.bodies])
        """Whether each body's particles can crack, by body index."""
        self._all_crackable = bool(self._crackable.all())
        self._impose_cracks()
        self.solver.set_stability_length(scene.critical_length())
        if self.cracks or self.damage_gradient or scene.initial_damage:
            # The phase field of the initial cracks; the damage-gradient fields;
            # the CPDI domains of initially failed particles.
            self.solver.prepare()

    def _flag_surfaces(self) -> None:
        """Surface flags at t = 0 (Homel & Herbold 2017, section 2.4): the particles
        inside ``contact.surfaces``, and with ``contact.surface_detection = "kernel_sum"``
        those whose kernel sum over their own body is below the threshold."""
        contact = self.scene.contact
        x = self.particles.x
        for shape in contact.surfaces:
            self.particles.surface[shape.contains(*x.T)] = 1
        if contact.surface_detection == "kernel_sum":
            spacing = [b.spacing(self.scene.grid.h) for b in self.scene.bodies]
            self.solver.detect_surfaces(spacing, contact.surface_threshold)

    def _fill(self, xs: list[np.ndarray], ids: list[np.ndarray] | None = None,
              done: set[str] = frozenset()) -> set[str]:
        """Seed the particles' columns, those not in ``done``, in place
        (:func:`pfmpm.scene.seeding.fill`) from the bodies' positions ``xs``
        and ids ``ids`` (needed while ``id`` is not done); return the names
        of all columns there are now."""
        names = {c["name"] for c in self.particles.columns()}
        seeding.fill(self.scene, xs, {name: getattr(self.particles, name) for name in names - done}, ids)
        return names

    def _initial_columns(self) -> None:
        """Set each material's initial column values on its particles
        (``MaterialSpec.initial_columns``: a Weibull strength field)."""
        for i, m in enumerate(self.scene.materials):
            sel = np.flatnonzero(self.particles.material == i)
            with at(f"materials[{i}]"):
                values = m.initial_columns(self.scene, self.particles.volume[sel])
            for name, value in values.items():
                getattr(self.particles, name)[sel] = value

    def _impose_damage(self, xs: list[np.ndarray], ids: list[np.ndarray]) -> None:
        """Set the damage of every ``[[initial_damage]]`` entry on the particles its
        region selects at t = 0, the largest D where entries overlap; before the
        first step and the set-up's solver preparation, so that the stresses, the
        damage-gradient fields and the CPDI domains see it from the start. A
        resumed run sets it too, then takes the checkpoint's ``damage`` column.

        The region selects from each body's seeding, its positions ``xs`` and
        ids ``ids`` in seeding order (where its ``particles`` index), and the
        damage goes to the rows of the ids selected."""
        damage = self.particles.damage if self.scene.initial_damage else None
        for entry in self.scene.initial_damage:
            for b in self.scene.initial_damage_bodies(entry):
                for start in range(0, len(xs[b]), _BLOCK):  # a block at a time: no copies of all
                    block = slice(start, start + _BLOCK)
                    hit = seeding.rows_of(self.particles.id, ids[b][block][entry.select(xs[b][block], start)])
                    damage[hit] = np.maximum(damage[hit], entry.D)

    def _initial_affine(self) -> None:
        """With APIC, the affine matrices of the bodies seeded with a velocity
        gradient: each particle's for the field ``velocity_gradient`` about it
        (``Solver.set_velocity_gradients``)."""
        gradients = np.array([b.velocity_gradient for b in self.scene.bodies], dtype=float)
        if np.any(gradients):
            self.solver.set_velocity_gradients(gradients[self.particles.body])

    def _impose_cracks(self) -> None:
        """Set the initial history of every crack on the particles of its bodies."""
        bodies = {body.name: b for b, body in enumerate(self.scene.bodies)}
        for crack in self.scene.cracks:
            names = [crack.body] if crack.body else [
                body.name for body in self.scene.bodies if self.scene.fracture_of(body)]
            for name in names:
                body = self.scene.bodies[bodies[name]]
                sel = np.flatnonzero(self.particles.body == bodies[name])
                for start in range(0, len(sel), _BLOCK):  # a block at a time: no copies of all
                    part = sel[start:start + _BLOCK]
                    h0 = initial_history(self.particles.x[part], crack, self.scene.fracture_of(body))
                    self.particles.history[part] = np.maximum(self.particles.history[part], h0)

    def _body_pairs(self) -> list[tuple[int, int]]:
        """The pairs of bodies a < b whose contact impulses ``energies.csv``
        keeps: with each body its own field, the first ``max_pair_fields``."""
        if not self.contact or self.damage_gradient:
            return []
        n = min(len(self.scene.bodies), _core.max_pair_fields)
        return [(a, b) for b in range(n) for a in range(b)]

    def columns(self, observed: list[str] = ()) -> list[str]:
        """Columns of ``energies.csv`` for this scene (:func:`pfmpm.run.energy_columns`,
        the walls' and the prescribed regions'): with more than one body
        also each body's momentum, ``momentum_x_<body>`` and ``momentum_y_<body>``
        (and ``momentum_z_<body>`` in 3D),
        then the columns ``observed`` of the run's observers
        (:meth:`pfmpm.observe.Observer.columns`), then those of the models
        and of contact: with each body its own field the contact impulse of
        each pair, ``contact_<a>_<b>_x|y`` (and ``_z`` in 3D; of body b on body a since t = 0)."""
        dim = self.scene.dim
        columns = (energy_columns(dim) + wall_columns(self.scene.walls, dim)
                   + region_columns(self.scene.prescribed, dim))
        if len(self.scene.bodies) > 1:
            columns += [f"momentum_{d}_{b.name}" for b in self.scene.bodies for d in "xyz"[:dim]]
        columns += list(observed)
        columns += dissipation_columns(self.dissipation)
        if self.contact:
            columns += CONTACT_COLUMNS + [f"fracture_{b.name}" for b in self.scene.bodies]
        names = [b.name for b in self.scene.bodies]
        columns += [f"contact_{names[a]}_{names[b]}_{d}" for a, b in self._body_pairs()
                    for d in "xyz"[:self.scene.dim]]
        return columns

    @property
    def time(self) -> float:
        return self.solver.time

    @property
    def step(self) -> int:
        return self.solver.step_count

    def advance(self, steps: int) -> None:
        """Take ``steps`` explicit steps in C++; with loads or prescribed
        motion that change over time, one at a time, each with the external
        forces at its midpoint time and the prescribed velocities over it."""
        if not self._amplified and all(r.steady for r in self.scene.prescribed):
            self.solver.advance(steps)
            return
        for _ in range(steps):
            self._set_step_loads()
            self.solver.advance(1)

    def _set_step_loads(self) -> None:
        """The external forces of the loads with an amplitude at the midpoint
        of the next step, and the velocities of the unsteady prescribed
        regions over it."""
        t = self.time
        if self._amplified:
            # The loads are kept by particle id: their rows are looked up each step.
            steady, touched, loads = self._amplified
            fext, ids = self.particles.fext, self.particles.id
            rows, held = self._load_rows(ids, touched)
            fext[rows] = steady[held]
            for amplitude, particles, force in loads:
                fext[self._load_rows(ids, particles)[0]] += amplitude(t + 0.5 * self.dt) * force
        for k, region in enumerate(self.scene.prescribed):
            if not region.steady:
                self.grid.set_region_velocity(k, list(region.velocity_over(t, self.dt)))

    @staticmethod
    def _load_rows(ids: np.ndarray, wanted: np.ndarray) -> tuple:
        """The rows of the particles ``wanted`` and which of them they are:
        all of them, in one process (:func:`pfmpm.scene.seeding.rows_of`)."""
        return seeding.rows_of(ids, wanted), slice(None)

    def _hold_particles(self, xs: list[np.ndarray], ids: list[np.ndarray]) -> None:
        """Mark the particles of each body's prescribed region in the column
        ``held_by`` (bit k for region k), whose nodes the grid then holds."""
        members = seeding.region_particles(self.scene, xs, ids)
        if all(region is None for region in members):
            return
        held = self.particles.held_by
        for k, region in enumerate(members):
            if region is not None:
                held[seeding.rows_of(self.particles.id, region)] |= np.int32(1 << k)

    def _amplified_loads(self, xs: list[np.ndarray], ids: list[np.ndarray]) -> tuple | None:
        """The loads with an amplitude, for :meth:`advance`, by particle id: the
        ids of the particles they touch (ascending), the force there of the
        loads without one (in that order), and each load's (amplitude, ids,
        force at amplitude 1) (:func:`pfmpm.scene.seeding.load_forces`); None
        without any."""
        if all(load.amplitude is None for load in self.scene.loads):
            return None
        forces = seeding.load_forces(self.scene, xs, ids)
        loads = [(load.amplitude, particles, force) for load, particles, force in forces
                 if load.amplitude is not None]
        touched = np.unique(np.concatenate([particles for _, particles, _ in loads]))
        steady = np.zeros((len(touched), self.scene.dim))
        for load, particles, force in forces:
            if load.amplitude is None:
                _, at, _ = np.intersect1d(touched, particles, assume_unique=True, return_indices=True)
                steady[at] += force
        return steady, touched, loads

    def energies(self) -> dict[str, float]:
        """Energies and momentum now, with the columns of ``energies.csv``."""
        e = self._raw_energies()
        axes = "xyz"[:self.scene.dim]
        by_body = e.pop("fracture_by_body")
        impulse = e.pop("wall_impulse")
        for wall in self.scene.walls:
            for d, value in zip(axes, impulse[SIDES.index(wall.side)]):
                e[f"impulse_{wall.side}_{d}"] = value
        region_impulse, region_work = e.pop("region_impulse"), e.pop("region_work")
        region_displacement = e.pop("region_displacement")
        pair_impulse = e.pop("pair_impulse")
        for a, b in self._body_pairs():
            name = f"contact_{self.scene.bodies[a].name}_{self.scene.bodies[b].name}"
            for d, value in zip(axes, pair_impulse[_core.field_pair(a, b)]):
                e[f"{name}_{d}"] = value
        for k, region in enumerate(self.scene.prescribed):
            name = region.name
            for d, impulse_d, displacement_d in zip(axes, region_impulse[k], region_displacement[k]):
                e[f"impulse_{name}_{d}"] = impulse_d
                e[f"displacement_{name}_{d}"] = displacement_d
            e[f"work_{name}"] = region_work[k]
        body_momentum = np.reshape(e.pop("momentum_by_body"), (-1, self.scene.dim))
        if len(self.scene.bodies) > 1:
            for d, name in enumerate(axes):
                for body, value in zip(self.scene.bodies, body_momentum[:, d]):
                    e[f"momentum_{name}_{body.name}"] = value
        e["step"] = self.step
        e["t"] = self.time
        friction = -e.pop("friction_work")
        dissipation = e.pop("dissipation")
        e["total"] = (e["kinetic"] + e["elastic"] + e["fracture"] - e["external_work"]
                      - e["wall_work"] - sum(region_work[:len(self.scene.prescribed)]) + friction)
        for kind in self.dissipation:
            e[f"{kind}_dissipation"] = dissipation[kind]
            e["total"] += dissipation[kind]
        if self.contact:
            e["friction_dissipation"] = friction
            for body, value in zip(self.scene.bodies, by_body):
                e[f"fracture_{body.name}"] = value
        return e

    def _raw_energies(self) -> dict:
        """The core's energies (``Solver.energies``)."""
        return self.solver.energies()

    def crack_points(self) -> tuple[np.ndarray, np.ndarray]:
        """The positions and phase field of the particles that can crack (the
        crack tip, the crack path and the phase-field images of
        :mod:`pfmpm.observe` watch them): views of the columns, no copies,
        when every particle can."""
        return self._of_crackable(self.particles.x), self._of_crackable(self.particles.c)

    def crack_ids(self) -> np.ndarray:
        """The ids of the points of :meth:`crack_points`, in their order: the
        particles' global ids (a view of the column when every particle can
        crack), by which the crack path keeps them."""
        return self._of_crackable(self.particles.id)

    def crack_area(self) -> float:
        """The crack surface area ``int Z dV`` of the crackable particles
        (:func:`pfmpm.post.tip.crack_area`): each particle's fracture energy
        over its material's G_c, as of the last step of an advance (in 2D an
        area times the thickness)."""
        gc = np.array([f.Gc if (f := self.scene.fracture_of(b)) is not None else np.inf
                       for b in self.scene.bodies])
        return crack_area(self._of_crackable(self.particles.fracture_energy),
                          self._of_crackable(gc[self.particles.body]))

    def _of_crackable(self, column: np.ndarray) -> np.ndarray:
        """A particle column's rows of the crackable particles, those of a
        crackable body (by the ``body`` column now): the column itself (a view,
        no copy) when every particle is crackable."""
        return column if self._all_crackable else column[self._crackable[self.particles.body]]

    @cached_property
    def setup(self) -> SetupReport:
        """The set-up report of the scene (:func:`pfmpm.scene.report.setup_report`):
        each body's seeded extent, the gaps between bodies and when they
        close, what sets the time step, and warnings."""
        return setup_report(self.scene)

    def legend(self) -> dict[str, int]:
        """What the integer particle columns stand for, as the VTU files' field
        data: ``{"body <name>": index, ..., "material <name>": index, ...}``."""
        return {**{f"body {b.name}": i for i, b in enumerate(self.scene.bodies)},
                **{f"material {m.name}": i for i, m in enumerate(self.scene.materials)}}

    def point_data(self, values: dict[str, np.ndarray] | None = None) -> Iterator[tuple[str, np.ndarray, str]]:
        """The particle output as :func:`pfmpm.output.write_vtu` takes it, (name,
        array, layout), made one array at a time: every column that declares an
        output name, under that name, as a view (:func:`pfmpm.output.vtk_values`
        says how tensors are written: ``velocity``, ``volume``, ``stress``,
        ``strain``, ``body``, ``material``, ``id``, the particle's global id
        (:func:`pfmpm.scene.seeding.seed_body`), with a phase field ``c`` and
        ``history``), then ``displacement`` (:meth:`displacement`) and
        ``damage`` (``1 - c``, with a phase field), these two as
        :class:`~pfmpm.output.Rows`, made a block at a time as they are written.
        With ``values``, of those columns (by name) instead of this process's
        particle arrays: all ranks' particles, gathered."""
        get = (lambda name: getattr(self.particles, name)) if values is None else values.__getitem__
        for c in self.particles.columns():
            if c["output"]:
                yield c["output"], get(c["name"]), c["layout"]
        x, ids = get("x"), get("id")
        yield "displacement", Rows.of(len(ids), lambda a, b: x[a:b] - seeding.seeded_positions(self.scene, ids[a:b])), ""
        if self.cracks:
            phase = get("c")
            yield "damage", Rows.of(len(ids), lambda a, b: 1.0 - phase[a:b]), ""

    def displacement(self) -> np.ndarray:
        """Each particle's displacement from its seeded position, in row order.
        The seeded position is not kept: it is read back from the particle's
        id (:func:`pfmpm.scene.seeding.seeded_positions`), so a resumed run
        gets the same start."""
        return self.particles.x - seeding.seeded_positions(self.scene, self.particles.id)

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
        if self.scene.initial_damage:
            active.append("initial_damage")
        if self.contact:
            active.append("contact")
        active += [{"damage": "damage", "plastic": "plasticity"}.get(k, k) for k in self.dissipation]
        if self.scene.transfer.scheme == "apic":
            active.append("apic")
        if self.damage_gradient:
            active.append("damage_gradient")
            if self.scene.contact.surface_detection != "none" or self.scene.contact.surfaces:
                active.append("surface_flags")
        return active

    def run(self, out_dir: Path | str, progress: bool = True, checkpoint_every: int = 0,
            keep: int = 3, resume=None, draw: bool = True, overwrite: bool = False,
            observers=None) -> RunResult:
        """Run to ``scene.time.end``, writing output to ``out_dir``: see
        :func:`pfmpm.run.run_to_end`, which takes the same parameters.

        The field series is ``particles.pvd`` with a VTU file per output
        step (with ``output.particles``).
        """
        return run_to_end(self, out_dir, progress, checkpoint_every, keep, resume, draw, overwrite, observers)

    # -- what the run loop of pfmpm.run asks of a simulation -----------------

    @property
    def dt(self) -> float:
        """The time step."""
        return self.solver.dt

    @property
    def field_series(self) -> bool:
        """Whether a run writes the particle series (``output.particles``)."""
        return self.scene.output.particles

    def open_frames(self, out: Path, entries=()) -> "_ParticleFrames":
        """The particle series ``particles.pvd`` of a run in ``out``, continuing
        the series ``entries`` ((time, file name) of those written before)."""
        return _ParticleFrames(self, ParticleSeries(out, entries, self.legend()))

    def snapshot_pixels(self) -> tuple[float, tuple[float, float], tuple[int, int], float]:
        """The pixels of the phase-field images (``output.snapshots``,
        :class:`~pfmpm.observe.Snapshots`): ``(pixel, origin, shape,
        reach)``, a pixel per (finest) spacing of the crackable bodies'
        particles, or larger pixels where that would make more than
        :data:`SNAPSHOT_PIXELS`, over the grid, each showing the nearest
        particle within the coarsest spacing."""
        g = self.scene.grid
        spacings = [b.spacing(g.h) for b in self.scene.bodies if self.scene.fracture_of(b)]
        pixel = max(min(spacings), math.sqrt(g.size[0] * g.size[1] / SNAPSHOT_PIXELS))
        return pixel, tuple(g.origin), tuple(int(round(s / pixel)) for s in g.size), max(spacings)

    def contact_record(self) -> dict:
        """The contact entry of ``summary.json`` now: the contact nodes of the last
        step, the node-pairs examined, active and sliding, the violations of the
        checks C.1-C.4 and the friction dissipation over the run; with the damage
        gradient also the split and separable nodes, the surface particles, the
        kernel radius, the neighbour-list builds and the seconds per block.
        Empty without a ``[contact]`` table."""
        if not self.contact:
            return {}
        # Checks C.1-C.4 of Algorithm 1, counted over the whole run.
        stats = self.solver.contact_stats()
        record = {
            "contact_nodes_last_step": stats["nodes"],
            "node_pairs": stats["pairs"],
            "active_node_pairs": stats["active"],
            "sliding_node_pairs": stats["sliding"],
            "violations": {c: stats[c] for c in ("C1", "C2", "C3", "C4")},
            "friction_dissipation": -stats["friction_work"],
        }
        if self.damage_gradient:
            # Homel & Herbold 2017: nodes where a group's two fields meet, the
            # separable ones (H&H eq. 21), the neighbour lists and the cost per block.
            part = self.solver.damage_partition()
            record.update({
                "split_nodes_last_step": stats["split"],
                "separable_nodes_last_step": stats["separable"],
                "separable_node_steps": stats["separable_total"],
                "surface_particles": int(np.count_nonzero(self.particles.surface)),
                "kernel_radius": part["radius"],
                "neighbour_builds": part["neighbour_builds"],
                "seconds": part["seconds"],
            })
        return record

    def checkpoint_state(self) -> tuple[dict[str, np.ndarray], dict] | None:
        """What a checkpoint keeps of the run (:func:`pfmpm.checkpoint.write`):
        every particle column by name (views) and the solver state."""
        return self._column_views(), self.solver.state()

    def _column_views(self) -> dict[str, np.ndarray]:
        """Every particle column by name, as views."""
        return {c["name"]: getattr(self.particles, c["name"]) for c in self.particles.columns()}

    def seeded_ids(self) -> np.ndarray:
        """The ids of all particles the scene seeds, ascending: those a
        checkpoint of the scene must hold, row by row."""
        return self.particles.id

    def restore_state(self, columns: dict[str, np.ndarray], state: dict) -> None:
        """Continue from a checkpoint's particle ``columns`` (every particle,
        rows in id order, the ids checked) and solver ``state``
        (:func:`pfmpm.checkpoint.restore`).

        Raises
        ------
        ValueError
            If the solver state does not fit this run.
        """
        for name, values in columns.items():
            if name != "id":
                getattr(self.particles, name)[...] = values
        self.solver.restore(state)

    def state_sha256(self) -> str:
        """The SHA-256 of the particle state: every column, in ``columns()``
        order, its name and then its values, rows in ascending id order. A
        run on any number of ranks gives the same."""
        return columns_sha256(self.particles.columns(), self._column_views())

    def light_momentum(self) -> float:
        """A bound on the momentum the light grid nodes held (``Solver.light_nodes``,
        given zero velocity), over the run so far, as a fraction of the bodies'
        total mass times the top particle speed: a node's momentum is at most
        its mass (at most ``Solver.mass_tol``) times the top speed, so the
        fraction is at most ``light_nodes * mass_tol / total mass``."""
        return self.solver.light_nodes * self.solver.mass_tol / float(np.sum(self.particles.mass))

    def summary_fields(self, result: RunResult) -> dict:
        """The MPM entries of ``summary.json``: sizes, speed, the parts of the method
        switched on, the seconds per stage of the step, the set-up report,
        the light nodes, phase-field and contact statistics."""
        fields = {
            "dt": self.solver.dt,
            "t_end": self.time,
            "particles": len(self.particles),
            "particle_steps_per_s": len(self.particles) * result.steps / max(result.wall_s, 1e-12),
            "ranks": 1,
            "threads": _core.num_threads(),
            # Steps the solver ran on fewer threads, finding them faster (ThreadGovernor).
            "reduced_thread_steps": self.solver.reduced_thread_steps,
            "modules": self.modules(),
            "grid": {"cells": list(self.scene.grid.cells), "h": self.scene.grid.h, "degree": self.scene.grid.degree,
                     "shape": self.scene.grid.shape},
            "light_nodes": self.solver.light_nodes,
            "light_momentum": self.light_momentum(),
            # Wall seconds per stage of the step (the damage-gradient blocks in contact.seconds).
            "seconds": self.solver.stage_seconds(),
            "setup": self.setup.to_dict(),
            "particles_sha256": self.state_sha256(),
        }
        if self.cracks:
            stats = self.solver.phase_field_stats()
            stats["mean_iterations"] = stats["iterations"] / max(stats["solves"], 1)
            fields["phase_field"] = stats
        if self.contact:
            fields["contact"] = self.contact_record()
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
