"""Tests of pfmpm.scene: loading, validation, overrides and particle generation."""

import copy
import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pfmpm import scenes

from pfmpm.scene import stability
from pfmpm.scene import (
    CRITICAL_FACTOR,
    LONE_PARTICLE_FACTOR,
    Body,
    BodyForce,
    Disk,
    Grid,
    Material,
    Output,
    Polygon,
    Rectangle,
    Ring,
    Scene,
    SceneError,
    Time,
    Traction,
    Wall,
    apply_overrides,
    wave_speed,
)

GLASS = {"name": "glass", "E": 32000.0, "nu": 0.2, "density": 2450.0}


def base():
    """A small valid scene dict: a 10 x 4 plate on a 10 x 4 grid of h = 0.5."""
    return {
        "name": "plate",
        "grid": {"size": [10.0, 4.0], "h": 0.5},
        "time": {"end": 1.0},
        "materials": [dict(GLASS)],
        "bodies": [{
            "name": "plate",
            "material": "glass",
            "shape": {"type": "rectangle", "min": [0.0, 0.0], "max": [10.0, 4.0]},
        }],
        "walls": [{"side": "left", "type": "fixed"}],
    }


def scene_with(shape, holes=(), h=0.5, size=(10.0, 4.0), n=2, thickness=1.0, loads=()):
    """Scene with one glass body of the given shape on a grid at the origin."""
    return Scene(
        grid=Grid(size=size, h=h),
        time=Time(end=1.0),
        materials=[Material(**GLASS)],
        bodies=[Body("b", "glass", shape, holes=holes, particles_per_cell=n)],
        thickness=thickness,
        loads=loads,
    )


def area(scene):
    """Total particle volume divided by the thickness."""
    return scene.particles()["volume"].sum() / scene.thickness


# -- particle generation -------------------------------------------------------


def test_rectangle_count_mass_and_layout():
    s = scene_with(Rectangle((2.0, 1.0), (8.0, 3.0)), n=3, thickness=2.5)
    p = s.particles()
    cells = (6 / 0.5) * (2 / 0.5)
    assert len(p["x"]) == cells * 9
    assert p["mass"].sum() == pytest.approx(2450.0 * 12.0 * 2.5, rel=1e-12)
    assert np.allclose(p["volume"], (0.5 / 3) ** 2 * 2.5)
    assert p["x"].dtype == np.float64 and p["x"].flags["C_CONTIGUOUS"]
    assert p["body"].dtype == np.int32 and p["material"].dtype == np.int32
    assert p["x"][:, 0].min() == pytest.approx(2.0 + 0.5 / 6)
    assert p["x"][:, 1].max() == pytest.approx(3.0 - 0.5 / 6)
    assert np.array_equal(p["x"], s.particles()["x"])  # deterministic
    assert np.all(p["fext"] == 0) and np.all(p["v"] == 0)


def test_disk_area_converges():
    s = scene_with(Disk((5.0, 5.0), 4.0), size=(10.0, 10.0), h=0.125)
    assert area(s) == pytest.approx(math.pi * 16.0, rel=0.01)


def test_ring_and_hole_areas():
    ring = scene_with(Ring((5.0, 5.0), 2.0, 4.0), size=(10.0, 10.0), h=0.125)
    assert area(ring) == pytest.approx(math.pi * 12.0, rel=0.01)
    holed = scene_with(Rectangle((0.0, 0.0), (10.0, 10.0)), holes=[Disk((5.0, 5.0), 3.0)],
                       size=(10.0, 10.0), h=0.125)
    assert area(holed) == pytest.approx(100.0 - math.pi * 9.0, rel=0.005)


def test_polygon_triangle_area():
    tri = Polygon([(1.0, 1.0), (9.0, 1.0), (1.0, 9.0)])
    assert tri.contains(np.array([2.0, 8.0]), np.array([2.0, 8.0])).tolist() == [True, False]
    s = scene_with(tri, size=(10.0, 10.0), h=0.125)
    assert area(s) == pytest.approx(32.0, rel=0.01)


@pytest.mark.parametrize("edge, length", [("top", 6.0), ("bottom", 6.0), ("left", 2.0), ("right", 2.0)])
def test_traction_total_force(edge, length):
    load = Traction("b", edge, (0.3, -1.5))
    s = scene_with(Rectangle((2.0, 1.0), (8.0, 3.0)), n=3, thickness=2.0, loads=[load])
    p = s.particles()
    total = p["fext"].sum(axis=0)
    assert total == pytest.approx(np.array([0.3, -1.5]) * length * 2.0, rel=1e-12)
    assert np.count_nonzero(p["fext"][:, 1]) == round(length / (0.5 / 3))


def test_body_force_is_mass_times_acceleration():
    s = scene_with(Disk((5.0, 2.0), 1.5), loads=[BodyForce((0.0, -9.81e-9)), BodyForce((1.0, 0.0), "b")])
    p = s.particles()
    m = p["mass"].sum()
    assert p["fext"].sum(axis=0) == pytest.approx([m * 1.0, -m * 9.81e-9], rel=1e-12)


def test_two_bodies_indices_and_velocity():
    d = base()
    d["materials"].append({"name": "steel", "E": 2e5, "nu": 0.3, "density": 7800.0})
    d["bodies"].append({"name": "ball", "material": "steel", "velocity": [1.0, -2.0],
                        "shape": {"type": "disk", "center": [5.0, 2.0], "radius": 1.0}})
    d["bodies"][0]["holes"] = [{"type": "disk", "center": [5.0, 2.0], "radius": 1.0}]
    p = Scene.from_dict(d).particles()
    ball = p["body"] == 1
    assert ball.any() and np.all(np.diff(p["body"]) >= 0)
    assert np.all(p["material"][ball] == 1) and np.all(p["material"][~ball] == 0)
    assert np.all(p["v"][ball] == [1.0, -2.0]) and np.all(p["v"][~ball] == 0)


# -- time step ------------------------------------------------------------------


def test_stable_dt_borden():
    c = wave_speed(32000.0, 0.2, 2450.0, "strain")
    assert c == pytest.approx(math.sqrt(32000 * 0.8 / (2450 * 1.2 * 0.6)))
    assert c == pytest.approx(3.8095, abs=1e-4)
    # Body clear of the grid sides, as the paper's plate: the grid's CFL limit
    # h / c, which is the largest fixed dt (the paper's 0.02625 us), and
    # below it a lone particle's, 0.577 h / c, the default step.
    s = scene_with(Rectangle((1.0, 1.0), (9.0, 3.0)), h=0.125)
    assert s.stable_dt() == pytest.approx(0.8 * 0.577 * 0.125 / c, rel=1e-12)
    assert stability.grid_dt(s) == pytest.approx(0.02625, abs=1e-5)
    assert s.dt() == s.stable_dt()
    paper = dataclasses.replace(s, time=dataclasses.replace(s.time, dt=stability.grid_dt(s)))
    assert paper.dt() == pytest.approx(0.02625, abs=1e-5)
    with pytest.raises(SceneError, match="^time.dt = .*: exceeds the stability limit"):
        dataclasses.replace(s, time=dataclasses.replace(s.time, dt=1.001 * stability.grid_dt(s)))
    # A body on the grid sides meets the open knot vector's end functions.
    touching = Scene.from_dict(base(), ["grid.h=0.125"])
    assert touching.stable_dt() == pytest.approx(min(CRITICAL_FACTOR[2][1], 0.577) * 0.8 * 0.125 / c,
                                                 rel=1e-12)
    assert Scene.from_dict(base(), ["time.dt=0.02"]).dt() == 0.02
    stress = wave_speed(32000.0, 0.2, 2450.0, "stress")
    assert stress == pytest.approx(math.sqrt(32000 / (2450 * 0.96)))


def test_stable_dt_includes_body_speed():
    s = Scene.from_dict(base(), ["bodies.plate.velocity=[3.0, 4.0]", "time.cfl=0.5"])
    kappa = min(CRITICAL_FACTOR[2][1], LONE_PARTICLE_FACTOR[2])
    assert s.stable_dt() == pytest.approx(kappa * 0.5 * 0.5 / (wave_speed(32000.0, 0.2, 2450.0, "strain") + 5.0))


def test_velocity_gradient_sets_the_initial_velocity_and_the_step():
    s = Scene.from_dict(base(), ["bodies.plate.velocity=[1.0, 0.0]",
                                 "bodies.plate.velocity_gradient=[[0.0, 0.5], [0.25, 0.0]]"])
    p = s.particles()
    np.testing.assert_allclose(p["v"][:, 0], 1.0 + 0.5 * p["x"][:, 1], rtol=0, atol=1e-15)
    np.testing.assert_allclose(p["v"][:, 1], 0.25 * p["x"][:, 0], rtol=0, atol=1e-15)
    # The fastest point is the corner (10, 4): v = (3, 2.5).
    c = wave_speed(32000.0, 0.2, 2450.0, "strain")
    kappa = min(CRITICAL_FACTOR[2][1], LONE_PARTICLE_FACTOR[2])
    assert s.stable_dt() == pytest.approx(kappa * 0.8 * 0.5 / (c + math.hypot(3.0, 2.5)))


def test_orientation_is_stored_per_particle_in_radians():
    s = Scene.from_dict(base(), ["bodies.plate.orientation=30"])
    assert np.all(s.particles()["phi"] == math.radians(30.0))


def test_summary():
    s = Scene.from_dict(base(), ["time.dt=0.01"])
    assert s.summary() == {"name": "plate", "plane": "strain", "cells": (20, 8), "h": 0.5,
                           "degree": 2, "particles": 640, "dt": 0.01, "steps": 100}


# -- overrides, dict and TOML -----------------------------------------------------


def test_overrides():
    d = base()
    s = Scene.from_dict(d, ["time.end=5", "bodies.plate.velocity=[1,0]",
                            "materials.glass.E=1e4", "grid.h=0.25", "plane=stress",
                            "bodies.0.particles_per_cell=3", "output.every=7"])
    assert s.time.end == 5.0
    assert s.bodies[0].velocity == (1.0, 0.0)
    assert s.materials[0].E == 1e4
    assert s.grid.h == 0.25 and s.grid.cells == (40, 16)
    assert s.plane == "stress" and s.bodies[0].particles_per_cell == 3 and s.output.every == 7
    assert d == base()  # input untouched
    assert apply_overrides({}, ["a.b.c=x y"]) == {"a": {"b": {"c": "x y"}}}


@pytest.mark.parametrize("override, message", [
    ("time.end", "--set = 'time.end': expected"),
    ("bodies.steel.velocity=[1,0]", "bodies.steel: no entry with that name (have: 'plate')"),
    ("bodies.3.velocity=[1,0]", "bodies.3: index out of range"),
    ("name.x=1", "name = 'plate': is not a table"),
])
def test_bad_overrides(override, message):
    with pytest.raises(SceneError) as err:
        apply_overrides(base(), [override])
    assert message in str(err.value)


def test_round_trip(tmp_path):
    d = base()
    d["loads"] = [{"type": "traction", "body": "plate", "edge": "top", "traction": [0.0, 1.0]},
                  {"type": "body_force", "acceleration": [0.0, -1.0]}]
    d["bodies"][0]["holes"] = [{"type": "ring", "center": [5, 2], "inner_radius": 0.5, "outer_radius": 1},
                               {"type": "polygon", "vertices": [[1, 1], [2, 1], [1, 2]]}]
    d["time"]["dt"] = 0.01
    s = Scene.from_dict(d)
    again = Scene.from_dict(s.to_dict())
    assert again == s and again.to_dict() == s.to_dict()
    assert "body" not in s.to_dict()["loads"][1]
    toml = tmp_path / "s.toml"
    toml.write_text(
        'name = "plate"\nplane = "stress"\n[grid]\nsize = [10, 4]\nh = 0.5\n[time]\nend = 1\n'
        '[[materials]]\nname = "glass"\nE = 32000\nnu = 0.2\ndensity = 2450\n'
        '[[bodies]]\nname = "plate"\nmaterial = "glass"\n'
        'shape = { type = "rectangle", min = [0, 0], max = [10, 4] }\n')
    t = Scene.from_toml(toml, ["time.end=2"])
    assert t.plane == "stress" and t.time.end == 2.0 and len(t.particles()["x"]) == 640
    toml.write_text("[grid\n")
    with pytest.raises(SceneError, match="invalid TOML"):
        Scene.from_toml(toml)


def test_direct_construction_validates():
    with pytest.raises(SceneError, match=r"^E = -5: must be > 0$"):
        Material("glass", -5, 0.2, 1.0)
    with pytest.raises(SceneError, match=r"^bodies\[0\]\.material = 'steel': no material"):
        Scene(Grid((10, 4), 0.5), Time(1.0), [Material(**GLASS)],
              [Body("b", "steel", Rectangle((0, 0), (10, 4)))])
    with pytest.raises(SceneError, match=r"^materials\[0\] = \{"):
        Scene(Grid((10, 4), 0.5), Time(1.0), [dict(GLASS)], [Body("b", "glass", Disk((5, 2), 1))])
    assert Output().every == 100 and Wall("top", "slip").type == "slip"


# -- the table of bad inputs ------------------------------------------------------


def _set(path, value):
    """Mutation setting the nested key ``path`` (a tuple) to ``value``."""
    def mutate(d):
        node = d
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value
    return mutate


def _delete(path):
    """Mutation deleting the nested key ``path``."""
    def mutate(d):
        node = d
        for key in path[:-1]:
            node = node[key]
        del node[path[-1]]
    return mutate


TRACTION = {"type": "traction", "body": "plate", "edge": "top", "traction": [0.0, 1.0]}
SHAPE = ("bodies", 0, "shape")

BAD = [
    # unknown keys at every level
    ("foo=1", "foo: unknown key (allowed: grid, time"),
    ("grid.hx=0.25", "grid.hx: unknown key (allowed: size, h, origin, degree, shape, scale_failed,"
                     " failed_c)"),
    ("time.stop=1", "time.stop: unknown key"),
    ("output.evry=3", "output.evry: unknown key"),
    ("materials.glass.youngs=3", "materials[0].youngs: unknown key"),
    ("bodies.plate.colour=red", "bodies[0].colour: unknown key"),
    ("bodies.plate.shape.radius=3", "bodies[0].shape.radius: unknown key (allowed: type, min, max)"),
    (_set(("loads",), [dict(TRACTION, acceleration=[0, 1])]), "loads[0].acceleration: unknown key"),
    (_set(("loads",), [{"type": "body_force", "acceleration": [0, 1], "edge": "top"}]),
     "loads[0].edge: unknown key (allowed: type, acceleration, body, amplitude)"),
    ("walls.0.normal=1", "walls[0].normal: unknown key"),
    # missing required keys
    (_delete(("grid", "h")), "grid.h: missing required key"),
    (_delete(("time",)), "time: missing required key"),
    (_delete(("materials", 0, "E")), "materials[0].E: missing required key"),
    (_delete(SHAPE + ("type",)), "bodies[0].shape.type: missing required key"),
    (_set(("loads",), [{"body": "plate"}]), "loads[0].type: missing required key"),
    # wrong types and lengths
    ("materials.glass.E='big'", "materials[0].E = 'big': must be a number"),
    ("grid.h=true", "grid.h = true: must be a number"),
    ("thickness=[1]", "thickness = [1]: must be a number"),
    ("bodies.plate.particles_per_cell=true", "bodies[0].particles_per_cell = true: must be an integer"),
    ("output.every=10.5", "output.every = 10.5: must be an integer"),
    ("output.particles=1", "output.particles = 1: must be true or false"),
    ("grid.size=[10]", "grid.size = [10]: must be a list of 2 or 3 numbers (one per direction)"),
    ("bodies.plate.velocity=[1,2,3]", "bodies[0].velocity = [1.0, 2.0, 3.0]: has 3 components, but the scene is"
                                      " 2D (grid.size has 2 entries)"),
    ("bodies.plate.material=3", "bodies[0].material = 3: must be a string"),
    ("grid=3", "grid = 3: must be a table"),
    ("materials.0=4", "materials[0] = 4: must be a table"),
    (_set(("materials",), dict(GLASS)), "materials = {"),
    ("bodies.plate.holes=3", "bodies[0].holes = 3: must be an array of tables"),
    # non-finite numbers
    ("materials.glass.density=nan", "materials[0].density = nan: must be finite"),
    ("bodies.plate.velocity=[inf,0]", "bodies[0].velocity[0] = inf: must be finite"),
    ("grid.origin=[0,-inf]", "grid.origin[1] = -inf: must be finite"),
    # out of range
    ("materials.glass.E=-5.0", "materials[0].E = -5.0: must be > 0"),
    ("materials.glass.nu=0.5", "materials[0].nu = 0.5: must be > -1 and < 0.5"),
    ("materials.glass.nu=-1", "materials[0].nu = -1: must be > -1 and < 0.5"),
    ("time.cfl=1.5", "time.cfl = 1.5: must be > 0 and <= 1"),
    ("time.cfl=0", "time.cfl = 0: must be > 0 and <= 1"),
    ("time.end=-1", "time.end = -1: must be > 0"),
    ("time.dt=0", "time.dt = 0: must be > 0"),
    ("thickness=0", "thickness = 0: must be > 0"),
    ("grid.size=[-10,4]", "grid.size[0] = -10: must be > 0"),
    ("grid.size=[10.1,4]", "grid.size = [10.1, 4.0]: not a whole number of cells of h = 0.5"),
    ("grid.size=[0.25,4]", "grid.size = [0.25, 4.0]: smaller than one cell of h = 0.5"),
    ("bodies.plate.particles_per_cell=0", "bodies[0].particles_per_cell = 0: must be >= 1"),
    ("output.energies_every=0", "output.energies_every = 0: must be >= 1"),
    ("name=''", "name = '': must not be empty"),
    (_set(SHAPE, {"type": "rectangle", "min": [5, 0], "max": [5, 4]}),
     "bodies[0].shape.max = [5.0, 4.0]: must exceed min = [5.0, 0.0] componentwise"),
    (_set(SHAPE, {"type": "disk", "center": [5, 2], "radius": 0}), "bodies[0].shape.radius = 0: must be > 0"),
    (_set(SHAPE, {"type": "ring", "center": [5, 2], "inner_radius": 1, "outer_radius": 1}),
     "bodies[0].shape.outer_radius = 1: must be > 1"),
    (_set(SHAPE, {"type": "ring", "center": [5, 2], "inner_radius": -1, "outer_radius": 1}),
     "bodies[0].shape.inner_radius = -1: must be >= 0"),
    (_set(SHAPE, {"type": "polygon", "vertices": [[0, 0], [1, 1]]}),
     "bodies[0].shape.vertices = [[0, 0], [1, 1]]: must have at least 3 points"),
    (_set(SHAPE, {"type": "polygon", "vertices": [[0, 0], [1, 1], [2, 2]]}),
     "bodies[0].shape.vertices = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]: polygon is degenerate"),
    (_set(SHAPE, {"type": "polygon", "vertices": [[0, 0], [1, 1], 3]}),
     "bodies[0].shape.vertices[2] = 3: must be a list of 2 numbers"),
    # unknown enum values
    ("plane=plane", "plane = 'plane': must be one of 'strain', 'stress'"),
    ("grid.degree=4", "grid.degree = 4: must be one of 1, 2, 3"),
    ("bodies.plate.shape.type=square", "bodies[0].shape.type = 'square': must be one of 'rectangle'"),
    (_set(("loads",), [dict(TRACTION, type="pressure")]), "loads[0].type = 'pressure': must be one of"),
    (_set(("loads",), [dict(TRACTION, edge="middle")]), "loads[0].edge = 'middle': must be one of"),
    ("walls.0.side=front", "walls[0].side = 'front': a side of a 3D grid (z min or max); a 2D grid has left, right, bottom, top"),
    ("walls.0.side=aft", "walls[0].side = 'aft': must be one of"),
    ("walls.0.type=sticky", "walls[0].type = 'sticky': must be one of 'fixed', 'slip'"),
    ("materials.glass.model=plastic", "materials[0].model = 'plastic': must be one of 'linear_elastic'"),
    # duplicates and dangling references
    (lambda d: d["materials"].append(dict(GLASS, E=1.0)),
     "materials[1].name = 'glass': duplicate name (also materials[0])"),
    (lambda d: d["bodies"].append(copy.deepcopy(d["bodies"][0])),
     "bodies[1].name = 'plate': duplicate name (also bodies[0])"),
    (lambda d: d["walls"].append({"side": "left", "type": "slip"}),
     "walls[1].side = 'left': duplicate wall on this side (also walls[0])"),
    ("bodies.plate.material=steel", "bodies[0].material = 'steel': no material with that name (have: 'glass')"),
    (_set(("loads",), [dict(TRACTION, body="ghost")]), "loads[0].body = 'ghost': no body with that name"),
    (_set(("loads",), [{"type": "body_force", "body": "ghost", "acceleration": [0, 1]}]),
     "loads[0].body = 'ghost': no body with that name (have: 'plate')"),
    ("bodies=[]", "bodies: at least one entry is required"),
    (_set(("loads",), [{"type": "body_force", "acceleration": [0, 1e308]}]),
     "loads[0].acceleration = [0.0, 1e+308]: gives the particles of body 'plate' a force that is not finite"),
    # particles
    (_set(SHAPE, {"type": "disk", "center": [0.5, 0.5], "radius": 0.01}), "bodies[0]: has no particles"),
    (_set(("bodies", 0, "holes"), [{"type": "rectangle", "min": [-1, -1], "max": [11, 5]}]),
     "bodies[0]: has no particles"),
    ("bodies.plate.shape.max=[10.4,4]", "bodies[0]: 32 particles lie outside the grid [0, 10] x [0, 4]"),
    ("bodies.plate.shape.min=[-0.2,-0.2]", "bodies[0]: 57 particles lie outside the grid [0, 10] x [0, 4]"),
    ("bodies.plate.shape.max=[20,4]", "bodies[0].shape: bounds [0.0, 0.0, 20.0, 4.0] extend more than"),
    ("bodies.plate.particles_per_cell=5000", "bodies[0]: would need"),
    # time step
    ("time.dt=1.0", "time.dt = 1.0: exceeds the stability limit 0.06"),
    # fracture
    ("materials.glass.fracture={Gc=-1.0,l0=1.0}", "materials[0].fracture.Gc = -1.0: must be > 0"),
    ("materials.glass.fracture={Gc=1.0}", "materials[0].fracture.l0: missing required key"),
    ("materials.glass.fracture={Gc=1.0,l0=1.0,k_f=1.0}", "materials[0].fracture.k_f = 1.0: must be >= 0 and < 1"),
    ("materials.glass.fracture={Gc=1.0,l0=1.0,split='miehe'}",
     "materials[0].fracture.split = 'miehe': must be one of 'spectral'"),
    ("materials.glass.fracture={Gc=1.0,l0=1.0,gamma=2}", "materials[0].fracture.gamma: unknown key"),
    ("materials.glass.fracture={Gc=1.0,l0=0.2}",
     "materials[0].fracture.l0 = 0.2: smaller than the grid spacing h = 0.5"),
    ("cracks=[{points=[[0,2],[5,2]]}]", "cracks[0]: no body's material has a fracture table"),
    (_set(("cracks",), [{"points": [[0, 2]]}]), "cracks[0].points"),
    (_set(("cracks",), [{"points": [[0, 2], [5, 2]], "body": "ghost"}]),
     "cracks[0].body = 'ghost': no body with that name"),
    ("bodies.plate.velocity_gradient=[[0.0, 1.0]]",
     "bodies[0].velocity_gradient = [[0.0, 1.0]]: must have 2 or 3 rows of as many numbers (one per"
     " direction)"),
    ("bodies.plate.velocity_gradient=[[0.0, 1.0], [1.0]]", "bodies[0].velocity_gradient[1]"),
    ("bodies.plate.velocity_gradient=[[0.0, 1e308], [0.0, 0.0]]",
     "bodies[0].velocity_gradient = [[0.0, 1e+308], [0.0, 0.0]]: gives a speed that is not finite"),
    ("bodies.plate.orientation=nan", "bodies[0].orientation = nan: must be finite"),
    ("phase_field.tol=0", "phase_field.tol = 0: must be > 0"),
    ("phase_field.max_iterations=0", "phase_field.max_iterations = 0: must be >= 1"),
    ("phase_field.preconditioner=gauss", "phase_field.preconditioner = 'gauss': must be one of "
                                         "'automatic', 'jacobi', 'ssor', 'multigrid'"),
    ("phase_field.preconditioner=1", "phase_field.preconditioner = 1: must be one of"),
    ("output.crack_threshold=1.5", "output.crack_threshold = 1.5: must be > 0 and < 1"),
    ("output.snapshots=[-1.0]", "output.snapshots[0] = -1.0: must be >= 0"),
]


@pytest.mark.parametrize("mutation, message", BAD, ids=[m for _, m in BAD])
def test_bad_input(mutation, message):
    d = base()
    if callable(mutation):
        mutation(d)
        overrides = []
    else:
        overrides = [mutation]
    with pytest.raises(SceneError) as err:
        Scene.from_dict(d, overrides)
    text = str(err.value)
    assert message in text and "\n" not in text
    assert isinstance(err.value, ValueError)


def test_bad_table_is_long_enough():
    assert len(BAD) >= 30


# -- fuzzing ----------------------------------------------------------------------

KEYS = ["name", "grid", "time", "size", "h", "origin", "degree", "end", "dt", "cfl", "E", "nu",
        "density", "model", "material", "shape", "holes", "type", "center", "radius", "min",
        "max", "vertices", "velocity", "particles_per_cell", "loads", "walls", "side", "edge"]
SCALARS = (st.none() | st.booleans() | st.integers(-3, 1000) | st.floats()
           | st.text(max_size=6) | st.sampled_from(["glass", "plate", "disk", "top", "strain"]))
VALUES = st.recursive(SCALARS, lambda inner: st.lists(inner, max_size=4)
                      | st.dictionaries(st.sampled_from(KEYS) | st.text(max_size=4), inner, max_size=3),
                      max_leaves=8)


def _paths(node, prefix=()):
    """All key paths into nested dicts and lists."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, value in items:
        yield prefix + (key,)
        yield from _paths(value, prefix + (key,))


def _rich():
    """A valid scene dict using every table, shape kind and load kind."""
    d = base()
    d["output"] = {"every": 5, "energies_every": 2, "particles": True}
    d["time"]["dt"] = 0.01
    d["bodies"][0]["holes"] = [{"type": "disk", "center": [5, 2], "radius": 1},
                               {"type": "polygon", "vertices": [[1, 1], [2, 1], [1, 2]]}]
    d["bodies"].append({"name": "ring", "material": "glass", "particles_per_cell": 1,
                        "shape": {"type": "ring", "center": [5, 2], "inner_radius": 0.2, "outer_radius": 0.8}})
    d["loads"] = [copy.deepcopy(TRACTION), {"type": "body_force", "body": "ring", "acceleration": [0, -1]}]
    d["materials"][0]["fracture"] = {"Gc": 0.003, "l0": 1.0, "anisotropy": {
        "symmetry": "orthotropic", "g1111": 1.0, "g2222": 80.0, "g1212": 74.0}}
    d["bodies"][0]["orientation"] = 30.0
    d["bodies"][1]["velocity_gradient"] = [[0.0, 0.01], [0.0, 0.0]]
    return d


@settings(max_examples=200, deadline=None)
@given(st.data())
def test_fuzzed_scene_dicts_raise_only_scene_error(data):
    d = _rich()
    for _ in range(data.draw(st.integers(1, 3))):
        path = data.draw(st.sampled_from(list(_paths(d))))
        parent = d
        for key in path[:-1]:
            parent = parent[key]
        action = data.draw(st.sampled_from(["delete", "insert", "replace"]))
        if action == "delete":
            del parent[path[-1]]
        elif action == "insert" and isinstance(parent, dict):
            parent[data.draw(st.sampled_from(KEYS) | st.text(max_size=4))] = data.draw(VALUES)
        elif action == "insert":
            parent.insert(path[-1], data.draw(VALUES))
        else:
            parent[path[-1]] = data.draw(VALUES)
        if not list(_paths(d)):
            break
    try:
        scene = Scene.from_dict(d)
    except SceneError as err:
        assert "\n" not in str(err)
    else:
        assert isinstance(scene, Scene)
        assert Scene.from_dict(scene.to_dict()) == scene


BORDEN = scenes.path("borden_plate")


@pytest.mark.parametrize("override, reported", [
    # E in Pa in an mm-us-MPa scene: 1000 times the wave speed.
    ("materials.concrete.E=32e9", "materials[0]: P-wave speed 3.81e+03 mm/µs = 3.81e+06 m/s is no solid's"),
    # The density in kg/mm^3 (2.45e-6): 31,600 times the wave speed.
    ("materials.concrete.density=2.45e-6", "materials[0]: P-wave speed 1.2e+05 mm/µs"),
    # In t/mm^3, as in an mm-s-MPa scene: too fast again.
    ("materials.concrete.density=2.45e-9", "materials[0]: P-wave speed 3.81e+06 mm/µs"),
])
def test_a_material_in_the_wrong_units_is_refused(override, reported):
    """Issue 21, defect 7: E in Pa started 1.5 million steps without a word, a
    wrong density failed 989 steps later as a particle off the grid."""
    with pytest.raises(SceneError) as err:
        Scene.from_toml(BORDEN, [override])
    assert str(err.value).startswith(reported)
    assert "check its moduli (MPa) and density (µg/mm^3) against units = 'mm-us-MPa'" in str(err.value)


def test_too_many_steps_are_refused_without_declared_units():
    """Without declared units E in Pa is caught by the step count, unless
    ``time.max_steps`` is raised for a run that really is that long."""
    with pytest.raises(SceneError) as err:
        Scene.from_toml(BORDEN, ["units=''", "materials.concrete.E=32e9"])
    message = str(err.value)
    assert message.startswith("time.end = 80.0: needs 2.64e+06 steps of dt = 3.029e-05, more than"
                              " time.max_steps = 1000000")
    assert "crosses the grid 2.99e+03 times" in message and "raise time.max_steps" in message
    scene = Scene.from_toml(BORDEN, ["units=''", "materials.concrete.E=32e9", "time.max_steps=3000000"])
    assert scene.steps() == 2640918


def test_too_few_steps_are_refused():
    """A modulus so small (here subnormal) that one stable step outlasts the
    run is refused by the step count too; it used to run its one step to
    t = 5e154 and stop on a velocity that was not finite."""
    with pytest.raises(SceneError) as err:
        Scene.from_toml(BORDEN, ["units=''", "materials.concrete.E=4.345847379899e-311"])
    message = str(err.value)
    assert message.startswith("time.end = 80.0: needs ") and ", less than one: the P-wave speed" in message
    steps = float(message.split("needs ")[1].split(" steps")[0])
    assert 0 < steps < 1e-150  # the wave speed scales as sqrt(E): 1e-155 of the concrete's
    assert message.endswith("check the units of E and density")


def test_units_must_be_known():
    with pytest.raises(SceneError, match=r"^units = 'mm-ms': must be one of '', 'm-s-Pa', "):
        Scene.from_toml(BORDEN, ["units='mm-ms'"])
    assert Scene.from_toml(BORDEN).unit_system().time == "µs"


def test_snapshots_without_a_phase_field_are_refused():
    """Issue 21, defect 10: they were ignored without a word."""
    d = base()
    d["output"] = {"snapshots": [0.5]}
    with pytest.raises(SceneError) as err:
        Scene.from_dict(d)
    assert str(err.value) == ("output.snapshots = [0.5]: draws the phase field, but no body's material"
                              " has a fracture table")
    d["materials"][0]["fracture"] = {"Gc": 0.003, "l0": 0.5}
    assert Scene.from_dict(d).output.snapshots == (0.5,)
