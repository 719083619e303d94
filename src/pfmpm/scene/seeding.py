"""Particle seeding: the bodies' lattices of material points and their initial arrays."""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from typing import TYPE_CHECKING

import numpy as np

from .bodies import Body
from .components import GridSpec
from .loads import SIDE_NAME, BodyForce, Traction, normal_axis
from .validation import SceneError

if TYPE_CHECKING:
    from .scene import Scene

__all__ = ["cell_range", "lattice", "lattice_size", "id_bases", "seed_body", "seeded_positions", "rows_of",
           "count", "positions", "seed", "particle_volume", "fill", "load_forces", "particles"]

_CHUNK = 1 << 16  # candidate particles examined per vectorised batch
_EDGE_TOL = 0.51  # edge layer thickness in particle spacings


def cell_range(body: Body, grid: GridSpec, margin: int = 0) -> tuple[tuple[int, int], ...]:
    """Cell index ranges of the body's bounding box, one ``(first, end)`` per
    direction, clipped to the grid plus ``margin`` cells."""
    bounds, dim, h = body.shape.bounds(), grid.dim, grid.h
    ranges = []
    for lo, hi, o, n in zip(bounds[:dim], bounds[dim:], grid.origin, grid.cells):
        a, b = np.clip([(lo - o) / h, (hi - o) / h], -margin, n + margin)
        ranges.append((math.floor(a), math.ceil(b)))
    return tuple(ranges)


def lattice(body: Body, grid: GridSpec, *ranges: tuple[int, int]) -> Iterator[np.ndarray]:
    """Yield the body's particles in the cells of ``ranges`` (``[i0, i1) x
    [j0, j1)``, and ``x [k0, k1)`` in 3D), a batch at a time.

    Particles sit at the centres of an ``n x n`` (``n x n x n``) sub-cell
    lattice in each cell, kept if inside the body's shape and outside its
    holes.  Candidates are numbered by cell, the last direction fastest (x
    outer: the order in which the transfers visit the cells, so that a
    column's particles lie together in memory), then by sub-position (x
    fastest), and examined ``_CHUNK`` at a time, so memory stays bounded;
    each yielded (k, dim) array keeps that order.
    """
    for x, _ in _numbered(body, grid, ranges, ranges):
        yield x


def _numbered(body: Body, grid: GridSpec, ranges, frame) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """:func:`lattice` in the cells of ``ranges``, with each particle's number
    in the lattice of the cells of ``frame`` (which holds ``ranges``): its
    cell's index there (the last direction fastest) times ``n^dim``, plus its
    sub-position's index (x fastest). ``frame = ranges`` numbers the
    candidates in the order they are examined."""
    n, dim = body.particles_per_cell, len(ranges)
    counts = [max(end - first, 0) for first, end in ranges]
    per_cell = n ** dim
    total = math.prod(counts) * per_cell
    shift = [first - whole for (first, _), (whole, _) in zip(ranges, frame)]
    frame_counts = [end - first for first, end in frame]
    same = list(ranges) == list(frame)
    for start in range(0, total, _CHUNK):
        candidate = np.arange(start, min(start + _CHUNK, total))
        cell, sub = np.divmod(candidate, per_cell)
        index = np.unravel_index(cell, counts)  # row-major: the last direction fastest
        offset = np.unravel_index(sub, (n,) * dim)[::-1]  # x fastest
        coords = _centres(grid, n, [first for first, _ in ranges], index, offset)
        keep = body.contains(*coords)
        number = candidate if same else (
            np.ravel_multi_index([i + s for i, s in zip(index, shift)], frame_counts) * per_cell + sub)
        yield np.column_stack([c[keep] for c in coords]), number[keep]


def _centres(grid: GridSpec, n: int, firsts, index, offset) -> list[np.ndarray]:
    """The coordinates, one array per direction, of the sub-cell centres at
    cell ``first + index`` and sub-position ``offset`` (0 to n - 1) in each
    direction: ``origin + (first + index + (offset + 0.5) / n) * h``, the one
    formula of a seeded position (:func:`lattice`, :func:`seeded_positions`)."""
    return [o + (first + i + (a + 0.5) / n) * grid.h for o, first, i, a in zip(grid.origin, firsts, index, offset)]


def lattice_size(body: Body, grid: GridSpec) -> int:
    """The candidates of the body's seeding lattice: ``n^dim`` per cell of its
    bounding box on the grid (:func:`cell_range`)."""
    return math.prod(end - first for first, end in cell_range(body, grid)) * body.particles_per_cell ** grid.dim


def id_bases(scene: "Scene") -> list[int]:
    """Each body's first particle id: the sum of the lattice sizes
    (:func:`lattice_size`) of the bodies before it, so that the ids of
    different bodies never meet and ascend in body order."""
    sizes = [lattice_size(body, scene.grid) for body in scene.bodies]
    return [sum(sizes[:b]) for b in range(len(sizes))]


def seed_body(body: Body, grid: GridSpec, base: int = 0,
              box: tuple[tuple[int, int], ...] | None = None) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Yield the body's particles with their ids, a batch at a time: positions
    (k, dim) and ids (k,), int64, in ascending id order.

    A particle's id is ``base`` (the body's, :func:`id_bases`) plus its number
    in the body's seeding lattice, the sub-cell centres of the cells of its
    bounding box (:func:`cell_range`), numbered as :func:`lattice` examines
    them. It is a function of the particle's lattice position alone, so ids
    are sparse where the shape leaves candidates out, and they are the same
    whatever part of the lattice is seeded.

    Parameters
    ----------
    body : Body
    grid : GridSpec
    base : int
        The body's first id.
    box : tuple of (first, end) per direction, optional
        Seed only the cells of this box (cell indices of the grid; those
        outside the bounding box have no particles); default all.

    Raises
    ------
    ValueError
        Naming ``box`` if it has not one (first, end) pair per direction.
    """
    whole = cell_range(body, grid)
    if box is not None and (len(box) != grid.dim or any(len(r) != 2 for r in box)):
        raise ValueError(f"box = {box}: must be {grid.dim} (first, end) cell ranges, one per direction")
    cells = whole if box is None else tuple(
        (max(a, first), min(b, end)) for (a, b), (first, end) in zip(box, whole))
    for x, number in _numbered(body, grid, cells, whole):
        yield x, base + number


def seeded_positions(scene: "Scene", ids) -> np.ndarray:
    """The positions at t = 0, (k, dim), of the particles with ids ``ids``
    (k,), in that order: the lattice positions the ids number
    (:func:`seed_body`), read back from the ids alone, bit for bit those the
    seeding gives.

    Raises
    ------
    ValueError
        Naming the first id that no particle of the seeding has: outside every
        body's lattice, or a candidate its body's shape or holes leave out.
    """
    ids = np.asarray(ids, dtype=np.int64)
    grid = scene.grid
    bases = id_bases(scene)
    ends = [base + lattice_size(body, grid) for body, base in zip(scene.bodies, bases)]
    body_of = np.searchsorted(ends, ids, side="right")  # the body whose id range holds each id
    outside = (ids < 0) | (body_of == len(ends))
    if outside.any():
        raise ValueError(f"particle id {ids[np.argmax(outside)]}: outside the lattices of the scene's bodies"
                         f" (ids 0 to {ends[-1] - 1})")
    out = np.empty((len(ids), grid.dim))
    for b, body in enumerate(scene.bodies):
        mine = body_of == b
        if not mine.any():
            continue
        sel = slice(None) if mine.all() else np.flatnonzero(mine)  # all of one body: no index array
        whole = cell_range(body, grid)
        n = body.particles_per_cell
        # The numbering of _numbered read backwards: cell (the last direction
        # fastest) times n^dim plus sub-position (x fastest).
        cell, sub = np.divmod(ids[sel] - bases[b], n ** grid.dim)
        index = np.unravel_index(cell, [end - first for first, end in whole])
        offset = np.unravel_index(sub, (n,) * grid.dim)[::-1]
        coords = _centres(grid, n, [first for first, _ in whole], index, offset)
        kept = body.contains(*coords)
        if not kept.all():
            raise ValueError(f"particle id {ids[sel][np.argmin(kept)]}: a lattice position that body"
                             f" {body.name!r} leaves out, no particle of the seeding")
        for d, coord in enumerate(coords):
            out[sel, d] = coord
    return out


def rows_of(ids: np.ndarray, wanted) -> slice | np.ndarray:
    """The rows of the particles with ids ``wanted`` in local arrays whose id
    column is ``ids``, in the order of ``wanted``.

    ``ids`` ascends (the invariant of the particle arrays, docs/particle-ids.md),
    so each id is found by bisection. Where ``wanted`` are the ids of a run of
    consecutive rows, in order (a body's particles, say), the rows are that
    slice, so that indexing with them makes views.

    Raises
    ------
    ValueError
        Naming the first id of ``wanted`` that no row holds.
    """
    wanted = np.asarray(wanted, dtype=np.int64)
    start = int(np.searchsorted(ids, wanted[0])) if len(wanted) else 0
    if np.array_equal(ids[start:start + len(wanted)], wanted):
        return slice(start, start + len(wanted))
    rows, held = held_rows(ids, wanted)
    if not held.all():
        raise ValueError(f"particle id {wanted[np.argmin(held)]}: no particle here has it")
    return rows


def held_rows(ids: np.ndarray, wanted) -> tuple[np.ndarray, np.ndarray]:
    """The rows of those of the ids ``wanted`` that local arrays whose id
    column is ``ids`` (ascending) hold, in the order of ``wanted``, and which
    of ``wanted`` they are (a mask): a rank of a distributed run holds some."""
    wanted = np.asarray(wanted, dtype=np.int64)
    rows = np.searchsorted(ids, wanted)
    held = rows < len(ids)
    held[held] = ids[rows[held]] == wanted[held]
    return rows[held], held


def count(scene: "Scene") -> int:
    """Number of particles of all bodies, without storing them."""
    return sum(len(p) for body in scene.bodies
               for p in lattice(body, scene.grid, *cell_range(body, scene.grid)))


def positions(scene: "Scene") -> list[np.ndarray]:
    """Each body's particle positions, (k, dim), in the order of :func:`lattice`."""
    return [np.concatenate([np.empty((0, scene.dim)), *lattice(body, scene.grid, *cell_range(body, scene.grid))])
            for body in scene.bodies]


def seed(scene: "Scene") -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Each body's particle positions, (k, dim), as :func:`positions` gives
    them, and their ids, (k,) int64 (:func:`seed_body`)."""
    xs, ids = [], []
    for body, base in zip(scene.bodies, id_bases(scene)):
        batches = list(seed_body(body, scene.grid, base))
        xs.append(np.concatenate([np.empty((0, scene.dim)), *(x for x, _ in batches)]))
        ids.append(np.concatenate([np.empty(0, dtype=np.int64), *(i for _, i in batches)]))
    return xs, ids


def particle_volume(scene: "Scene", body: Body) -> float:
    """The volume of each of a body's particles, ``(h/n)^2 * thickness``
    (``(h/n)^3`` in 3D): the lattice's sub-cell."""
    return math.prod([body.spacing(scene.grid.h)] * scene.dim) * scene.thickness


def fill(scene: "Scene", xs: list[np.ndarray], columns: Mapping[str, np.ndarray],
         ids: list[np.ndarray] | None = None) -> None:
    """Write the initial particle arrays into ``columns``, body by body.

    ``xs`` are the bodies' positions (:func:`positions`), ``ids`` their ids
    (:func:`seed`; needed where ``columns`` has ``id`` or ``fext``);
    ``columns`` maps names to arrays of all particles (the core's columns,
    say), and each of the names below that it holds is written, in place, so
    no array of all particles is made on the way:

    ``x`` (N, dim) positions, ``v`` (N, dim) velocities, ``mass`` (N,),
    ``volume`` (N,) (:func:`particle_volume`), ``body``
    (N,) body index, ``material`` (N,) material index, ``id`` (N,) the ids, ``phi`` (N,) material
    orientation in radians (clockwise from x) and ``fext`` (N, dim) the external forces at
    t = 0, those of :func:`load_forces` times each load's amplitude then, on
    the rows of their ids (``fext`` needs ``id`` among the columns).  With ``grid.shape = "cpdi"`` also the
    half-edges of the particle domains, the ``h/n`` squares (cubes in 3D) of the lattice:
    ``convected_r1`` and ``domain_r1`` (N, dim) ``= (h/2n, 0[, 0])``,
    ``convected_r2`` and ``domain_r2`` ``= (0, h/2n[, 0])`` and in 3D
    ``convected_r3`` and ``domain_r3`` ``= (0, 0, h/2n)``.
    """
    materials = {m.name: i for i, m in enumerate(scene.materials)}
    start = 0
    for b, (body, x) in enumerate(zip(scene.bodies, xs)):
        part = slice(start, start + len(x))
        m = materials[body.material]
        spacing = body.spacing(scene.grid.h)
        volume = particle_volume(scene, body)
        values = {"x": x, "volume": volume, "mass": scene.materials[m].density * volume,
                  "body": b, "material": m, "phi": math.radians(body.orientation)}
        if "id" in columns:
            values["id"] = ids[b]
        # CPDI: the domains are the lattice's h/n squares or cubes (half-edges h/2n along the axes)
        for k, edge in enumerate(0.5 * spacing * np.eye(scene.dim), start=1):
            values[f"convected_r{k}"] = values[f"domain_r{k}"] = tuple(edge)
        for name, value in values.items():
            if name in columns:
                columns[name][part] = value
        if "v" in columns:
            columns["v"][part] = body.velocity
            if np.any(body.velocity_gradient):
                columns["v"][part] += x @ np.asarray(body.velocity_gradient).T
        start += len(x)
    if "fext" not in columns:
        return
    fext = columns["fext"]
    fext[...] = 0.0
    for load, particles, force in load_forces(scene, xs, ids):
        fext[rows_of(columns["id"], particles)] += (1.0 if load.amplitude is None else load.amplitude(0.0)) * force


def load_forces(scene: "Scene", xs: list[np.ndarray], ids: list[np.ndarray]) -> list[tuple]:
    """Each load's particles, by id, and the force on each at amplitude 1.

    Parameters
    ----------
    scene : Scene
    xs : list of ndarray
        The bodies' particle positions at t = 0, in body order
        (:func:`positions`).
    ids : list of ndarray
        Their ids (:func:`seed`).

    Returns
    -------
    list of (load, ids, force)
        Per entry of ``scene.loads``, in order (a body force on all bodies:
        one per body, in body order): the ids of its particles, ascending, an
        array of its own, and the force on each, ``(dim,)``.
        A traction gives each particle of the body's edge layer (within
        ``0.51 h/n`` of its extreme particle coordinate on that side; with a
        ``span``, those whose coordinates along the edge or face lie in it)
        ``traction * (h/n) * thickness``, in 3D ``traction * (h/n)^2`` (the
        face area a particle stands for); a body force gives each particle
        of its body (or of all) ``mass * acceleration``, the mass of its
        body's particles (:func:`fill`).

    Raises
    ------
    SceneError
        If a traction's span holds no particle of its edge (face) layer.
    """
    body_index = {body.name: b for b, body in enumerate(scene.bodies)}
    forces = []
    for i, load in enumerate(scene.loads):
        if isinstance(load, BodyForce):
            for b in ([body_index[load.body]] if load.body is not None else range(len(scene.bodies))):
                body = scene.bodies[b]
                mass = scene.material_of(body).density * particle_volume(scene, body)
                forces.append((load, ids[b].copy(), mass * np.asarray(load.acceleration)))
            continue
        b = body_index[load.body]
        x, spacing = xs[b], scene.bodies[b].spacing(scene.grid.h)
        layer = edge_layer(x, spacing, load.edge)
        if load.span is not None:
            eps = 1e-9 * spacing
            for axis, lo, hi in load.patch():
                layer &= (x[:, axis] >= lo - eps) & (x[:, axis] <= hi + eps)
            if not layer.any():
                raise SceneError(f"loads[{i}].span", f"holds no particle of the {load.edge}"
                                                     f" {SIDE_NAME[scene.dim]} layer of body {load.body!r}",
                                 load.span)
        area = math.prod([spacing] * (scene.dim - 1)) * scene.thickness  # a particle's share of the face
        forces.append((load, ids[b][layer], np.multiply(load.traction, area)))
    return forces


def edge_layer(x: np.ndarray, spacing: float, edge: str) -> np.ndarray:
    """Which of a body's particles ``x`` (k, dim) form its layer on ``edge``:
    those within 0.51 particle ``spacing`` of its outermost particle
    coordinate on that side."""
    coord = x[:, normal_axis(edge)]
    tol = _EDGE_TOL * spacing
    return coord >= coord.max() - tol if edge in ("right", "top", "front") else coord <= coord.min() + tol


def region_particles(scene: "Scene", xs: list[np.ndarray], ids: list[np.ndarray]) -> list[np.ndarray | None]:
    """Per prescribed region, the ids of a body's region, or None for a box.

    ``xs`` are the bodies' positions at t = 0 (:func:`positions`), ``ids``
    their ids (:func:`seed`): a face is the body's edge layer there, and the
    region's ``particles``, indices into the body's particles in seeding
    order, are the ids at those places of the body's ``ids``.

    Raises
    ------
    SceneError
        Naming ``prescribed[i].particles`` for an index past the body's particles.
    """
    body_index = {body.name: b for b, body in enumerate(scene.bodies)}
    out: list[np.ndarray | None] = []
    for i, region in enumerate(scene.prescribed):
        if region.box:
            out.append(None)
            continue
        b = body_index[region.body]
        x, body_ids = xs[b], ids[b]
        if region.face is not None:
            out.append(body_ids[edge_layer(x, scene.bodies[b].spacing(scene.grid.h), region.face)])
        elif region.particles is not None:
            places = np.asarray(region.particles)  # in the body's seeding order
            if places.max() >= len(x):
                raise SceneError(f"prescribed[{i}].particles", f"body {region.body!r} has {len(x)} particles"
                                 f" (0 to {len(x) - 1})", int(places.max()))
            out.append(body_ids[places])
        else:
            out.append(body_ids)
    return out


def particles(scene: "Scene") -> dict[str, np.ndarray]:
    """The particles of all bodies of a scene as new arrays, named as in
    :func:`fill`. Bodies come in order; within a body particles are sorted
    by cell (column by column, x outer) then by sub-position (see :func:`lattice`),
    which is ascending id order (:func:`seed_body`)."""
    xs, ids = seed(scene)
    n, dim = sum(len(x) for x in xs), scene.dim
    out = {"x": np.empty((n, dim)), "v": np.empty((n, dim)), "mass": np.empty(n), "volume": np.empty(n),
           "body": np.empty(n, dtype=np.int32), "material": np.empty(n, dtype=np.int32),
           "id": np.empty(n, dtype=np.int64), "phi": np.empty(n), "fext": np.empty((n, dim))}
    if scene.grid.shape == "cpdi":
        out.update({f"{kind}_r{k}": np.empty((n, dim)) for kind in ("convected", "domain")
                    for k in range(1, dim + 1)})
    fill(scene, xs, out, ids)
    return out
