"""Particle seeding: the bodies' lattices of material points and their initial arrays."""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from typing import TYPE_CHECKING

import numpy as np

from .bodies import Body
from .components import GridSpec
from .loads import BodyForce, Traction
from .validation import SceneError

if TYPE_CHECKING:
    from .scene import Scene

__all__ = ["cell_range", "lattice", "count", "positions", "position_batches", "fill", "load_forces",
           "particles"]

_CHUNK = 1 << 16  # candidate particles examined per vectorised batch
_EDGE_TOL = 0.51  # edge layer thickness in particle spacings


def cell_range(body: Body, grid: GridSpec, margin: int = 0) -> tuple[tuple[int, int], tuple[int, int]]:
    """Cell index ranges of the body's bounding box, clipped to the grid plus ``margin`` cells."""
    xmin, ymin, xmax, ymax = body.shape.bounds()
    (ox, oy), h, (nx, ny) = grid.origin, grid.h, grid.cells
    lo_x, hi_x = np.clip([(xmin - ox) / h, (xmax - ox) / h], -margin, nx + margin)
    lo_y, hi_y = np.clip([(ymin - oy) / h, (ymax - oy) / h], -margin, ny + margin)
    return ((math.floor(lo_x), math.ceil(hi_x)), (math.floor(lo_y), math.ceil(hi_y)))


def lattice(body: Body, grid: GridSpec, i_range: tuple[int, int],
            j_range: tuple[int, int]) -> Iterator[np.ndarray]:
    """Yield the body's particles in cells ``[i0, i1) x [j0, j1)``, a batch at a time.

    Particles sit at the centres of an ``n x n`` sub-cell lattice in each
    cell, kept if inside the body's shape and outside its holes.  Candidates
    are numbered by cell, column by column (x outer: the order in which the
    transfers visit the cells, so that a column's particles lie together in
    memory), then by sub-position (row-major), and examined ``_CHUNK`` at a
    time, so memory stays bounded; each yielded (k, 2) array keeps that order.
    """
    (i0, i1), (j0, j1) = i_range, j_range
    rows, n, h, (ox, oy) = j1 - j0, body.particles_per_cell, grid.h, grid.origin
    total = max(i1 - i0, 0) * max(rows, 0) * n * n
    for start in range(0, total, _CHUNK):
        cell, sub = np.divmod(np.arange(start, min(start + _CHUNK, total)), n * n)
        i, j = np.divmod(cell, rows)
        b, a = np.divmod(sub, n)
        x = ox + (i0 + i + (a + 0.5) / n) * h
        y = oy + (j0 + j + (b + 0.5) / n) * h
        keep = body.contains(x, y)
        yield np.column_stack((x[keep], y[keep]))


def count(scene: "Scene") -> int:
    """Number of particles of all bodies, without storing them."""
    return sum(len(p) for body in scene.bodies
               for p in lattice(body, scene.grid, *cell_range(body, scene.grid)))


def positions(scene: "Scene") -> list[np.ndarray]:
    """Each body's particle positions, (k, 2), in the order of :func:`lattice`."""
    return [np.concatenate([np.empty((0, 2)), *lattice(body, scene.grid, *cell_range(body, scene.grid))])
            for body in scene.bodies]


def position_batches(scene: "Scene") -> Iterator[np.ndarray]:
    """All bodies' particle positions in the order of :func:`positions`, a
    batch of :func:`lattice` at a time (so without an array of them all)."""
    for body in scene.bodies:
        yield from lattice(body, scene.grid, *cell_range(body, scene.grid))


def fill(scene: "Scene", xs: list[np.ndarray], columns: Mapping[str, np.ndarray]) -> None:
    """Write the initial particle arrays into ``columns``, body by body.

    ``xs`` are the bodies' positions (:func:`positions`); ``columns`` maps
    names to arrays of all particles (the core's columns, say), and each of
    the names below that it holds is written, in place, so no array of all
    particles is made on the way:

    ``x`` (N, 2) positions, ``v`` (N, 2) velocities, ``mass`` (N,),
    ``volume`` (N,) ``= (h/n)^2 * thickness``, ``body`` (N,) body index,
    ``material`` (N,) material index, ``phi`` (N,) material orientation in
    radians (clockwise from x) and ``fext`` (N, 2) the external forces at
    t = 0, those of :func:`load_forces` times each load's amplitude then.  With ``grid.shape = "cpdi"`` also the
    half-edges of the particle domains, the ``h/n`` squares of the lattice:
    ``convected_r1`` and ``domain_r1`` (N, 2) ``= (h/2n, 0)``,
    ``convected_r2`` and ``domain_r2`` ``= (0, h/2n)``.
    """
    materials = {m.name: i for i, m in enumerate(scene.materials)}
    start = 0
    for b, (body, x) in enumerate(zip(scene.bodies, xs)):
        part = slice(start, start + len(x))
        m = materials[body.material]
        spacing = body.spacing(scene.grid.h)
        volume = spacing * spacing * scene.thickness
        values = {"x": x, "volume": volume, "mass": scene.materials[m].density * volume,
                  "body": b, "material": m, "phi": math.radians(body.orientation),
                  # CPDI: the domains are the lattice's h/n squares (half-edges h/2n)
                  "convected_r1": (0.5 * spacing, 0.0), "domain_r1": (0.5 * spacing, 0.0),
                  "convected_r2": (0.0, 0.5 * spacing), "domain_r2": (0.0, 0.5 * spacing)}
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
    for load, rows, force in load_forces(scene, xs, columns["mass"]):
        fext[rows] += (1.0 if load.amplitude is None else load.amplitude(0.0)) * force


def load_forces(scene: "Scene", xs: list[np.ndarray], mass: np.ndarray) -> list[tuple]:
    """Each load's particles and the force on each at amplitude 1.

    Parameters
    ----------
    scene : Scene
    xs : list of ndarray
        The bodies' particle positions at t = 0, in body order
        (:func:`positions`).
    mass : ndarray (N,)
        The particles' masses.

    Returns
    -------
    list of (load, rows, force)
        Per entry of ``scene.loads``: its particles (a slice or indices into
        all particles) and the force on them, ``(2,)`` or ``(len(rows), 2)``.
        A traction gives each particle of the body's edge layer (within
        ``0.51 h/n`` of its extreme particle coordinate on that side; with a
        ``span``, those whose coordinate along the edge lies in it)
        ``traction * (h/n) * thickness``; a body force gives each particle
        of its body (or of all) ``mass * acceleration``.

    Raises
    ------
    SceneError
        If a traction's span holds no particle of its edge layer.
    """
    parts, start = {}, 0
    for body, x in zip(scene.bodies, xs):
        parts[body.name] = (slice(start, start + len(x)), body.spacing(scene.grid.h), x)
        start += len(x)
    forces = []
    for i, load in enumerate(scene.loads):
        if isinstance(load, BodyForce):
            rows = slice(None) if load.body is None else parts[load.body][0]
            forces.append((load, rows, mass[rows, None] * np.asarray(load.acceleration)))
            continue
        part, spacing, x = parts[load.body]
        normal = 0 if load.edge in ("left", "right") else 1
        layer = edge_layer(x, spacing, load.edge)
        if load.span is not None:
            along = x[:, 1 - normal]
            (a, b), eps = load.span, 1e-9 * spacing
            layer &= (along >= a - eps) & (along <= b + eps)
            if not layer.any():
                raise SceneError(f"loads[{i}].span", f"holds no particle of the {load.edge} edge layer"
                                                     f" of body {load.body!r}", load.span)
        rows = part.start + np.flatnonzero(layer)
        forces.append((load, rows, np.multiply(load.traction, spacing * scene.thickness)))
    return forces


def edge_layer(x: np.ndarray, spacing: float, edge: str) -> np.ndarray:
    """Which of a body's particles ``x`` (k, 2) form its layer on ``edge``:
    those within 0.51 particle ``spacing`` of its outermost particle
    coordinate on that side."""
    coord = x[:, 0 if edge in ("left", "right") else 1]
    tol = _EDGE_TOL * spacing
    return coord >= coord.max() - tol if edge in ("right", "top") else coord <= coord.min() + tol


def region_particles(scene: "Scene", xs: list[np.ndarray]) -> list[np.ndarray | None]:
    """Per prescribed region, the particles (indices into all particles) of a
    body's region, or None for a box.

    Raises
    ------
    SceneError
        Naming ``prescribed[i].particles`` for an index past the body's particles.
    """
    start, first = 0, {}
    for body, x in zip(scene.bodies, xs):
        first[body.name] = (start, x, body.spacing(scene.grid.h))
        start += len(x)
    out: list[np.ndarray | None] = []
    for i, region in enumerate(scene.prescribed):
        if region.box:
            out.append(None)
            continue
        offset, x, spacing = first[region.body]
        if region.face is not None:
            rows = np.flatnonzero(edge_layer(x, spacing, region.face))
        elif region.particles is not None:
            rows = np.asarray(region.particles)
            if rows.max() >= len(x):
                raise SceneError(f"prescribed[{i}].particles", f"body {region.body!r} has {len(x)} particles"
                                 f" (0 to {len(x) - 1})", int(rows.max()))
        else:
            rows = np.arange(len(x))
        out.append(offset + rows)
    return out


def particles(scene: "Scene") -> dict[str, np.ndarray]:
    """The particles of all bodies of a scene as new arrays, named as in
    :func:`fill`. Bodies come in order; within a body particles are sorted
    by cell (column by column, x outer) then by sub-position (see :func:`lattice`)."""
    xs = positions(scene)
    n = sum(len(x) for x in xs)
    out = {"x": np.empty((n, 2)), "v": np.empty((n, 2)), "mass": np.empty(n), "volume": np.empty(n),
           "body": np.empty(n, dtype=np.int32), "material": np.empty(n, dtype=np.int32),
           "phi": np.empty(n), "fext": np.empty((n, 2))}
    if scene.grid.shape == "cpdi":
        out.update({name: np.empty((n, 2)) for name in
                    ("convected_r1", "domain_r1", "convected_r2", "domain_r2")})
    fill(scene, xs, out)
    return out
