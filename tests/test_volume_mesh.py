"""Bodies from volume meshes (meshio's tetrahedra and hexahedra): a mesh with
volume cells is a 3D shape; its particles lie in its cells, fill its volume,
leave its cavities empty; a scene file runs with one; the wrong dimension is
a one-line error naming the file."""

from __future__ import annotations

import itertools

import meshio
import numpy as np
import pytest

from pfmpm import Scene, Simulation
from pfmpm.cli import main
from pfmpm.scene import Body, Box, GridSpec, MeshShape, SceneError, seeding
from pfmpm.scene.toml import toml_text

GRID = GridSpec(size=(4.0, 4.0, 4.0), h=0.25)
"""Particle centres (2 x 2 x 2 per cell) at 0.0625 + 0.125 k: none on the
meshes' faces below, which lie at 0.1 + multiples of 0.1."""


def block(cells: tuple[int, int, int], lo, hi, cavity=()) -> tuple[np.ndarray, np.ndarray]:
    """A structured block of hexahedra from ``lo`` to ``hi``, ``cells`` a side,
    without the cells whose (i, j, k) are in ``cavity``: points (n, 3) and
    hexahedra (m, 8) in meshio's corner order."""
    axes = [np.linspace(a, b, n + 1) for a, b, n in zip(lo, hi, cells)]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    index = np.arange(len(points)).reshape([n + 1 for n in cells])
    hexes = [[index[i + a, j + b, k + c] for c, b, a in ((0, 0, 0), (0, 0, 1), (0, 1, 1), (0, 1, 0),
                                                          (1, 0, 0), (1, 0, 1), (1, 1, 1), (1, 1, 0))]
             for i, j, k in itertools.product(*map(range, cells)) if (i, j, k) not in cavity]
    return points, np.array(hexes)


def five_tetrahedra(hexes: np.ndarray, parity: np.ndarray) -> np.ndarray:
    """Each hexahedron as five tetrahedra, the corner cut off at 0 or at 1 as
    ``parity`` says; alternating parity in a block makes a conforming mesh."""
    even = [(0, 1, 3, 4), (1, 2, 3, 6), (1, 4, 5, 6), (3, 4, 6, 7), (1, 3, 4, 6)]
    odd = [(0, 1, 2, 5), (0, 2, 3, 7), (0, 4, 5, 7), (2, 5, 6, 7), (0, 2, 5, 7)]
    return np.concatenate([hexes[parity == p][:, list(t)] for p, split in ((0, even), (1, odd)) for t in split])


def particles(shape, holes=(), grid=GRID, per_cell=2) -> np.ndarray:
    body = Body("b", "m", shape, holes=holes, particles_per_cell=per_cell)
    return np.concatenate([np.empty((0, 3)), *seeding.lattice(body, grid, *seeding.cell_range(body, grid))])


CAVITY = {(1, 1, 1)}
"""The block's cavity: one interior cell of its 3 x 3 x 3, 0.6 to 1.2 (plus
the offset 0.1) in every direction: 4 x 4 x 4 lattice points."""


def holed_block(path, kind: str) -> MeshShape:
    """A 1.8 cube of 3 x 3 x 3 cells from (0.1, 0.1, 0.1), the middle one left
    out: hexahedra, or five tetrahedra each (alternating), written to ``path``."""
    points, hexes = block((3, 3, 3), (0.0, 0.0, 0.0), (1.8, 1.8, 1.8), CAVITY)
    cells = hexes
    if kind == "tetra":
        corner = points[hexes[:, 0]] / 0.6
        cells = five_tetrahedra(hexes, np.round(corner).astype(int).sum(axis=1) % 2)
    meshio.write_points_cells(path, points, [(kind, cells)])
    return MeshShape(str(path), offset=(0.1, 0.1, 0.1))


@pytest.mark.parametrize("name, kind", [("block.vtu", "hexahedron"), ("block.vtk", "tetra"),
                                        ("block.msh", "tetra")])
def test_a_mesh_with_a_cavity_seeds_the_block_minus_the_cavity(tmp_path, name, kind, capfd):
    """The same particles, in the same order, as the box minus the cavity's
    box; the cavity holds none; the mesh's volume is 26 cells'."""
    shape = holed_block(tmp_path / name, kind)
    capfd.readouterr()  # meshio's notes on gmsh tags
    assert shape.dim == 3 and shape.volume == pytest.approx(26 * 0.6**3, rel=1e-12)
    assert shape.bounds() == pytest.approx((0.1, 0.1, 0.1, 1.9, 1.9, 1.9))
    x = particles(shape)
    cavity = Box((0.7, 0.7, 0.7), (1.3, 1.3, 1.3))
    np.testing.assert_array_equal(x, particles(Box((0.1,) * 3, (1.9,) * 3), holes=(cavity,)))
    assert len(x) == 14**3 - 4**3 and not cavity.contains(*x.T).any()


def test_a_tetrahedral_cube_off_the_lattice_fills_its_volume(tmp_path):
    """A cube of five tetrahedra, of six, and of five second-order ones (read
    by their corners), scaled and offset off the lattice: the particles are
    the lattice points in the cube, their volume the cube's to 2 % (46.4
    particle spacings a side: +1.7 %); points on the faces its tetrahedra
    share are inside."""
    points, hexes = block((1, 1, 1), (0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    five = five_tetrahedra(hexes, np.zeros(1, int))
    six = hexes[:, [0, 1, 2, 6, 0, 2, 3, 6, 0, 3, 7, 6, 0, 7, 4, 6, 0, 4, 5, 6, 0, 5, 1, 6]].reshape(-1, 4)
    edges = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]
    middles = np.concatenate([0.5 * (points[five[:, a]] + points[five[:, b]]) for a, b in edges])
    ten = np.column_stack([five, len(points) + np.arange(len(middles)).reshape(len(edges), -1).T])
    spacing = GRID.h / 4
    lo = np.array([0.33, 0.41, 0.27])
    lattice = 0.5 * spacing + spacing * np.arange(64)
    for kind, cells, nodes in (("tetra", five, points), ("tetra", six, points),
                               ("tetra10", ten, np.concatenate([points, middles]))):
        meshio.write_points_cells(tmp_path / "cube.vtu", nodes, [(kind, cells)])
        shape = MeshShape(str(tmp_path / "cube.vtu"), scale=2.9, offset=tuple(lo))
        assert shape.volume == pytest.approx(2.9**3, rel=1e-12)
        assert shape.bounds() == pytest.approx((*lo, *(lo + 2.9)))
        x = particles(shape, per_cell=4)
        assert len(x) == np.prod([np.sum((lattice >= a) & (lattice <= a + 2.9)) for a in lo])
        assert np.all((x >= lo) & (x <= lo + 2.9))
        assert len(x) * spacing**3 == pytest.approx(shape.volume, rel=0.02)
        # The faces' diagonals and the cube's main diagonal lie on faces that tetrahedra share.
        t = np.linspace(0.0, 1.0, 101)
        for a, b in ((0, 6), (0, 2), (1, 3), (4, 6), (0, 5), (2, 7)):
            p = lo + 2.9 * (points[a] + t[:, None] * (points[b] - points[a]))
            assert shape.contains(*p.T).all()
        assert not shape.contains(*(lo - 1e-6)) and not shape.contains(np.nan, 1.0, 1.0)


def test_a_warped_block_of_hexahedra_matches_its_tetrahedra(tmp_path):
    """A 6 x 5 x 4 block of hexahedra with its inner points moved at random:
    a point lies in the mesh when it lies in one of its hexahedra's six
    tetrahedra (tested one by one), in chunks of any size."""
    points, hexes = block((6, 5, 4), (0.0, 0.0, 0.0), (3.0, 2.5, 2.0))
    rng = np.random.default_rng(3)
    inner = np.all((points > 0) & (points < [3.0, 2.5, 2.0]), axis=1)
    points[inner] += rng.uniform(-0.15, 0.15, (inner.sum(), 3))
    meshio.write_points_cells(tmp_path / "warped.vtu", points, [("hexahedron", hexes)])
    shape = MeshShape(str(tmp_path / "warped.vtu"))
    q = rng.uniform(-0.2, 3.2, (4000, 3))
    inside = shape.contains(q[:, 0], q[:, 1], q[:, 2])
    assert inside.shape == (4000,) and 0.3 < inside.mean() < 0.7
    corners = points[hexes[:, [0, 1, 2, 6, 0, 2, 3, 6, 0, 3, 7, 6, 0, 7, 4, 6, 0, 4, 5, 6, 0, 5, 1, 6]]]
    corners = corners.reshape(-1, 4, 3)
    inverse = np.linalg.inv(np.swapaxes(corners[:, 1:] - corners[:, :1], 1, 2))
    lam = np.einsum("mij,nmj->nmi", inverse, q[:, None] - corners[None, :, 0])
    expected = np.any(np.all(lam >= -1e-9, axis=2) & (lam.sum(axis=2) <= 1 + 1e-9), axis=1)
    np.testing.assert_array_equal(inside, expected)
    assert shape.contains(*q.T.reshape(3, 40, 100)).shape == (40, 100)


def scene_tables(file: str) -> dict:
    """A 3D scene of one body, the mesh ``file``, on GRID."""
    return {"name": "mesh3d", "grid": {"size": [4.0, 4.0, 4.0], "h": 0.25}, "time": {"end": 0.02},
            "output": {"energies_every": 1, "particles": False},
            "materials": [{"name": "m", "E": 100.0, "nu": 0.3, "density": 2.0}],
            "bodies": [{"name": "b", "material": "m", "velocity": [0.5, 0.0, 0.0],
                        "shape": {"type": "mesh", "file": file, "offset": [0.1, 0.1, 0.1]}}]}


def test_pfmpm_run_of_a_scene_with_a_mesh_body(tmp_path):
    """A scene file naming its mesh beside it runs from the command line; its
    particles are the lattice points in the mesh, each of volume (h/2)^3."""
    holed_block(tmp_path / "block.vtu", "tetra")
    toml = tmp_path / "mesh3d.toml"
    tables = scene_tables("block.vtu")  # found beside the scene file
    tables["grid"]["size"], tables["time"]["end"] = [2.0, 2.0, 2.0], 0.05
    toml.write_text(toml_text(tables))
    assert main(["run", str(toml), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    scene = Scene.from_toml(toml)
    assert scene.dim == 3 and scene.bodies[0].shape.file == str(tmp_path / "block.vtu")
    sim = Simulation(scene)
    assert sim.particles.volume.sum() == pytest.approx((14**3 - 4**3) * 0.125**3)
    energies = (tmp_path / "out" / "energies.csv").read_text().splitlines()
    assert len(energies) > 3 and "momentum_z" in energies[0]


def test_wrong_dimensions_and_bad_files_are_one_line_errors(tmp_path, capfd):
    """A flat mesh in a 3D scene, a volume mesh in a 2D one, a surface mesh, a
    mesh of lines, a file that is no mesh, and a 2D offset for a 3D mesh."""
    square = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    meshio.write_points_cells(tmp_path / "flat.vtu", square, [("triangle", np.array([[0, 1, 2], [0, 2, 3]]))])
    tent = square + [[0.0, 0.0, 0.0], [0.0, 0.0, 0.5], [0.0, 0.0, 0.0], [0.0, 0.0, 0.5]]
    meshio.write_points_cells(tmp_path / "tent.vtu", tent, [("triangle", np.array([[0, 1, 2], [0, 2, 3]]))])
    meshio.write_points_cells(tmp_path / "lines.vtu", square, [("line", np.array([[0, 1], [1, 2]]))])
    holed_block(tmp_path / "block.vtu", "hexahedron")
    (tmp_path / "junk.msh").write_text("not a mesh")
    flat = scene_tables(str(tmp_path / "block.vtu"))
    flat["grid"] = {"size": [4.0, 4.0], "h": 0.25}
    flat["bodies"][0].update(velocity=[0.5, 0.0], shape={"type": "mesh", "file": str(tmp_path / "block.vtu")})
    plane = scene_tables(str(tmp_path / "flat.vtu"))
    del plane["bodies"][0]["shape"]["offset"]
    cases = [
        (plane, r"bodies\[0\].shape.file = '.*flat.vtu': has no tetrahedra or hexahedra \(it has triangle\):"
         r" a 2D mesh in a 3D scene \(grid.size has 3 entries\); mesh its volume, or extrude it"),
        (scene_tables(str(tmp_path / "flat.vtu")), r"bodies\[0\].shape.file = '.*flat.vtu': has no tetrahedra or"
         r" hexahedra \(it has triangle\): a 2D mesh, but offset = \[0.1, 0.1, 0.1\] has 3 components"),
        (flat, r"bodies\[0\].shape.file = '.*block.vtu': has volume cells \(it has hexahedron\): a 3D mesh in a"
         r" 2D scene"),
        (scene_tables(str(tmp_path / "tent.vtu")), r"bodies\[0\].shape.file = '.*tent.vtu': has no tetrahedra or"
         r" hexahedra \(it has triangle\) and is not flat"),
        (scene_tables(str(tmp_path / "lines.vtu")), r"bodies\[0\].shape.file = '.*lines.vtu': has no triangle or"
         r" quadrilateral cells \(it has line\) and no tetrahedra or hexahedra"),
        (scene_tables(str(tmp_path / "junk.msh")), r"bodies\[0\].shape.file = '.*junk.msh': cannot be read as a"
         r" mesh"),
    ]
    offset = scene_tables(str(tmp_path / "block.vtu"))
    offset["bodies"][0]["shape"]["offset"] = [0.1, 0.1]
    cases.append((offset, r"bodies\[0\].shape.offset = \[0.1, 0.1\]: has 2 components, but the mesh is 3D"))
    extruded = scene_tables(str(tmp_path / "block.vtu"))
    extruded["bodies"][0]["shape"] = {"type": "extrusion", "shape": {"type": "mesh", "file": str(tmp_path / "block.vtu")},
                                      "z0": 0.0, "z1": 1.0}
    cases.append((extruded, r"bodies\[0\].shape.shape = 'mesh': a 3D shape \(mesh\): an extrusion takes a 2D one"))
    for tables, message in cases:
        with pytest.raises(SceneError) as err:
            Scene.from_dict(tables)
        assert "\n" not in str(err.value)
        assert err.match("^" + message), str(err.value)
    capfd.readouterr()
    # From the command line: one line, no traceback.
    flat = scene_tables("flat.vtu")
    del flat["bodies"][0]["shape"]["offset"]
    (tmp_path / "flat.toml").write_text(toml_text(flat))
    assert main(["run", str(tmp_path / "flat.toml"), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capfd.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: bodies[0].shape.file = ") and "has no tetrahedra" in err[0]
