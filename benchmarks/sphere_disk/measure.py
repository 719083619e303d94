"""A steel sphere fragmenting a thick alumina disk (Homel & Herbold 2017,
section 4, Fig. 20): the measures of benchmarks/sphere_disk.

:func:`momentum_error` is the largest change of the total momentum over the
impact momentum (the system is free: no walls, no loads);
:func:`energy_balance` compares kinetic + elastic energy + the work
dissipated by damage and by friction with the sphere's kinetic energy at
t = 0; :func:`disk_fragments` is the fragment-size distribution of the disk's
intact particles (:func:`~pfmpm.post.fragments.fragment_sizes` in 3D, linked
within :data:`LINK_CELLS` cells in the current configuration, fragments below
:data:`SMALLEST` left out), :func:`material_fragments` labels the intact
particles by the pieces they form in the reference configuration and
:func:`inside_other` finds the particles of one such piece (or of the sphere)
that lie inside another in the current one; :func:`render` draws the
fragments.
"""

from __future__ import annotations

import math

import numpy as np

from pfmpm.post.fragments import (FULL_DAMAGE, INTACT, fragment_sizes, intact as intact_particles, linked_sets,
                                  median_size, size_distribution)
from pfmpm.scene import Scene

__all__ = ["INTACT", "LINK_CELLS", "SMALLEST", "INSIDE", "impact_momentum", "momentum_error", "energy_balance",
           "disk_fragments", "material_fragments", "inside_other", "render"]

LINK_CELLS = 0.75
"""Connectivity radius in cells: with 2 x 2 x 2 particles per cell it joins
lattice neighbours (0.5 cell) and face diagonals (0.71), not body diagonals
(0.87) nor particles across a one-particle crack (1.0)."""
SMALLEST = 1.0
"""Smallest resolved fragment (mm): the coarse cell, the equivalent diameter
of about four of its particles; smaller pieces are debris at both
resolutions."""
INSIDE = 0.5
"""A particle lies inside another piece when its centre is closer than this
many particle spacings to one of that piece's particles: within the cube of
side one spacing that each particle stands for (the two bodies' particles
start 2 spacings apart, and particles of two pieces of the disk at least
one, across the failed layer between them)."""




def impact_momentum(scene: Scene, body: str = "sphere") -> float:
    """|M v| of the body at t = 0: the impact momentum."""
    p = scene.particles()
    mine = p["body"] == scene.body_index(body)
    return float(np.linalg.norm((p["mass"][mine, None] * p["v"][mine]).sum(axis=0)))


def momentum_error(e: dict, p0: float) -> float:
    """Largest change of any component of the total momentum over the rows of
    ``energies.csv`` (``e``), over the impact momentum ``p0``."""
    return max(float(np.abs(e[f"momentum_{d}"] - e[f"momentum_{d}"][0]).max()) for d in "xyz") / p0


def energy_balance(e: dict) -> dict:
    """Where the initial kinetic energy KE0 went, from ``energies.csv`` (``e``).

    Returns fractions of KE0 at the last row (``kinetic``, ``elastic``,
    ``damage``, ``friction``), ``balance`` = 1 - (their sum) at the last row
    (the energy the scheme lost: the check asks |balance| <= 0.02),
    ``largest`` its largest magnitude over the run, and ``KE0``.
    """
    ke0 = float(e["kinetic"][0])
    zero = np.zeros_like(e["t"])
    parts = {"kinetic": e["kinetic"], "elastic": e["elastic"],
             "damage": e.get("damage_dissipation", zero), "friction": e.get("friction_dissipation", zero)}
    held = sum(parts.values())
    balance = 1.0 - held / ke0
    out = {k: float(v[-1] / ke0) for k, v in parts.items()}
    out.update(KE0=ke0, balance=float(balance[-1]), largest=float(np.abs(balance).max()))
    return out


def disk_fragments(scene: Scene, x: np.ndarray, volume: np.ndarray, mass: np.ndarray, damage: np.ndarray,
                   body: np.ndarray, intact: str = "undamaged", name: str = "disk") -> dict:
    """The fragments of the body ``name``'s intact particles in the
    configuration ``x`` (N, 3): linked within :data:`LINK_CELLS` cells, each
    sized by the equivalent diameter of its volume, (6 V / pi)^(1/3).

    Returns ``sizes`` and ``fractions`` (the cumulative mass-fraction
    distribution of the fragments of at least :data:`SMALLEST`), ``d50``
    (mass-weighted median size), ``fragments`` (their number), ``largest``
    (size), ``intact`` (the mass fraction of the body in them) and
    ``failed`` (the body's failed volume fraction)."""
    mine = np.asarray(body) == scene.body_index(name)
    damage = np.asarray(damage)
    keep = mine & intact_particles(damage, intact)
    sizes, masses = fragment_sizes(np.asarray(x)[keep], np.asarray(volume)[keep], np.asarray(mass)[keep],
                                   LINK_CELLS * scene.grid.h)
    s, fraction = size_distribution(sizes, masses, SMALLEST)
    resolved = sizes >= SMALLEST
    vol = np.asarray(volume)[mine]
    return {"sizes": s, "fractions": fraction, "d50": median_size(sizes, masses, SMALLEST),
            "fragments": int(np.count_nonzero(resolved)),
            "largest": float(sizes.max()) if len(sizes) else math.nan,
            "intact": float(masses[resolved].sum() / np.asarray(mass)[mine].sum()),
            "failed": float(vol[damage[mine] >= FULL_DAMAGE].sum() / vol.sum())}


def material_fragments(scene: Scene, X: np.ndarray, damage: np.ndarray, body: np.ndarray,
                       intact: str = "undamaged", name: str = "disk") -> np.ndarray:
    """A label per particle: the piece of material it belongs to. The intact
    particles of body ``name`` are linked within :data:`LINK_CELLS` cells in
    the reference configuration ``X`` (their positions at t = 0), so two
    pieces are apart where failed particles part them, wherever they have
    moved since; every other body is one piece; failed particles get -1."""
    body = np.asarray(body)
    mine = body == scene.body_index(name)
    keep = mine & intact_particles(np.asarray(damage), intact)
    labels = np.full(len(body), -1, dtype=np.int64)
    labels[keep] = linked_sets(np.asarray(X)[keep], LINK_CELLS * scene.grid.h)
    top = labels.max() + 1
    for k in range(len(scene.bodies)):
        if k != scene.body_index(name):
            labels[body == k] = top + k
    return labels


def inside_other(x: np.ndarray, labels: np.ndarray, spacing: float) -> dict:
    """Particles of one piece inside another, in the configuration ``x``.

    A particle is inside another piece when a particle of that piece is
    closer than :data:`INSIDE` ``spacing``; ``labels`` from
    :func:`material_fragments` (-1, failed, is no piece). Returns ``inside``
    (how many particles) and ``closest`` (the smallest distance between
    particles of two pieces, in spacings; inf with one piece)."""
    from scipy.spatial import cKDTree

    x, labels = np.asarray(x), np.asarray(labels)
    pieces = labels >= 0
    xs, ls = x[pieces], labels[pieces]
    if len(np.unique(ls)) < 2:
        return {"inside": 0, "closest": math.inf}
    tree = cKDTree(xs)
    pairs = tree.query_pairs(2.0 * spacing, output_type="ndarray")
    apart = ls[pairs[:, 0]] != ls[pairs[:, 1]]
    pairs = pairs[apart]
    if not len(pairs):
        return {"inside": 0, "closest": math.inf}
    d = np.linalg.norm(xs[pairs[:, 0]] - xs[pairs[:, 1]], axis=1) / spacing
    close = pairs[d < INSIDE]
    return {"inside": int(len(np.unique(close))), "closest": float(d.min())}


def render(path, x: np.ndarray, labels: np.ndarray, sphere: np.ndarray, title: str, limit: int = 60_000):
    """Draw the pieces (``labels`` >= 0, each its colour, the sphere grey) and
    the failed particles (small, light) as points in perspective, from above
    at 35 degrees and from the side: matplotlib's mplot3d, off screen
    (Debian's VTK 9.1 renders through X alone: docs/verification/sphere-disk.md).
    At most ``limit`` points of each kind, evenly thinned."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x, labels, sphere = np.asarray(x), np.asarray(labels), np.asarray(sphere, dtype=bool)
    rank = np.zeros(len(labels), dtype=np.int64)  # pieces by size, largest first
    disk_pieces = (labels >= 0) & ~sphere
    names, counts = np.unique(labels[disk_pieces], return_counts=True)
    order = {n: k for k, n in enumerate(names[np.argsort(-counts, kind="stable")])}
    rank[disk_pieces] = [order[n] for n in labels[disk_pieces]]
    cmap = plt.get_cmap("tab20")
    fig = plt.figure(figsize=(13, 6.2))
    for k, (elev, azim) in enumerate(((35.0, -60.0), (0.0, -90.0))):
        ax = fig.add_subplot(1, 2, k + 1, projection="3d")
        for kind, mask, size in (("failed", labels < 0, 0.3), ("pieces", disk_pieces, 1.5), ("sphere", sphere, 1.5)):
            idx = np.flatnonzero(mask)
            idx = idx[:: max(1, len(idx) // limit)]
            if kind == "failed":
                colour = (0.75, 0.75, 0.75, 0.15)
            elif kind == "sphere":
                colour = (0.2, 0.2, 0.2, 1.0)
            else:
                colour = cmap(rank[idx] % 20)
            ax.scatter(*x[idx].T, s=size, c=[colour] if isinstance(colour, tuple) else colour, depthshade=False,
                       linewidths=0)
        ax.set_box_aspect(np.ptp(x, axis=0))
        ax.view_init(elev=elev, azim=azim)
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
        ax.set_zlabel("z (mm)")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
