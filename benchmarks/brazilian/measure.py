"""The dynamic Brazilian disk (Homel & Herbold 2017, section 3.4, Figs. 15-18):
the measures of checks Z1-Z6 of ``shared/benchmarks-homel-herbold.md`` section 6.

A disk between two platens breaks into fragments that flow out to the side
walls. :func:`disk_fragments` gives the fragment-size distribution of the
disk's intact material (:func:`~pfmpm.post.fragments.fragment_sizes` with
the card's choices: intact D_p <= 1e-6, or not failed; linked within 0.75 cell
in the current configuration; fragments below 50 um left out) and
:func:`disk_speed` its mean speed; :func:`failed_fraction` the fully damaged area fraction (Z3);
:func:`contact_distance` how far a particle starts from the platen-disk
contact points (Z1); :func:`wall_excursion` and :func:`platen_penetration`
how far particles pass a wall or into a platen (Z6). The single-field runs
are :func:`benchmarks.common.self_contact.body_fields` of the scene.
"""

from __future__ import annotations

import math

import numpy as np

from pfmpm.post.fragments import (FULL_DAMAGE, INTACT, failed, fragment_sizes, intact as intact_particles, mean_speed,
                                  median_size, size_distribution)
from pfmpm.scene import Scene

__all__ = ["INTACT", "LINK_CELLS", "SMALLEST", "disk_fragments", "disk_speed", "failed_fraction",
           "contact_distance", "wall_excursion", "platen_penetration"]

LINK_CELLS = 0.75
"""Connectivity radius in cells: joins lattice and diagonal neighbours of 2 x 2
particles per cell, not particles across a one-particle crack."""
SMALLEST = 0.05
"""Smallest resolved fragment, 50 um in the scene's mm (section 3.4)."""




def disk_fragments(scene: Scene, p, body: str = "disk", intact: str = "undamaged") -> dict:
    """Fragments of one body's intact particles and its mean speed.

    ``p`` has the particle columns ``x``, ``v``, ``mass``, ``volume``
    (current), ``damage`` and ``body`` (a :class:`pfmpm.Simulation`'s
    ``particles``, or a copy of them). Areas are volumes over the scene's
    thickness; fragments link within :data:`LINK_CELLS` cells.

    Returns
    -------
    dict
        ``sizes`` and ``fractions`` (the cumulative mass-fraction
        distribution of fragments of at least :data:`SMALLEST`), ``d50`` (the
        mass-weighted median size), ``fragments`` (their number), ``intact``
        (the mass fraction of the body in them) and ``mean_speed`` (mass-
        weighted, over all the body's particles, failed or not).
    """
    mine = np.asarray(p.body) == scene.body_index(body)
    damage = np.asarray(p.damage)
    keep = mine & intact_particles(damage, intact)
    mass = np.asarray(p.mass)
    sizes, masses = fragment_sizes(np.asarray(p.x)[keep], np.asarray(p.volume)[keep] / scene.thickness,
                                   mass[keep], LINK_CELLS * scene.grid.h)
    s, fraction = size_distribution(sizes, masses, SMALLEST)
    resolved = sizes >= SMALLEST
    return {"sizes": s, "fractions": fraction, "d50": median_size(sizes, masses, SMALLEST),
            "fragments": int(np.count_nonzero(resolved)),
            "intact": float(masses[resolved].sum() / mass[mine].sum()),
            "mean_speed": disk_speed(scene, p, body)}


def disk_speed(scene: Scene, p, body: str = "disk") -> float:
    """Mass-weighted mean speed of the body's particles, failed or not (Fig. 18's inset)."""
    mine = np.asarray(p.body) == scene.body_index(body)
    return mean_speed(np.asarray(p.v)[mine], np.asarray(p.mass)[mine])


def failed_fraction(scene: Scene, p, body: str = "disk") -> float:
    """Failed (:func:`~pfmpm.post.fragments.failed`) fraction of the body's current area (check Z3)."""
    mine = np.asarray(p.body) == scene.body_index(body)
    volume = np.asarray(p.volume)[mine]
    return float(volume[failed(np.asarray(p.damage)[mine])].sum() / volume.sum())


def contact_distance(scene: Scene, x0: np.ndarray, body: str = "disk") -> np.ndarray:
    """Distance of each point ``x0`` (N, 2) from the nearer of the disk body's
    top and bottom points, where it touches the platens at t = 0 (check Z1)."""
    shape = scene.body(body).shape
    (cx, cy), r = shape.center, shape.radius
    x0 = np.asarray(x0, dtype=float).reshape(-1, 2)
    return np.minimum(np.hypot(x0[:, 0] - cx, x0[:, 1] - cy - r), np.hypot(x0[:, 0] - cx, x0[:, 1] - cy + r))


def wall_excursion(scene: Scene, x: np.ndarray) -> float:
    """How far the farthest particle lies beyond any wall of the scene, in
    cells (negative: every particle inside; check Z6)."""
    x = np.asarray(x).reshape(-1, 2)
    (x0, y0), (w, h) = scene.grid.origin, scene.grid.size
    beyond = {"left": x0 - x[:, 0], "right": x[:, 0] - (x0 + w), "bottom": y0 - x[:, 1],
              "top": x[:, 1] - (y0 + h)}
    return max((float(beyond[wall.side].max()) for wall in scene.walls), default=-math.inf) / scene.grid.h


def platen_penetration(scene: Scene, x0: np.ndarray, x: np.ndarray, body: np.ndarray,
                       platen: str, into: str = "disk") -> float:
    """How far the particles of body ``into`` lie inside the face of ``platen``
    that faces them, in cells (negative: a gap; check Z6).

    The face is the platen's row of particles nearest the other body at t =
    0, followed in ``x`` (interpolated along it), moved out by half a
    particle spacing: at t = 0 the particles of two bodies in touch lie half
    a spacing either side of it, so the value is -1/2 spacing.
    """
    x0, x, body = np.asarray(x0).reshape(-1, 2), np.asarray(x).reshape(-1, 2), np.asarray(body)
    mine, theirs = body == scene.body_index(platen), body == scene.body_index(into)
    below = np.mean(x0[theirs, 1]) < np.mean(x0[mine, 1])  # the other body lies below the platen
    y0 = x0[mine, 1]
    row = np.flatnonzero(mine)[np.isclose(y0, y0.min() if below else y0.max())]
    row = row[np.argsort(x[row, 0])]
    spacing = scene.body(platen).spacing(scene.grid.h)
    face = np.interp(x[theirs, 0], x[row, 0], x[row, 1]) + (-0.5 if below else 0.5) * spacing
    inside = x[theirs, 1] - face if below else face - x[theirs, 1]
    return float(inside.max()) / scene.grid.h
