"""Particle seeding: the bodies' lattices of material points and their initial arrays."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import TYPE_CHECKING

import numpy as np

from .bodies import Body
from .components import GridSpec
from .loads import Traction

if TYPE_CHECKING:
    from .scene import Scene

__all__ = ["cell_range", "lattice", "count", "particles"]

_CHUNK = 1 << 20  # candidate particles examined per vectorised batch
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
    are numbered by cell (row-major, y outer) then sub-position (row-major)
    and examined ``_CHUNK`` at a time, so memory stays bounded; each yielded
    (k, 2) array keeps that order.
    """
    (i0, i1), (j0, j1) = i_range, j_range
    cols, n, h, (ox, oy) = i1 - i0, body.particles_per_cell, grid.h, grid.origin
    total = max(cols, 0) * max(j1 - j0, 0) * n * n
    for start in range(0, total, _CHUNK):
        cell, sub = np.divmod(np.arange(start, min(start + _CHUNK, total)), n * n)
        j, i = np.divmod(cell, cols)
        b, a = np.divmod(sub, n)
        x = ox + (i0 + i + (a + 0.5) / n) * h
        y = oy + (j0 + j + (b + 0.5) / n) * h
        keep = body.contains(x, y)
        yield np.column_stack((x[keep], y[keep]))


def count(scene: "Scene") -> int:
    """Number of particles of all bodies, without storing them."""
    return sum(len(p) for body in scene.bodies
               for p in lattice(body, scene.grid, *cell_range(body, scene.grid)))


def particles(scene: "Scene") -> dict[str, np.ndarray]:
    """Generate the particles of all bodies of a scene.

    Bodies come in order; within a body particles are sorted by cell
    (row-major, y outer) then by sub-position (see :func:`lattice`).

    Returns
    -------
    dict of str to ndarray
        ``x`` (N, 2) positions, ``v`` (N, 2) velocities, ``mass`` (N,),
        ``volume`` (N,) ``= (h/n)^2 * thickness``, ``body`` (N,) int32
        body index, ``material`` (N,) int32 material index, ``phi`` (N,)
        material orientation in radians (clockwise from x) and ``fext``
        (N, 2) constant external forces: ``traction * (h/n) * thickness``
        on the edge layer of each traction load plus
        ``mass * acceleration`` of each body force.  The edge layer is
        the particles of the body within ``0.51 h/n`` of its extreme
        particle coordinate on that side.  With ``grid.shape = "cpdi"``
        also the half-edges of the particle domains, the ``h/n`` squares of
        the lattice: ``convected_r1`` and ``domain_r1`` (N, 2) ``= (h/2n, 0)``,
        ``convected_r2`` and ``domain_r2`` ``= (0, h/2n)``.
    """
    h = scene.grid.h
    materials = {m.name: i for i, m in enumerate(scene.materials)}
    xs, vs, masses, volumes, body_ids, material_ids, phis, halves, slices = [], [], [], [], [], [], [], [], {}
    start = 0
    for b, body in enumerate(scene.bodies):
        x = np.concatenate(list(lattice(body, scene.grid, *cell_range(body, scene.grid))))
        n = len(x)
        m = materials[body.material]
        spacing = body.spacing(h)
        volume = spacing * spacing * scene.thickness
        xs.append(x)
        vs.append(np.asarray(body.velocity) + x @ np.asarray(body.velocity_gradient).T)
        volumes.append(np.full(n, volume))
        masses.append(np.full(n, scene.materials[m].density * volume))
        body_ids.append(np.full(n, b, dtype=np.int32))
        material_ids.append(np.full(n, m, dtype=np.int32))
        phis.append(np.full(n, math.radians(body.orientation)))
        halves.append(np.full(n, 0.5 * spacing))
        slices[body.name] = (slice(start, start + n), spacing)
        start += n
    out = {
        "x": np.concatenate(xs),
        "v": np.concatenate(vs),
        "mass": np.concatenate(masses),
        "volume": np.concatenate(volumes),
        "body": np.concatenate(body_ids),
        "material": np.concatenate(material_ids),
        "phi": np.concatenate(phis),
        "fext": np.zeros((start, 2)),
    }
    if scene.grid.shape == "cpdi":
        half = np.concatenate(halves)
        zero = np.zeros_like(half)
        out["convected_r1"] = out["domain_r1"] = np.stack([half, zero], axis=1)
        out["convected_r2"] = out["domain_r2"] = np.stack([zero, half], axis=1)
    for load in scene.loads:
        if isinstance(load, Traction):
            part, spacing = slices[load.body]
            coord = out["x"][part, 0 if load.edge in ("left", "right") else 1]
            tol = _EDGE_TOL * spacing
            if load.edge in ("right", "top"):
                layer = coord >= coord.max() - tol
            else:
                layer = coord <= coord.min() + tol
            out["fext"][part][layer] += np.multiply(load.traction, spacing * scene.thickness)
        else:
            part = slice(None) if load.body is None else slices[load.body][0]
            out["fext"][part] += out["mass"][part, None] * np.asarray(load.acceleration)
    return out
