"""The scene: its parts put together, and the checks that need more than one part."""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import seeding, stability
from .bodies import Body
from .components import GridSpec, Output, PhaseFieldSpec, Time, TransferSpec
from .contact import Contact
from .damage import DamageSpec, InitialDamage
from .loads import MAX_REGIONS, BodyForce, Crack, Prescribed, Traction, WallSpec
from .materials import PLANES, FractureSpec, MaterialSpec
from .toml import build_scene, plain, read_toml
from .units import SOLID_WAVE_SPEEDS, UNIT_SYSTEMS, UnitSystem, unit_system
from .validation import (MAX_COUNT, SceneError, at, choice, fmt, planar, real, reference, same_dimension, seq, store,
                         text)

__all__ = ["Scene"]

_MAX_STEPS = 2**53  # step counts beyond this are not representable exactly
_BYTES_PER_TABLE_CELL = 128  # B-spline polynomial table, per cell of each direction
_BYTES_PER_PARTICLE = 320  # particle state, sort and phase-field arrays, setup temporaries
_BYTES_PER_NODE = 30
"""Per padded grid node, the active-node tables of the step (measured 2026-12-07:
29 bytes per node of a 2 x 8e6-cell grid with one particle, `ru_maxrss`)."""
_BYTES_PER_CRACK_NODE = 100
"""Per padded grid node with a phase field, besides 8 bytes per stencil entry
of its matrix: the solution, warm start, right-hand side, diagonal and the
solve's vectors (measured 2026-12-07: 208 bytes per node with degree 2, where
this and the stencil give 204 + 30)."""


@dataclass(frozen=True)
class Scene:
    """A complete, validated scene, in two or three dimensions: a grid with
    three ``size`` entries makes a 3D scene (:attr:`dim`), whose bodies have
    3D shapes and whose vectors have three components. A 3D scene runs one
    velocity field, or every body its own with frictional contact, on
    B-splines or CPDI with elastic and neo-Hookean materials (with damage); the
    phase field, initial cracks, the damage-gradient partition, plane stress
    and Drucker-Prager are two-dimensional yet and refused there.

    Parameters
    ----------
    grid : GridSpec
    time : Time
    materials : sequence of MaterialSpec
        At least one; names unique.
    bodies : sequence of Body
        At least one; names unique; each names a material, holds at least
        one particle and has none outside the grid.
    name, description : str
    plane : str
        ``"strain"`` or ``"stress"`` (a 3D scene keeps ``"strain"``, the
        plane modes' 3D parent).
    thickness : float
        Out-of-plane thickness, > 0 (a 3D scene keeps 1).
    loads : sequence of Traction or BodyForce
    walls : sequence of WallSpec
        At most one per grid side.
    prescribed : sequence of Prescribed
        Grid nodes with prescribed motion, in a box or reached by a body's
        particles; at most four, names unique.
    output : Output
    cracks : sequence of Crack
        Initial cracks, on bodies whose material can crack.
    phase_field : PhaseFieldSpec
        Phase-field solver settings (used when some material can crack).
    transfer : TransferSpec
        The particle-grid transfer: FLIP (the default) or APIC.
    contact : Contact or None
        Frictional contact between the bodies, each its own discrete field;
        ``None``: the bodies form one continuum.
    units : str
        The scene's unit system, a key of
        :data:`~pfmpm.scene.units.UNIT_SYSTEMS` (e.g. ``"mm-us-MPa"``), or
        ``""``: undeclared.  Declared units label the plots, and every
        material's P-wave speed must then be a solid's
        (:data:`~pfmpm.scene.units.SOLID_WAVE_SPEEDS`).
    initial_damage : sequence of InitialDamage
        Damage at t = 0 on regions of bodies whose material has a damage
        model; each region selects at least one particle.

    Raises
    ------
    SceneError
        On the first invalid entry.
    """

    grid: GridSpec
    time: Time
    materials: tuple[MaterialSpec, ...]
    bodies: tuple[Body, ...]
    name: str = "scene"
    description: str = ""
    plane: str = "strain"
    thickness: float = 1.0
    loads: tuple[Traction | BodyForce, ...] = ()
    walls: tuple[WallSpec, ...] = ()
    output: Output = field(default_factory=Output)
    cracks: tuple[Crack, ...] = ()
    phase_field: PhaseFieldSpec = field(default_factory=PhaseFieldSpec)
    contact: Contact | None = None
    units: str = ""
    initial_damage: tuple[InitialDamage, ...] = ()
    transfer: TransferSpec = field(default_factory=TransferSpec)
    prescribed: tuple[Prescribed, ...] = ()

    def __post_init__(self):
        self.validate()

    # -- validation ---------------------------------------------------------

    def validate(self) -> None:
        """Check the whole scene, normalising sequences to tuples.

        Raises
        ------
        SceneError
            On the first invalid entry, naming its key path.
        """
        store(self, "name", text("name", self.name))
        store(self, "description", text("description", self.description, empty=True))
        store(self, "plane", choice("plane", self.plane, PLANES))
        store(self, "thickness", real("thickness", self.thickness, gt=0))
        store(self, "units", choice("units", self.units, ("", *UNIT_SYSTEMS)))
        for key, cls in (("grid", GridSpec), ("time", Time), ("output", Output),
                         ("phase_field", PhaseFieldSpec), ("transfer", TransferSpec)):
            if not isinstance(getattr(self, key), cls):
                raise SceneError(key, f"must be a {cls.__name__}", getattr(self, key))
        store(self, "materials", self._items("materials", (MaterialSpec,), required=True))
        store(self, "bodies", self._items("bodies", (Body,), required=True))
        store(self, "loads", self._items("loads", (Traction, BodyForce)))
        store(self, "walls", self._items("walls", (WallSpec,)))
        store(self, "prescribed", self._items("prescribed", (Prescribed,)))
        if len(self.prescribed) > MAX_REGIONS:
            raise SceneError("prescribed", f"at most {MAX_REGIONS} regions", len(self.prescribed))
        store(self, "cracks", self._items("cracks", (Crack,)))
        store(self, "initial_damage", self._items("initial_damage", (InitialDamage,)))
        materials = self._unique("materials", "name", "duplicate name")
        bodies = self._unique("bodies", "name", "duplicate name")
        self._unique("walls", "side", "duplicate wall on this side")
        self._unique("prescribed", "name", "duplicate name")
        for i, body in enumerate(self.bodies):
            reference(f"bodies[{i}].material", body.material, materials, "material")
        for i, load in enumerate(self.loads):
            if load.body is not None:
                reference(f"loads[{i}].body", load.body, bodies, "body")
        for i, region in enumerate(self.prescribed):
            if region.body is not None:
                reference(f"prescribed[{i}].body", region.body, bodies, "body")
        self._check_dimension()
        for i, body in enumerate(self.bodies):
            with at(f"bodies[{i}]"):
                self._check_particles(body)
        self._check_loads()
        self._check_memory()
        self._check_fracture(bodies)
        for i, material in enumerate(self.materials):
            with at(f"materials[{i}]"):
                material.check_scene(self)
        self._check_initial_damage(bodies)
        self._check_contact(bodies)
        self._check_time()

    def _items(self, key: str, classes: tuple[type, ...], required: bool = False) -> tuple:
        """Check that field ``key`` is a sequence of ``classes`` instances."""
        items = seq(key, getattr(self, key), " or ".join(c.__name__ for c in classes))
        if required and not items:
            raise SceneError(key, "at least one entry is required")
        for i, item in enumerate(items):
            if not isinstance(item, classes):
                raise SceneError(f"{key}[{i}]", "must be a " + " or ".join(c.__name__ for c in classes), item)
        return items

    def _unique(self, key: str, attr: str, reason: str) -> dict[str, int]:
        """Check that ``attr`` is unique over field ``key``; map value -> index."""
        seen: dict[str, int] = {}
        for i, item in enumerate(getattr(self, key)):
            value = getattr(item, attr)
            if value in seen:
                raise SceneError(f"{key}[{i}].{attr}", f"{reason} (also {key}[{seen[value]}])", value)
            seen[value] = i
        return seen

    def _check_dimension(self) -> None:
        """Check that every part has the grid's dimension: the bodies' shapes
        and vectors, the loads', walls' and regions' vectors and sides; and
        that a 3D scene asks for nothing that is two-dimensional yet."""
        dim = self.grid.dim
        for key in ("bodies", "loads", "walls", "prescribed", "initial_damage", "cracks"):
            for i, item in enumerate(getattr(self, key)):
                with at(f"{key}[{i}]"):
                    item.check_dimension(dim)
        if self.contact is not None:
            for i, shape in enumerate(self.contact.surfaces):
                with at(f"contact.surfaces[{i}]"):
                    shape.check_dimension(dim)
        if self.output.crack_direction is not None:
            with at("output"):
                same_dimension("crack_direction", self.output.crack_direction, dim)
        if dim == 2:
            return
        if self.plane != "strain":
            raise planar("plane", "plane stress", self.plane)
        if self.thickness != 1.0:
            raise planar("thickness", "an out-of-plane thickness", self.thickness)
        for i, material in enumerate(self.materials):
            if material.fracture is not None and material.fracture.anisotropy is not None:
                raise planar(f"materials[{i}].fracture.anisotropy", "an anisotropic crack resistance",
                             material.fracture.anisotropy.symmetry)
            if not material.solid():
                raise planar(f"materials[{i}].model", f"the {material.model} model", material.model)
        if self.cracks and self.output.crack_direction is None:
            raise SceneError("output.crack_direction", "a 3D scene with initial cracks needs the"
                             " direction its crack front runs in, e.g. [1, 0, 0]")
        if self.output.snapshots:
            raise planar("output.snapshots", "an image of the phase field", self.output.snapshots)

    def _check_particles(self, body: Body) -> None:
        """Check that the body has particles, all inside the grid, and not too many."""
        grid = self.grid
        h, dim = grid.h, grid.dim
        bounds = body.shape.bounds()
        if any(lo < o - h or hi > o + (n + 1) * h
               for lo, hi, o, n in zip(bounds[:dim], bounds[dim:], grid.origin, grid.cells)):
            raise SceneError("shape", f"bounds {fmt(bounds)} extend more than"
                                      f" one cell beyond the grid {grid.box()}")
        ranges = seeding.cell_range(body, grid, margin=1)
        n = body.particles_per_cell
        candidates = math.prod(b - a for a, b in ranges) * n ** dim
        if candidates > MAX_COUNT:
            raise SceneError("", f"would need {candidates:.3g} candidate particles"
                                 f" (limit {MAX_COUNT}); coarsen the grid or particles_per_cell")
        inner = [(max(a, 0), min(b, cells)) for (a, b), cells in zip(ranges, grid.cells)]
        # The cells outside the grid, as slabs below and above it in each
        # direction, within the grid in the directions after it (2D: the
        # strips below and above in y, then left and right of the grid in x).
        strips = []
        for d in reversed(range(dim)):
            (a, b), cells = ranges[d], grid.cells[d]
            for part in ((a, min(b, 0)), (max(a, cells), b)):
                strips.append((*ranges[:d], part, *inner[d + 1:]))
        outside = sum(len(p) for cells in strips for p in seeding.lattice(body, grid, *cells))
        if outside:
            raise SceneError("", f"{outside} particles lie outside the grid {grid.box()}")
        if not any(len(p) for p in seeding.lattice(body, grid, *inner)):
            lattice = " x ".join([str(n)] * dim)
            raise SceneError("", f"has no particles (no sub-cell centre of the {lattice}"
                                 f" lattice per cell of h = {h:g} lies in its shape minus holes)")

    def _check_loads(self) -> None:
        """Check that every load gives its particles a finite force."""
        h, thickness = self.grid.h, self.thickness
        for i, load in enumerate(self.loads):
            bodies = self.bodies if load.body is None else [self.body(load.body)]
            for body in bodies:
                spacing = body.spacing(h)
                if isinstance(load, Traction):
                    key, vector, scale = "traction", load.traction, spacing * thickness
                else:
                    key, vector = "acceleration", load.acceleration
                    scale = self.material_of(body).density * spacing * spacing * thickness
                with np.errstate(over="ignore"):
                    finite = np.isfinite(np.multiply(vector, scale)).all()
                if not finite:
                    raise SceneError(f"loads[{i}].{key}", f"gives the particles of body {body.name!r}"
                                     " a force that is not finite", vector)

    def memory_estimate(self) -> tuple[float, float, list[int]]:
        """A rough upper estimate of the core's storage for this scene, in
        bytes: (grid, particles, the particle bound of each body), from the
        ``_BYTES_*`` constants."""
        cells, p, dim = self.grid.cells, self.grid.degree, self.grid.dim
        nodes = math.prod(n + 2 * p for n in cells)  # the phase field's padded layout
        stencil = ((2 * p + 1) ** 2 + 1) // 2
        cracks = any(m.fracture is not None for m in self.materials)
        grid = (_BYTES_PER_TABLE_CELL * sum(cells) + (8 + 8 * (os.cpu_count() or 1)) * math.prod(cells)
                + nodes * (_BYTES_PER_NODE + (_BYTES_PER_CRACK_NODE + 8 * stencil if cracks else 0)))
        counts = [seeding.lattice_size(body, self.grid) for body in self.bodies]
        return grid, _BYTES_PER_PARTICLE * sum(counts), counts

    def _check_memory(self) -> None:
        """Check that the core's storage for the grid and particles fits in
        this machine's memory (:meth:`memory_estimate`), so that a scene too
        large to run fails here, naming the key to change, rather than in an
        allocation inside the C++ core."""
        grid, particles, counts = self.memory_estimate()
        need = grid + particles
        have = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        if need > have:
            cells, i = " x ".join(map(str, self.grid.cells)), int(np.argmax(counts))
            key = "grid.size" if grid >= _BYTES_PER_PARTICLE * counts[i] else f"bodies[{i}].particles_per_cell"
            raise SceneError(key, f"{cells} cells and up to {sum(counts):.3g} particles need about"
                                  f" {need / 1e9:.3g} GB, more than this machine's {have / 1e9:.3g} GB")

    def _check_fracture(self, bodies: Mapping[str, int]) -> None:
        """Check that l0 is resolved by the grid and cracks lie on crackable bodies."""
        h = self.grid.h
        for i, material in enumerate(self.materials):
            if material.fracture is not None and material.fracture.l0 < h:
                raise SceneError(f"materials[{i}].fracture.l0",
                                 f"smaller than the grid spacing h = {h:g}, which cannot resolve"
                                 " the phase-field profile (use l0 >= h; the paper uses l0 = 2 h)",
                                 material.fracture.l0)
            anisotropy = material.fracture.anisotropy if material.fracture else None
            if anisotropy is not None and anisotropy.fourth_order and self.grid.degree < 2:
                raise SceneError(f"materials[{i}].fracture.anisotropy",
                                 "the fourth-order term needs second derivatives of C1 splines:"
                                 f" grid.degree must be 2 or 3, not {self.grid.degree}",
                                 anisotropy.symmetry)
        fractures = [m.fracture for m in self.materials if m.fracture is not None]
        fourth = any(f.anisotropy is not None and f.anisotropy.fourth_order for f in fractures)
        if self.phase_field.preconditioner == "multigrid" and not fourth and any(f.bound for f in fractures):
            raise SceneError("phase_field.preconditioner", "the bounded second-order solve takes"
                             " 'jacobi' or 'ssor' (or set fracture.bound = false)", "multigrid")
        crackable = [b.name for b in self.bodies if self.fracture_of(b) is not None]
        if self.output.snapshots and not crackable:
            raise SceneError("output.snapshots", "draws the phase field, but no body's material"
                                                 " has a fracture table", self.output.snapshots)
        for i, crack in enumerate(self.cracks):
            origin, size = np.asarray(self.grid.origin), np.asarray(self.grid.size)
            reach = size.max()
            for j, point in enumerate(crack.points):
                if np.any(point < origin - reach) or np.any(point > origin + size + reach):
                    raise SceneError(f"cracks[{i}].points[{j}]", "lies farther from the grid"
                                     f" {self.grid.box()} than its {'longer' if len(size) == 2 else 'longest'} side", point)
            if crack.body is not None:
                reference(f"cracks[{i}].body", crack.body, bodies, "body")
                if crack.body not in crackable:
                    hint = ("; a damage material starts cracked with [[initial_damage]]"
                            if self.damage_of(self.body(crack.body)) is not None else "")
                    raise SceneError(f"cracks[{i}].body", f"its material has no fracture table{hint}",
                                     crack.body)
            elif not crackable:
                raise SceneError(f"cracks[{i}]", "no body's material has a fracture table")

    def _check_initial_damage(self, bodies: Mapping[str, int]) -> None:
        """Check the initial damage: bodies that exist and whose material has a damage
        model, and a region that selects particles of them, within their range."""
        for i, entry in enumerate(self.initial_damage):
            key = f"initial_damage[{i}]"
            if entry.body is not None:
                reference(f"{key}.body", entry.body, bodies, "body")
                material = self.material_of(self.body(entry.body))
                if self.damage_of(self.body(entry.body)) is None:
                    reason = (f"its material {material.name!r} cracks by the phase field, not by"
                              " damage: give it [[cracks]]" if material.fracture is not None else
                              f"its material {material.name!r} has no damage table")
                    raise SceneError(f"{key}.body", reason, entry.body)
            elif not any(self.damage_of(b) is not None for b in self.bodies):
                hint = ("; a phase-field material takes [[cracks]]"
                        if any(self.fracture_of(b) is not None for b in self.bodies) else "")
                raise SceneError(key, f"no body's material has a damage table{hint}")
            targets = self.initial_damage_bodies(entry)
            if entry.region == "particles" and len(targets) > 1:
                names = " and ".join(repr(self.bodies[b].name) for b in targets)
                raise SceneError(f"{key}.body", f"missing required key: particle indices are into"
                                                f" one body's particles, and {names} have damage tables")
            selected = 0
            for b in targets:
                body = self.bodies[b]
                count = 0
                for x in seeding.lattice(body, self.grid, *seeding.cell_range(body, self.grid)):
                    selected += int(np.count_nonzero(entry.select(x, count)))
                    count += len(x)
                if entry.region == "particles":
                    self._check_particle_range(f"{key}.particles", entry, body, count)
            if not selected:
                names = ("body " if len(targets) == 1 else "bodies ") + " or ".join(
                    repr(self.bodies[b].name) for b in targets)
                raise SceneError(key, f"{entry.describe()} selects no particle of {names}"
                                      " (at their positions at t = 0)")

    @staticmethod
    def _check_particle_range(key: str, entry: InitialDamage, body: Body, count: int) -> None:
        """Check that a particle set fits a body of ``count`` particles."""
        if entry.is_mask:
            if len(entry.particles) != count:
                raise SceneError(key, f"a mask of {len(entry.particles)} entries, but body"
                                      f" {body.name!r} has {count} particles")
            return
        index = np.asarray(entry.particles)
        if index.max() >= count:
            k = int(np.argmax(index >= count))
            raise SceneError(f"{key}[{k}]", f"out of range: body {body.name!r} has {count}"
                                            f" particles (0 to {count - 1})", entry.particles[k])

    def _check_contact(self, bodies: Mapping[str, int]) -> None:
        """Check the contact table: known bodies, quadratic or cubic grid or CPDI, no overlap at t = 0."""
        contact = self.contact
        if contact is None:
            return
        if not isinstance(contact, Contact):
            raise SceneError("contact", "must be a Contact", contact)
        if self.grid.degree < 2 and self.grid.shape != "cpdi":
            raise SceneError("grid.degree", "contact needs quadratic or cubic B-splines, or"
                                            " shape = \"cpdi\" on the degree-1 grid (single-point"
                                            " linear shape functions are unstable where a particle"
                                            " enters a cell: docs/contact.md)", self.grid.degree)
        seen: dict[frozenset, int] = {}
        for i, pair in enumerate(contact.pairs):
            for k, name in enumerate(pair.bodies):
                reference(f"contact.pairs[{i}].bodies[{k}]", name, bodies, "body")
            key = frozenset(pair.bodies)
            if key in seen:
                raise SceneError(f"contact.pairs[{i}].bodies",
                                 f"duplicate pair (also contact.pairs[{seen[key]}])", pair.bodies)
            seen[key] = i
        if contact.damage_gradient:
            self._check_damage_gradient(bodies)
        # Bodies in contact must start apart: no particle of one inside another.
        lattices = [np.concatenate(list(seeding.lattice(b, self.grid, *seeding.cell_range(b, self.grid))))
                    for b in self.bodies]
        for a, body in enumerate(self.bodies):
            for b, other in enumerate(self.bodies):
                if a == b:
                    continue
                x = lattices[b]
                inside = int(np.count_nonzero(body.contains(*x.T)))
                if inside:
                    raise SceneError(f"bodies[{b}]", f"{inside} of its particles lie inside"
                                     f" bodies[{a}] ({body.name!r}) at t = 0; bodies in contact"
                                     " must not overlap", other.name)

    def _check_damage_gradient(self, bodies: Mapping[str, int]) -> None:
        """Check the damage-gradient keys: groups of known bodies, each body in one group,
        no pair within a group, a kernel radius that reaches the neighbours."""
        contact = self.contact
        where: dict[str, int] = {}
        for i, group in enumerate(contact.groups):
            for k, name in enumerate(group):
                reference(f"contact.groups[{i}][{k}]", name, bodies, "body")
                if name in where:
                    raise SceneError(f"contact.groups[{i}][{k}]", "body already in"
                                     f" contact.groups[{where[name]}]", name)
                where[name] = i
        groups = dict(zip(bodies, contact.group_indices(tuple(bodies))))
        for i, pair in enumerate(contact.pairs):
            if groups[pair.bodies[0]] == groups[pair.bodies[1]]:
                raise SceneError(f"contact.pairs[{i}].bodies", "both bodies are in one contact"
                                 " group, whose fields meet with contact.friction", pair.bodies)
        radius = contact.resolved_radius(self.grid.h, self.grid.dim)
        spacing = max(b.spacing(self.grid.h) for b in self.bodies)
        if radius <= spacing:
            raise SceneError("contact.kernel_radius", f"must exceed the particle spacing"
                                                      f" {spacing:g}, or the kernel sees no"
                                                      " neighbour", radius)

    def _check_time(self) -> None:
        """Check the stability limit, a fixed dt against it, and the step count."""
        for i, material in enumerate(self.materials):
            c = material.wave_speed(self.plane)
            if not 0 < c < math.inf:
                raise SceneError(f"materials[{i}]", f"P-wave speed {c:g} is not a positive finite number")
        for i, body in enumerate(self.bodies):
            if not math.isfinite(math.hypot(*body.velocity)):
                raise SceneError(f"bodies[{i}].velocity", "speed is not finite", body.velocity)
            if not math.isfinite(body.max_speed()):
                raise SceneError(f"bodies[{i}].velocity_gradient", "gives a speed that is not finite"
                                 " over the body", body.velocity_gradient)
        units = self.unit_system()
        if units.declared:
            lo, hi = SOLID_WAVE_SPEEDS
            for i, material in enumerate(self.materials):
                c = material.wave_speed(self.plane)
                if not lo <= c * units.speed_si <= hi:
                    raise SceneError(f"materials[{i}]", f"P-wave speed {c:.3g} {units.speed}"
                                     f" = {c * units.speed_si:.3g} m/s is no solid's ({lo:g} to"
                                     f" {hi:g} m/s): check its moduli ({units.stress}) and density"
                                     f" ({units.density}) against units = {self.units!r}")
        limit = stability.grid_dt(self)
        if not 0 < limit < math.inf:
            raise SceneError("time", f"the stability limit {limit:g} is not a positive finite step")
        dt = self.time.dt
        if dt is not None and dt > limit:
            raise SceneError("time.dt", f"exceeds the stability limit {limit:.4g}"
                                        " (cfl * kappa * h / (max wave speed + max body speed))", dt)
        steps = self.time.end / self.dt()
        if steps > self.time.max_steps or steps < 1:
            c = max(m.wave_speed(self.plane) for m in self.materials)
            crossings = self.time.end * c / max(self.grid.size)
            bound = (f"more than time.max_steps = {self.time.max_steps}" if steps > 1 else
                     "less than one")
            advice = ", or raise time.max_steps" if steps > 1 else ""
            raise SceneError("time.end", f"needs {steps:.3g} steps of dt = {self.dt():.4g}, {bound}:"
                                         f" the P-wave speed {c:.3g} crosses the grid {crossings:.3g}"
                                         f" times; check the units of E and density{advice}",
                             self.time.end)
        if not steps <= _MAX_STEPS:
            raise SceneError("time.end", f"needs {steps:.3g} steps of dt = {self.dt():.4g}"
                                         f" (limit {_MAX_STEPS})", self.time.end)

    # -- parts and derived quantities ----------------------------------------

    @property
    def dim(self) -> int:
        """The scene's dimension, the grid's: 2 or 3."""
        return self.grid.dim

    def material_of(self, body: Body) -> MaterialSpec:
        """A body's material."""
        return next(m for m in self.materials if m.name == body.material)

    def fracture_of(self, body: Body) -> FractureSpec | None:
        """The fracture parameters of a body's material, or ``None``."""
        return self.material_of(body).fracture

    def damage_of(self, body: Body) -> DamageSpec | None:
        """The damage model of a body's material, or ``None``."""
        return getattr(self.material_of(body), "damage", None)

    def body(self, name: str) -> Body:
        """The body called ``name``."""
        return next(b for b in self.bodies if b.name == name)

    def body_index(self, name: str) -> int:
        """The index of the body called ``name``: its particles' ``body`` value."""
        return [b.name for b in self.bodies].index(name)

    def initial_damage_bodies(self, entry: InitialDamage) -> list[int]:
        """The indices of the bodies an initial damage entry acts on: its body, or
        every body whose material has a damage model."""
        return [b for b, body in enumerate(self.bodies)
                if (body.name == entry.body if entry.body is not None else self.damage_of(body) is not None)]

    def crack_rayleigh_speed(self) -> float:
        """Rayleigh speed of the first crackable body's material."""
        body = next(b for b in self.bodies if self.fracture_of(b) is not None)
        return self.material_of(body).rayleigh_speed()

    def unit_system(self) -> UnitSystem:
        """The declared :class:`~pfmpm.scene.units.UnitSystem` (labels "scene units" if none)."""
        return unit_system(self.units)

    def stable_dt(self) -> float:
        """The stability limit, see :func:`pfmpm.scene.stability.stable_dt`."""
        return stability.stable_dt(self)

    def critical_length(self) -> float:
        """``kappa * h``, see :func:`pfmpm.scene.stability.critical_length`."""
        return stability.critical_length(self)

    def dt(self) -> float:
        """Time step: the fixed ``time.dt`` if given, else :meth:`stable_dt`."""
        return self.time.dt if self.time.dt is not None else self.stable_dt()

    def steps(self) -> int:
        """Number of steps of :meth:`dt` to reach ``time.end`` (round-off tolerant)."""
        return stability.steps(self.time.end, self.dt())

    def particles(self) -> dict[str, np.ndarray]:
        """The particles of all bodies, see :func:`pfmpm.scene.seeding.particles`."""
        return seeding.particles(self)

    def summary(self) -> dict[str, Any]:
        """Small dict for logging: name, plane, cells, h, degree, particles, dt, steps."""
        return {
            "name": self.name,
            "plane": self.plane,
            "cells": self.grid.cells,
            "h": self.grid.h,
            "degree": self.grid.degree,
            "particles": seeding.count(self),
            "dt": self.dt(),
            "steps": self.steps(),
        }

    # -- dict / TOML --------------------------------------------------------

    @classmethod
    def from_dict(cls, d: Mapping, overrides: list[str] | tuple[str, ...] = ()) -> "Scene":
        """Build a scene from a nested dict (as parsed from TOML).

        Parameters
        ----------
        d : Mapping
            The scene tables.
        overrides : sequence of str
            ``"dotted.path=value"`` overrides applied first, see
            :func:`~pfmpm.scene.apply_overrides`.

        Raises
        ------
        SceneError
            On unknown or missing keys and any invalid value.
        """
        return build_scene(cls, d, overrides)

    @classmethod
    def from_toml(cls, path: Path | str, overrides: list[str] | tuple[str, ...] = ()) -> "Scene":
        """Load a scene from a TOML file; see :meth:`from_dict`.

        Raises
        ------
        SceneError
            On a TOML syntax error (path = the file) or an invalid scene.
        OSError
            If the file cannot be read.
        """
        return cls.from_dict(read_toml(path), overrides)

    def to_dict(self) -> dict[str, Any]:
        """Return the scene as a TOML-ready nested dict; ``from_dict`` inverts it."""
        return plain(self)
