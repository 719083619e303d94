"""Fragments: the pieces a body has broken into, and how close different bodies come."""

from __future__ import annotations

import numpy as np

from ..scene import Scene

__all__ = ["LINK", "MIN_POINTS", "linked_sets", "count_fragments", "fragments", "closest_approach",
           "run_fragments"]

LINK = 1.5
"""Two intact particles belong to one fragment when closer than this many particle spacings."""
MIN_POINTS = 4
"""A fragment has at least this many particles (fewer are debris)."""


def linked_sets(x: np.ndarray, radius: float) -> np.ndarray:
    """Label of the connected set of each point of ``x`` (N, 2), two points
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
        frame = read_frame(t, path)
        body = frame.data["body"]
        c = frame.data.get("c", np.ones(len(body)))  # no phase field: nothing can crack
        rows.append({"t": t, "fragments": fragments(scene, frame.x, body, c),
                     "closest": closest_approach(scene, frame.x, body)})
    return rows
