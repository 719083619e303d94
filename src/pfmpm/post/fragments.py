"""Fragments: the pieces a body has broken into, their sizes, and how close
different bodies come.

:func:`count_fragments` counts the pieces of a phase-field run (the two
rings); :func:`fragment_sizes`, :func:`size_distribution` and
:func:`median_size` give the fragment-size distribution of a damage run (the
dynamic Brazilian disk, Homel & Herbold 2017, section 3.4, Fig. 18, with the
measure of ``shared/benchmarks-homel-herbold.md`` section 6). Both link the
particles into connected components with scipy's ``connected_components``.
"""

from __future__ import annotations

import math

import numpy as np

from .. import _core
from ..scene import Scene

__all__ = ["FULL_DAMAGE", "failed", "INTACT", "intact", "LINK", "MIN_POINTS", "linked_sets", "count_fragments", "fragments", "closest_approach",
           "particle_domains", "domain_gap", "run_fragments", "fragment_sizes", "size_distribution", "median_size", "mean_speed"]

FULL_DAMAGE = _core.DamageGradient().full_damage
"""Damage at which a particle has failed: the damage-gradient partition's
"fully damaged" test (D >= 1 - 1e-4), the one threshold of every damage
benchmark's measures."""


def failed(damage: np.ndarray) -> np.ndarray:
    """Which particles have failed: ``damage >= FULL_DAMAGE``."""
    return np.asarray(damage) >= FULL_DAMAGE


INTACT = {"undamaged": 1e-6, "unfailed": FULL_DAMAGE}
"""The two readings of an intact particle of the fragment measures: D_p at
most 1e-6 (the literal "undamaged" of H&H section 3.4), or not failed (D_p
below :data:`FULL_DAMAGE`)."""


def intact(damage: np.ndarray, which: str = "undamaged") -> np.ndarray:
    """Which particles are intact in the reading ``which`` of :data:`INTACT`."""
    damage = np.asarray(damage)
    if which == "undamaged":
        return damage <= INTACT["undamaged"]
    if which == "unfailed":
        return damage < INTACT["unfailed"]
    raise ValueError(f"intact = {which!r}: one of {sorted(INTACT)}")


LINK = 1.5
"""Two intact particles belong to one fragment when closer than this many particle spacings."""
MIN_POINTS = 4
"""A fragment has at least this many particles (fewer are debris)."""


def linked_sets(x: np.ndarray, radius: float) -> np.ndarray:
    """Label of the connected set of each point of ``x`` (N, 2) or (N, 3), two points
    linked when closer than ``radius`` (scipy's connected components)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    if len(x) == 0:
        return np.zeros(0, dtype=np.int32)
    pairs = cKDTree(x).query_pairs(radius, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(x), len(x)))
    return connected_components(graph, directed=False)[1]


def count_fragments(x: np.ndarray, spacing: float) -> int:
    """Number of connected sets of the points ``x`` (N, 2), two points linked when
    closer than :data:`LINK` spacings, with at least :data:`MIN_POINTS` points."""
    if len(x) == 0:
        return 0
    return int(np.count_nonzero(np.bincount(linked_sets(x, LINK * spacing)) >= MIN_POINTS))


def fragment_sizes(x: np.ndarray, measure: np.ndarray, mass: np.ndarray,
                   radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Sizes and masses of the fragments that the particles ``x`` (N, 2) or
    (N, 3) form.

    Two particles belong to one fragment when closer than ``radius`` (in the
    configuration ``x``; linked through others, as connected components). A
    fragment's size is its equivalent diameter, that of the disk of its area
    in 2D, sqrt(4 A / pi), or of the ball of its volume in 3D, (6 V / pi)^(1/3),
    with A or V the sum of its particles' ``measure``; its mass the sum of
    their ``mass``.

    Returns
    -------
    sizes, masses : ndarray
        One entry per fragment, in no particular order (empty for no particles).
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 2:
        x = x.reshape(-1, 2)
    if len(x) == 0:
        return np.zeros(0), np.zeros(0)
    labels = linked_sets(x, radius)
    total = np.bincount(labels, weights=np.asarray(measure, dtype=float))
    sizes = np.sqrt(4.0 * total / math.pi) if x.shape[1] == 2 else np.cbrt(6.0 * total / math.pi)
    return sizes, np.bincount(labels, weights=np.asarray(mass, dtype=float))


def size_distribution(sizes: np.ndarray, masses: np.ndarray,
                      smallest: float) -> tuple[np.ndarray, np.ndarray]:
    """The cumulative mass-fraction distribution of fragment size.

    Fragments of size below ``smallest`` are left out (not resolved); the
    rest are sorted by size, and the fraction at the k-th is the mass of the
    first k + 1 over the mass of all of them (the last is 1).

    Returns
    -------
    sizes, fractions : ndarray
        Ascending sizes and the mass fraction in fragments of at most that size.
    """
    sizes, masses = np.asarray(sizes, dtype=float), np.asarray(masses, dtype=float)
    kept = sizes >= smallest
    order = np.argsort(sizes[kept], kind="stable")
    s, m = sizes[kept][order], masses[kept][order]
    cumulative = np.cumsum(m)
    return s, cumulative / cumulative[-1] if len(m) else cumulative


def median_size(sizes: np.ndarray, masses: np.ndarray, smallest: float) -> float:
    """Mass-weighted median fragment size d50: the smallest size at which the
    cumulative mass fraction of :func:`size_distribution` reaches 1/2 (NaN
    with no fragment of at least ``smallest``)."""
    s, fraction = size_distribution(sizes, masses, smallest)
    if len(s) == 0:
        return math.nan
    return float(s[np.searchsorted(fraction, 0.5)])


def mean_speed(v: np.ndarray, mass: np.ndarray) -> float:
    """Mass-weighted mean particle speed ``sum M_p |v_p| / sum M_p`` of
    velocities ``v`` (N, 2) or (N, 3)."""
    v, mass = np.asarray(v, dtype=float), np.asarray(mass, dtype=float)
    if v.ndim != 2:
        v = v.reshape(-1, 2)
    return float(np.sum(mass * np.linalg.norm(v, axis=1)) / np.sum(mass))


def _spacing(scene: Scene) -> float:
    """The finest particle spacing of the scene's bodies."""
    return min(b.spacing(scene.grid.h) for b in scene.bodies)


def fragments(scene: Scene, x: np.ndarray, body: np.ndarray, c: np.ndarray) -> dict[str, int]:
    """Fragments per body: :func:`count_fragments` of its intact particles
    (``c`` at least the scene's ``output.crack_threshold``), in the finest
    particle spacing of the scene."""
    intact = np.asarray(c) >= scene.output.crack_threshold
    return {b.name: count_fragments(x[(body == k) & intact], _spacing(scene))
            for k, b in enumerate(scene.bodies)}


def closest_approach(scene: Scene, x: np.ndarray, body: np.ndarray) -> float:
    """Smallest distance between particles of different bodies, in particle
    spacings (below about 0.5 one body would be inside another); inf with one body."""
    from scipy.spatial import cKDTree

    closest = np.inf
    for k in range(len(scene.bodies)):
        mine, others = x[body == k], x[body != k]
        if len(mine) and len(others):
            closest = min(closest, float(cKDTree(mine).query(others)[0].min()))
    return closest / _spacing(scene)


def particle_domains(scene: Scene, particles) -> tuple[np.ndarray, np.ndarray]:
    """The half-edges r_1, r_2 (N x 2 each) of the particles' current domains:
    each particle's initial square, of side its body's particle spacing,
    carried by its deformation gradient. CPDI's domains where the run has
    them; otherwise F of the materials that keep it (neo-Hookean) and I +
    epsilon, the small strain without the rotation, of the others."""
    if hasattr(particles, "domain_r1"):
        return np.asarray(particles.domain_r1), np.asarray(particles.domain_r2)
    n = len(particles.body)
    F = np.empty((n, 2, 2))
    F[:] = np.eye(2)
    material = np.asarray(particles.material)
    for m, spec in enumerate(scene.materials):
        mine = material == m
        if not mine.any():
            continue
        if spec.model == "neo_hookean":
            F[mine] = np.asarray(particles.F)[mine].reshape(-1, 2, 2)
        elif hasattr(particles, "strain"):
            e = np.asarray(particles.strain)[mine]
            F[mine, 0, 0] += e[:, 0]
            F[mine, 1, 1] += e[:, 1]
            F[mine, 0, 1] = F[mine, 1, 0] = e[:, 2]
    half = 0.5 * np.array([b.spacing(scene.grid.h) for b in scene.bodies])[np.asarray(particles.body)]
    return F[:, :, 0] * half[:, None], F[:, :, 1] * half[:, None]


def domain_gap(scene: Scene, x: np.ndarray, body: np.ndarray, r1: np.ndarray,
               r2: np.ndarray) -> float:
    """The smallest gap between the domains (parallelograms x +- r_1 +- r_2,
    :func:`particle_domains`) of particles of different bodies, in grid
    cells: 0 where they touch, negative by the depth by which they overlap
    (the separating-axis distance along the four edge normals of the pair),
    inf where no two come within reach. The interpenetration measure of
    checks B4 and W3 of shared/benchmarks-homel-herbold.md (at least -0.1
    cells); unlike :func:`closest_approach` it does not take the shrinking
    of compressed particles for an overlap."""
    from scipy.spatial import cKDTree

    x, body = np.asarray(x), np.asarray(body)
    reach = np.abs(r1).sum(axis=1) + np.abs(r2).sum(axis=1)  # bounds each domain's extent
    gap = np.inf
    for k in range(len(scene.bodies)):
        mine, others = np.flatnonzero(body == k), np.flatnonzero(body > k)
        if not len(mine) or not len(others):
            continue
        near = cKDTree(x[mine]).query_ball_tree(cKDTree(x[others]), 2.0 * reach.max())
        counts = [len(q) for q in near]
        if not sum(counts):
            continue
        a = np.repeat(mine, counts)
        b = others[np.concatenate([q for q in near if q]).astype(np.int64)]
        d = x[b] - x[a]
        separation = np.full(len(a), -np.inf)
        for e in (r1[a], r2[a], r1[b], r2[b]):
            normal = np.stack([-e[:, 1], e[:, 0]], axis=1)
            normal /= np.linalg.norm(normal, axis=1)[:, None]
            support = sum(np.abs(np.einsum("ij,ij->i", normal, r[i]))
                          for r in (r1, r2) for i in (a, b))
            separation = np.maximum(separation, np.abs(np.einsum("ij,ij->i", normal, d)) - support)
        gap = min(gap, float(separation.min()))
    return gap / scene.grid.h


def run_fragments(scene: Scene, run_dir) -> list[dict]:
    """:func:`fragments` and :func:`closest_approach` at every particle snapshot of a run
    (with no phase field in the snapshots, every particle is intact).

    Returns
    -------
    list of dict
        Per snapshot: ``t``, ``fragments`` (by body name) and ``closest`` (spacings).
    """
    from .frames import read_frame, series

    rows = []
    for t, path in series(run_dir):
        frame = read_frame(t, path, scene.dim)
        body = frame.data["body"]
        c = frame.data.get("c", np.ones(len(body)))  # no phase field: nothing can crack
        rows.append({"t": t, "fragments": fragments(scene, frame.x, body, c),
                     "closest": closest_approach(scene, frame.x, body)})
    return rows
