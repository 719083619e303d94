"""Bodies from mesh files (meshio) and from PNG masks: their particles against
the source's area, and their scene keys."""

import json

import matplotlib.image as mpimg
import meshio
import numpy as np
import pytest

from pfmpm import Simulation
from pfmpm.scene import (Body, Grid, ImageShape, Material, MeshShape, Polygon, Rectangle, Scene,
                         SceneError, image_colors, seeding)
from pfmpm.scene.toml import read_toml

# An L-shaped outline with a square hole, its corners off the particle lattice.
OUTLINE = [(0.1, 0.1), (6.1, 0.1), (6.1, 2.1), (2.1, 2.1), (2.1, 4.1), (0.1, 4.1)]
HOLE = Rectangle((0.6, 0.6), (1.6, 1.6))
AREA = 6 * 2 + 2 * 2 - 1
GRID = Grid(size=(8.0, 6.0), h=0.25)
STEEL = Material("m", 200.0, 0.3, 1.0)


def count(body: Body) -> int:
    return sum(len(p) for p in seeding.lattice(body, GRID, *seeding.cell_range(body, GRID)))


def write_mesh(path, kind: str) -> None:
    """The L-shape minus the hole as quadrilaterals (``kind = "quad"``) or
    triangles, on the lines through every corner."""
    xs = np.unique([p[0] for p in OUTLINE] + [0.6, 1.6])
    ys = np.unique([p[1] for p in OUTLINE] + [0.6, 1.6])
    outline = Polygon(OUTLINE)
    nx = len(xs)
    cells = []
    for j in range(len(ys) - 1):
        for i in range(nx - 1):
            cx, cy = 0.5 * (xs[i] + xs[i + 1]), 0.5 * (ys[j] + ys[j + 1])
            if outline.contains(cx, cy) and not HOLE.contains(cx, cy):
                cells.append([j * nx + i, j * nx + i + 1, (j + 1) * nx + i + 1, (j + 1) * nx + i])
    cells = np.array(cells)
    if kind == "triangle":
        cells = np.concatenate([cells[:, [0, 1, 2]], cells[:, [0, 2, 3]]])
    X, Y = np.meshgrid(xs, ys)
    points = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    meshio.write_points_cells(path, points, [(kind, cells)])


@pytest.mark.parametrize("name, kind", [("l.msh", "quad"), ("l.vtk", "triangle"), ("l.vtu", "quad")])
def test_a_mesh_body_has_the_particles_of_its_outline(tmp_path, name, kind, capfd):
    """Every lattice point inside the mesh's cells, and only those: the same
    particles as the polygon minus the hole it meshes, whose volume adds up to
    its area to within the lattice's boundary layer."""
    write_mesh(tmp_path / name, kind)
    capfd.readouterr()  # meshio's notes on gmsh tags
    shape = MeshShape(str(tmp_path / name))
    assert shape.area == pytest.approx(AREA, rel=1e-12)
    assert shape.bounds() == pytest.approx((0.1, 0.1, 6.1, 4.1))
    n = count(Body("mesh", "m", shape, particles_per_cell=2))
    assert n == count(Body("poly", "m", Polygon(OUTLINE), holes=(HOLE,), particles_per_cell=2)) == 960
    spacing = GRID.h / 2
    assert n * spacing**2 == pytest.approx(AREA, rel=0.01)


def test_mesh_scale_offset_and_errors(tmp_path, capfd):
    write_mesh(tmp_path / "l.msh", "quad")
    shape = MeshShape(str(tmp_path / "l.msh"), scale=0.5, offset=(1.0, 1.0))
    assert shape.area == pytest.approx(AREA / 4)
    assert shape.bounds() == pytest.approx((1.05, 1.05, 4.05, 3.05))
    meshio.write_points_cells(tmp_path / "lines.vtk", np.zeros((2, 3)), [("line", np.array([[0, 1]]))])
    with pytest.raises(SceneError, match=r"^file = '.*lines.vtk': has no triangle or quadrilateral cells \(it has line\)"):
        MeshShape(str(tmp_path / "lines.vtk"))
    (tmp_path / "junk.msh").write_text("not a mesh")
    with pytest.raises(SceneError, match=r"^file = '.*junk.msh': cannot be read as a mesh"):
        MeshShape(str(tmp_path / "junk.msh"))


def mask(path) -> None:
    """A 60 x 40 PNG: white, a red 20 x 15 rectangle and a blue 15 x 10 one."""
    image = np.full((40, 60, 3), 255, np.uint8)
    image[5:20, 10:30] = (255, 0, 0)
    image[25:35, 40:55] = (0, 0, 255)
    mpimg.imsave(path, image)


def test_an_image_gives_one_body_per_colour(tmp_path):
    """Pixels of a particle spacing: one particle per pixel of the body's colour."""
    mask(tmp_path / "mask.png")
    assert image_colors(str(tmp_path / "mask.png")) == {"#ffffff": 1950, "#ff0000": 300, "#0000ff": 150}
    pixel = GRID.h / 2
    for colour, pixels, box in (("#ff0000", 300, (1.25, 2.5, 3.75, 4.375)),
                                ([0, 0, 255], 150, (5.0, 0.625, 6.875, 1.875))):
        shape = ImageShape(str(tmp_path / "mask.png"), pixel=pixel, color=colour)
        assert shape.bounds() == pytest.approx(box)
        n = count(Body("b", "m", shape, particles_per_cell=2))
        assert n == pixels and n * pixel**2 == shape.area
    with pytest.raises(SceneError, match=r"^color = '#00ff00': no pixel of .*mask.png has it"):
        ImageShape(str(tmp_path / "mask.png"), pixel=pixel, color="#00ff00")
    with pytest.raises(SceneError, match=r"^color = 'red': must be"):
        ImageShape(str(tmp_path / "mask.png"), pixel=pixel, color="red")


def test_scene_files_find_their_meshes_and_masks_beside_them(tmp_path, capfd):
    """A relative ``file`` is read from the scene file's folder, whatever the
    current directory; the particles carry the scene's density; the scene
    runs and its checkpointed dict names the file."""
    folder = tmp_path / "scene"
    folder.mkdir()
    write_mesh(folder / "l.msh", "quad")
    mask(folder / "mask.png")
    (folder / "s.toml").write_text("""
name = "shapes"
[grid]
size = [12.0, 6.0]
h = 0.25
[time]
end = 0.05
[[materials]]
name = "m"
E = 200.0
nu = 0.3
density = 2.5
[[bodies]]
name = "l"
material = "m"
shape = { type = "mesh", file = "l.msh" }
[[bodies]]
name = "red"
material = "m"
shape = { type = "image", file = "mask.png", pixel = 0.125, color = "#ff0000", origin = [6.5, 0.0] }
""")
    scene = Scene.from_toml(folder / "s.toml")
    assert scene.bodies[0].shape.file == str(folder / "l.msh")
    assert read_toml(folder / "s.toml")["bodies"][1]["shape"]["file"] == str(folder / "mask.png")
    sim = Simulation(scene)
    assert np.bincount(sim.particles.body).tolist() == [960, 300]
    assert sim.particles.volume.sum() == pytest.approx((960 + 300) * 0.125**2)
    np.testing.assert_allclose(sim.particles.mass, 2.5 * sim.particles.volume, rtol=1e-15)
    sim.advance(5)
    again = Scene.from_dict(json.loads(json.dumps(scene.to_dict())))
    assert again == scene
