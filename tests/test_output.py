"""The particle files of pfmpm.output, read back by meshio, the names in them,
and the particle columns as attributes."""

import meshio
import numpy as np

from pfmpm.output import _BLOCK, Rows, write_vtu
from pfmpm.scene import Scene


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


def test_rows_are_written_as_the_array_they_make(tmp_path):
    """A field given as Rows, in blocks of uneven length (one empty), writes
    the same bytes as the array it adds up to."""
    n = 2 * _BLOCK + 5
    rng = np.random.default_rng(2)
    x, u = rng.random((n, 2)), rng.random((n, 2))
    cuts = [0, 7, 7, _BLOCK + 3, n]
    rows = Rows(n, lambda: (u[a:b] for a, b in zip(cuts, cuts[1:])))
    write_vtu(tmp_path / "a.vtu", x, iter([("u", u, ""), ("id", np.arange(n), "")]))
    write_vtu(tmp_path / "b.vtu", x, iter([("u", rows, ""), ("id", Rows.of(n, np.arange, np.int64), "")]))
    assert (tmp_path / "a.vtu").read_bytes() == (tmp_path / "b.vtu").read_bytes()


def test_a_snapshot_holds_no_array_of_all_particles(tmp_path, monkeypatch):
    """Issue 18 (memory of a whole run): writing a particle file, taking a
    phase-field image and recording the crack tip make no copy of a particle
    column. With blocks (of the files, and of the seeded positions the
    displacement reads back from the ids) and image bands of about 1024
    particles, everything they allocate at once is below 4 bytes per
    particle (the masks of one comparison over all particles); one column
    of doubles is 8, the displacement or a tree of every point 16 or more."""
    import tracemalloc

    import scipy.spatial  # noqa: F401 (imported before the count, as a run has)

    from pfmpm import observe, output
    from pfmpm.simulation import Simulation

    monkeypatch.setattr(output, "_BLOCK", 1024)
    monkeypatch.setattr(observe, "_QUERY_PIXELS", 1024)
    scene = Scene.from_toml("demos/borden_plate.toml", ["grid.h=0.5", "materials.concrete.fracture.l0=1.0"])
    sim = Simulation(scene)
    n = len(sim.particles)
    frames, images, tips = (observe.FrameObserver(sim), observe.SnapshotObserver(sim),
                            observe.CrackObserver(sim))
    frames.start(sim, tmp_path)
    row = {}
    tracemalloc.start()
    try:
        frames.record(sim, row, True)
        images.record(sim, row, True)
        tips.record(sim, row, True)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    snapshots = images.snapshots
    assert n > 100_000 and len(snapshots.images) == 1 and set(row) == set(observe.CrackTip.columns())
    kept = snapshots.images[0][1].nbytes  # the image itself (at most SNAPSHOT_PIXELS of them)
    assert peak - kept < 4 * n, f"{(peak - kept) / n:.1f} bytes per particle"
    written = meshio.read(tmp_path / "particles_000000.vtu")
    assert np.array_equal(written.point_data["displacement"], np.zeros((n, 3)))
    assert np.array_equal(written.point_data["id"].ravel(), np.arange(n))


def test_particle_columns_are_attributes_under_the_names_the_docs_use():
    """``dir(sim.particles)`` lists every column (issue 53), each a view of N
    rows; the README and the notebooks name only columns."""
    import re
    from pathlib import Path

    from pfmpm.simulation import Simulation

    root = Path(__file__).resolve().parents[1]
    sim = Simulation(Scene.from_toml(root / "demos" / "borden_plate.toml",
                                     ["grid.h=2.0", "materials.concrete.fracture.l0=4.0"]))
    p = sim.particles
    columns = {c["name"]: c["components"] for c in p.columns()}
    assert {"x", "v", "stress", "c", "history", "body", "material"} <= set(columns) <= set(dir(p))
    for name, components in columns.items():
        assert getattr(p, name).shape == ((len(p),) if components == 1 else (len(p), components)), name
    p.v[3] = (1.5, -2.0)  # a view: the core's own memory
    assert p.v[3].tolist() == [1.5, -2.0]
    docs = [root / "README.md", *sorted((root / "docs" / "notebooks").glob("*.ipynb"))]
    text = "".join(path.read_text() for path in docs)
    used = set(re.findall(r"particles\.([A-Za-z_]\w*)", text)) - {"pvd", "columns"}
    assert {"x", "c"} <= used <= set(columns)


def test_the_vtu_files_name_the_bodies_and_materials(tmp_path):
    """Each snapshot's field data says which body and material each integer is."""
    from pfmpm.simulation import Simulation

    scene = Scene.from_toml("demos/disk_beam.toml", ["grid.h=1.0", "materials.beam.fracture.l0=2.0",
                                                     "materials.disk.fracture.l0=2.0"])
    sim = Simulation(scene)
    frames = sim.open_frames(tmp_path)
    frames.write()
    mesh = meshio.read(tmp_path / "particles_000000.vtu")
    assert {k: v.tolist() for k, v in mesh.field_data.items()} == {
        "body beam": [0], "body disk": [1], "material beam": [0], "material disk": [1]}
    body = mesh.point_data["body"].ravel()
    assert np.array_equal(body, sim.particles.body) and set(body) == {0, 1}
