"""The particle files of pfmpm.output, read back by meshio, and the seeding
that writes positions in place."""

import meshio
import numpy as np

from pfmpm.output import _BLOCK, write_vtu
from pfmpm.scene import Scene, seeding


def test_vtu_written_in_blocks_reads_back_exactly(tmp_path):
    """More particles than one encoding block, with byte counts that are not
    multiples of 3, so the base64 pieces of the blocks must join: every array
    reads back bit for bit, tensors and vectors in ParaView's layout."""
    n = 2 * _BLOCK + 7
    rng = np.random.default_rng(1)
    x = rng.random((n, 2))
    stress = rng.random((n, 4))  # xx, yy, xy, zz
    v = rng.random((n, 2))
    body = rng.integers(0, 5, n).astype(np.int32)
    path = tmp_path / "p.vtu"
    write_vtu(path, x, iter([("stress", stress, "xx,yy,xy,zz"), ("velocity", v, "x,y"),
                             ("body", body, "")]))
    mesh = meshio.read(path)
    assert np.array_equal(mesh.points[:, :2], x) and not mesh.points[:, 2].any()
    s = mesh.point_data["stress"]
    assert np.array_equal(s[:, [0, 1, 3, 2]], stress) and not s[:, 4:].any()
    assert np.array_equal(mesh.point_data["velocity"][:, :2], v)
    assert np.array_equal(mesh.point_data["body"].ravel(), body)
    assert np.array_equal(mesh.cells_dict["vertex"][:, 0], np.arange(n))


def test_write_positions_is_positions_in_place():
    scene = Scene.from_toml("demos/disk_beam.toml")
    xs = seeding.positions(scene)
    out = np.full((sum(len(x) for x in xs), 2), np.nan)
    seeding.write_positions(scene, out)
    assert np.array_equal(out, np.concatenate(xs))
