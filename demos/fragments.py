"""Fragments per body and the closest approach of different bodies in a run's output.

Reads the particle snapshots (``particles.pvd``) a ``pfmpm run`` wrote and, for
each snapshot, prints per body the number of fragments (connected sets of
particles with c >= 0.2, two particles connected when closer than 1.5 particle
spacings) and the smallest distance between particles of different bodies in
particle spacings (below about 0.5 a body would be inside another).

    .venv/bin/python demos/fragments.py out/two_rings demos/two_rings.toml
"""

from __future__ import annotations

import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from pfmpm.scene import Scene

THRESHOLD = 0.2


def fragments(x: np.ndarray, spacing: float) -> int:
    """Connected sets of the points ``x`` (links shorter than 1.5 spacings) with more than 3 points."""
    pairs = cKDTree(x).query_pairs(1.5 * spacing, output_type="ndarray")
    from scipy.sparse import coo_matrix

    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(x), len(x)))
    _, labels = connected_components(graph, directed=False)
    return int(np.count_nonzero(np.bincount(labels) > 3))


def main() -> None:
    out, scene_path = Path(sys.argv[1]), sys.argv[2]
    scene = Scene.from_toml(scene_path, sys.argv[3:])
    spacing = scene.grid.h / max(b.particles_per_cell for b in scene.bodies)
    names = [b.name for b in scene.bodies]
    for item in ET.parse(out / "particles.pvd").getroot().iter("DataSet"):
        mesh = meshio.read(out / item.get("file"))
        x = mesh.points[:, :2]
        body, c = mesh.point_data["body"].ravel(), mesh.point_data["c"].ravel()
        counts = [fragments(x[(body == b) & (c >= THRESHOLD)], spacing) for b in range(len(names))]
        closest = np.inf
        for b in range(len(names)):
            tree = cKDTree(x[body == b])
            closest = min(closest, float(tree.query(x[body != b])[0].min()))
        text = ", ".join(f"{n}: {k}" for n, k in zip(names, counts))
        print(f"t = {float(item.get('timestep')):8.2f}  fragments {text}  closest {closest / spacing:.2f} spacings")


if __name__ == "__main__":
    main()
