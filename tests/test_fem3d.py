"""Fracture in 3D on the FEM side (issue 51): initial cracks as planar
patches, the PF-FEM on tetrahedra, the 1D crack profile through a 3D plate,
the crack front and the crack area.

The MPM phase field in 3D is the core's (a later change); what here is
shared with it (the patch distance, ``initial_history`` on (N, 3) points,
the crack front and area of (N, 3) particle data) is tested on its own.
"""

import math

import numpy as np
import pytest

from pfmpm import SceneError, _core
from pfmpm.crack import distance_to_crack, initial_history
from pfmpm.fem import FemSimulation
from pfmpm.scene import (Body, BodyForce, Box, Crack, Disk, Extrusion, Fracture, Grid, Material, Output,
                         PhaseField, Rectangle, Scene, Sphere, Time, Traction, Wall)
from pfmpm.scene.shapes import distance_to_polygon

from test_fem import exact_1d

# -- the patch of a 3D initial crack --------------------------------------------


def test_distance_to_a_planar_patch():
    """Distances to a 2 x 1 rectangle in z = 0 and to the same patch turned
    about two axes, against the values worked out by hand."""
    square = [(0.0, 0.0, 0.0), (2.0, 0.0, 0.0), (2.0, 1.0, 0.0), (0.0, 1.0, 0.0)]
    points = np.array([
        [1.0, 0.5, 0.3],    # above the inside: the height
        [1.0, 0.5, -0.7],   # below it
        [0.5, 0.5, 0.0],    # on it
        [3.0, 0.5, 0.0],    # beyond side x = 2, in the plane
        [3.0, 0.5, 2.0],    # beyond that side, off the plane: sqrt(1 + 4)
        [3.0, 2.0, -1.0],   # beyond the corner (2, 1, 0): sqrt(1 + 1 + 1)
        [1.0, -0.5, 0.5],   # beyond side y = 0: sqrt(0.25 + 0.25)
    ])
    expected = [0.3, 0.7, 0.0, 1.0, math.sqrt(5.0), math.sqrt(3.0), math.sqrt(0.5)]
    np.testing.assert_allclose(distance_to_polygon(points, square), expected, rtol=0, atol=1e-15)
    # The corners in the other order (the normal turned over) give the same.
    np.testing.assert_allclose(distance_to_polygon(points, square[::-1]), expected, rtol=0, atol=1e-15)
    # Turned and moved: distances are invariant.
    a, b = 0.7, -0.4
    rz = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    rx = np.array([[1, 0, 0], [0, math.cos(b), -math.sin(b)], [0, math.sin(b), math.cos(b)]])
    turn, shift = rx @ rz, np.array([0.3, -2.0, 5.0])
    moved = [tuple(turn @ p + shift) for p in np.array(square)]
    np.testing.assert_allclose(distance_to_polygon(points @ turn.T + shift, Crack(points=moved).points),
                               expected, rtol=0, atol=1e-14)


def test_initial_history_on_a_patch_is_borden_s():
    """``initial_history`` on (N, 3) points and a patch: ``B G_c / (4 l0) (1 - d / w)``
    within the half width, 0 beyond; (N, 2) points for a patch are refused."""
    fracture = Fracture(Gc=0.003, l0=0.5)
    crack = Crack(points=((0.0, 0.0, 0.0), (0.0, 2.0, 0.0), (0.0, 2.0, 1.0)), B=100.0)  # a triangle in x = 0
    x = np.array([[0.1, 1.0, 0.25], [-0.2, 1.9, 0.5], [0.0, 1.0, 0.9], [0.1, 0.0, -0.1]])
    # Above the inside, below it, beyond the side z = y / 2 (in the plane:
    # |y - 2 z| / sqrt(5)), beyond the corner (0, 0, 0).
    d = np.array([0.1, 0.2, abs(1.0 - 2 * 0.9) / math.sqrt(5.0), math.sqrt(0.02)])
    np.testing.assert_allclose(distance_to_crack(x, crack), d, rtol=1e-14)
    w = 0.25  # l0 / 2
    expected = np.where(d <= w, 100.0 * 0.003 / (4 * 0.5) * (1 - d / w), 0.0)
    np.testing.assert_allclose(initial_history(x, crack, fracture), expected, rtol=1e-14)
    assert np.all(expected[[0, 1, 3]] > 0) and expected[2] == 0
    with pytest.raises(ValueError, match=r"points of shape \(4, 2\) for a 3D crack"):
        initial_history(x[:, :2], crack, fracture)
    line = Crack(points=((0.0, 0.0), (1.0, 0.0)))
    with pytest.raises(ValueError, match=r"points of shape \(4, 3\) for a 2D crack"):
        initial_history(x, line, fracture)


def solid_tables() -> dict:
    """A small valid 3D scene with a crackable box, as tables."""
    return {"name": "slab", "grid": {"size": [6.0, 6.0, 6.0], "h": 1.0}, "time": {"end": 1.0},
            "output": {"crack_direction": [1.0, 0.0, 0.0]},
            "materials": [{"name": "m", "E": 100.0, "nu": 0.3, "density": 1.0,
                           "fracture": {"Gc": 1.0, "l0": 2.0}}],
            "bodies": [{"name": "b", "material": "m",
                        "shape": {"type": "box", "min": [1.0, 1.0, 1.0], "max": [5.0, 5.0, 5.0]}}]}


PATCH = "cracks=[{points = [[1.0, 3.0, 0.0], [3.0, 3.0, 0.0], [3.0, 3.0, 6.0], [1.0, 3.0, 6.0]]}]"
BAD_CRACKS = [
    (["cracks=[{points = [[2.0, 3.0], [3.0, 3.0]]}]"],
     "cracks[0].points = [[2.0, 3.0], [3.0, 3.0]]: 2D points in a 3D scene (grid.size has 3 entries):"
     " give a convex planar polygon of three or more [x, y, z] points"),
    (["cracks=[{points = [[1.0, 3.0, 0.0], [3.0, 3.0, 0.0]]}]"],
     "cracks[0].points = [[1.0, 3.0, 0.0], [3.0, 3.0, 0.0]]: a planar patch needs at least three"
     " [x, y, z] points"),
    (["cracks=[{points = [[1.0, 3.0, 0.0], [3.0, 3.0, 0.0], [3.0, 3.5, 6.0], [1.0, 3.0, 6.0]]}]"],
     "cracks[0].points = [[1.0, 3.0, 0.0], [3.0, 3.0, 0.0], [3.0, 3.5, 6.0], [1.0, 3.0, 6.0]]:"
     " the points are not on one plane (up to 0.248 off it)"),
    (["cracks=[{points = [[1.0, 3.0, 0.0], [3.0, 3.0, 6.0], [3.0, 3.0, 0.0], [1.0, 3.0, 6.0]]}]"],
     "cracks[0].points = [[1.0, 3.0, 0.0], [3.0, 3.0, 6.0], [3.0, 3.0, 0.0], [1.0, 3.0, 6.0]]:"
     " the points enclose no area (they lie on one line, or its sides cross)"),
    (["cracks=[{points = [[1.0, 3.0, 0.0], [3.0, 3.0, 0.0], [2.0, 3.0, 1.0], [3.0, 3.0, 6.0],"
      " [1.0, 3.0, 6.0]]}]"],
     "cracks[0].points = [[1.0, 3.0, 0.0], [3.0, 3.0, 0.0], [2....1.0], [3.0, 3.0, 6.0], [1.0, 3.0, 6.0]]:"
     " the polygon is not convex (give its corners in order around it, none on a straight side)"),
    ([PATCH, "output.crack_direction=[1.0, 0.0]"],
     "output.crack_direction = [1.0, 0.0]: has 2 components, but the scene is 3D (grid.size has 3 entries)"),
    ([PATCH, "output.crack_direction=[0.0, 0.0, 0.0]"],
     "output.crack_direction = [0.0, 0.0, 0.0]: must not be zero"),
]


@pytest.mark.parametrize("sets, message", BAD_CRACKS, ids=range(len(BAD_CRACKS)))
def test_bad_3d_cracks_are_one_line_errors(sets, message):
    with pytest.raises(SceneError) as err:
        Scene.from_dict(solid_tables(), overrides=sets)
    assert str(err.value) == message
    assert "\n" not in str(err.value)


def test_a_3d_crack_needs_the_front_s_direction_and_a_2d_scene_its_polyline():
    tables = solid_tables()
    del tables["output"]
    with pytest.raises(SceneError, match=r"^output.crack_direction: a 3D scene with initial cracks needs"
                                         r" the direction its crack front runs in"):
        Scene.from_dict(tables, overrides=[PATCH])
    assert Scene.from_dict(solid_tables(), overrides=[PATCH]).cracks[0].dim == 3
    flat = {"name": "plate", "grid": {"size": [6.0, 6.0], "h": 1.0}, "time": {"end": 1.0},
            "materials": [{"name": "m", "E": 100.0, "nu": 0.3, "density": 1.0, "fracture": {"Gc": 1.0, "l0": 2.0}}],
            "bodies": [{"name": "b", "material": "m", "shape": {"type": "rectangle", "min": [1, 1], "max": [5, 5]}}]}
    with pytest.raises(SceneError) as err:
        Scene.from_dict(flat, overrides=["cracks=[{points = [[1.0, 3.0, 0.0], [3.0, 3.0, 0.0], [3.0, 3.0, 6.0]]}]"])
    assert str(err.value) == ("cracks[0].points = [[1.0, 3.0, 0.0], [3.0, 3.0, 0.0], [3.0, 3.0, 6.0]]: 3D points"
                              " in a 2D scene (grid.size has 2 entries): give a polyline of [x, y] points")
    # In 2D the direction is optional (the last segment's), and 2D.
    assert Scene.from_dict(flat).output.crack_direction is None
    with pytest.raises(SceneError, match=r"^output.crack_direction = \[1.0, 0.0, 0.0\]: has 3 components"):
        Scene.from_dict(flat, overrides=["output.crack_direction=[1.0, 0.0, 0.0]"])


# -- the splits on 3 x 3 strains ---------------------------------------------------


@pytest.mark.parametrize("split", ["none", "spectral", "volumetric_deviatoric"])
def test_3d_splits_are_the_core_s_in_plane_strain(split):
    """With eps_zz = eps_yz = eps_xz = 0 the split of a 3D strain (N, 6) is the
    plane-strain split of its (N, 3): stresses (xx, yy, xy, zz) and psi+- to
    1e-13 of their scale, over strains of every sign and degradations in [0, 1]."""
    E, nu = 210.0, 0.3
    core = _core.LinearElastic(E, nu, 1.0, _core.Plane.strain, _core.Split.__members__[split])
    solid = core
    rng = np.random.default_rng(51)
    eps2 = rng.normal(size=(400, 3)) * 1e-3
    eps2[:50, 2] = 0.0  # principal axes along x and y
    eps2[50:60] = [1e-3, 1e-3, 0.0]  # equal principal strains
    g = rng.uniform(0.0, 1.0, len(eps2))
    eps3 = np.zeros((len(eps2), 6))
    eps3[:, :3] = eps2
    scale = E * 1e-3
    np.testing.assert_allclose(solid.stresses(eps3, g)[:, :4], core.stresses(eps2, g), rtol=0, atol=1e-13 * scale)
    assert np.all(solid.stresses(eps3, g)[:, 4:] == 0.0)
    for mine, theirs in zip(solid.split_energies(eps3), core.split_energies(eps2)):
        np.testing.assert_allclose(mine, theirs, rtol=0, atol=1e-13 * scale * 1e-3)


def test_3d_split_stress_is_the_derivative_of_the_energy():
    """sigma = d(g psi+ + psi-)/d eps for general 3D strains (central differences,
    the shear columns counted twice as eps : sigma does)."""
    rng = np.random.default_rng(5)
    eps = rng.normal(size=(20, 6)) * 1e-3
    g = rng.uniform(0.0, 1.0, len(eps))
    weight = np.array([1.0, 1.0, 2.0, 1.0, 2.0, 2.0])
    for split in ("none", "spectral", "volumetric_deviatoric"):
        solid = _core.LinearElastic(200.0, 0.3, 1.0, _core.Plane.strain, _core.Split.__members__[split])
        sig = solid.stresses(eps, g)

        def energy(e):
            plus, minus = solid.split_energies(e)
            return g * plus + minus

        if split == "spectral":  # psi+ of the principal strains (Miehe et al. 2010)
            t = np.zeros((len(eps), 3, 3))
            for e, (i, j) in enumerate([(0, 0), (1, 1), (0, 1), (2, 2), (1, 2), (0, 2)]):
                t[:, i, j] = t[:, j, i] = eps[:, e]
            lam, mu = solid.lame
            tr, principal = np.trace(t, axis1=1, axis2=2), np.linalg.eigvalsh(t)
            expected = 0.5 * lam * np.maximum(tr, 0) ** 2 + mu * (np.maximum(principal, 0) ** 2).sum(axis=1)
            np.testing.assert_allclose(solid.split_energies(eps)[0], expected, rtol=1e-12)
            # The stress from the eigenvectors, on these strains and on rotated
            # ones with two equal principal strains of either sign.
            rot, _ = np.linalg.qr(rng.normal(size=(3, 3)))
            equal = np.stack([rot @ np.diag(v) @ rot.T for v in ([2e-3, 2e-3, -1e-3], [1e-3, -2e-3, -2e-3])])
            t = np.concatenate([t, equal])
            cols = np.stack([t[:, i, j] for i, j in [(0, 0), (1, 1), (0, 1), (2, 2), (1, 2), (0, 2)]], axis=1)
            gg = np.concatenate([g, [0.3, 0.7]])
            values, vectors = np.linalg.eigh(t)
            eps_plus = np.einsum("nik,nk,njk->nij", vectors, np.maximum(values, 0), vectors)
            tr = np.trace(t, axis1=1, axis2=2)
            sigma = (lam * (gg * np.maximum(tr, 0) + np.minimum(tr, 0)))[:, None, None] * np.eye(3) \
                + 2 * mu * (gg[:, None, None] * eps_plus + t - eps_plus)
            expected = np.stack([sigma[:, i, j] for i, j in [(0, 0), (1, 1), (0, 1), (2, 2), (1, 2), (0, 2)]], axis=1)
            np.testing.assert_allclose(solid.stresses(cols, gg), expected, rtol=0, atol=1e-12 * np.abs(expected).max())

        step = 1e-9
        for k in range(6):
            up, down = eps.copy(), eps.copy()
            up[:, k] += step
            down[:, k] -= step
            derivative = (energy(up) - energy(down)) / (2 * step)
            np.testing.assert_allclose(derivative, weight[k] * sig[:, k], rtol=0, atol=1e-6 * 0.3)


# -- the PF-FEM on tetrahedra ------------------------------------------------------


def block(shape=Box((0.0, 0.0, 0.0), (2.0, 1.0, 1.5)), h=0.25, **kwargs):
    """A one-body 3D scene with a cell of margin around the body."""
    material = kwargs.pop("material", Material(name="m", E=100.0, nu=0.25, density=7.0))
    return Scene(grid=Grid(size=(4.0, 3.0, 3.5), h=h, origin=(-1.0, -1.0, -1.0)), time=kwargs.pop("time", Time(end=1.0)),
                 materials=(material,), bodies=(Body(name="b", material=material.name, shape=shape),), **kwargs)


def test_tetrahedral_mesh_mass_and_loads_add_up():
    """Six tetrahedra per cube; the lumped mass sums to rho V; a traction on
    the front face and gravity give momentum (t A + M g) t exactly."""
    rho, h = 7.0, 0.25
    traction, gravity = (0.3, -0.7, 0.2), (0.0, -9.81, 1.0)
    sim = FemSimulation(block(loads=(Traction(body="b", edge="front", traction=traction), BodyForce(gravity))))
    summary = sim.summary()
    assert summary["cells"] == 6 * 8 * 4 * 6 and summary["vertices"] == 9 * 5 * 7
    volume = 2.0 * 1.0 * 1.5
    assert sim.lumped_mass.sum() == pytest.approx(rho * volume, rel=1e-13)
    assert sim._area.sum() == pytest.approx(volume, rel=1e-13)
    force = np.array(traction) * 2.0 * 1.0 + rho * volume * np.array(gravity)
    sim.advance(10)
    e = sim.energies()
    for k, d in enumerate("xyz"):
        assert e[f"momentum_{d}"] == pytest.approx(force[k] * sim.time, rel=1e-10)
    assert sim.columns()[:13] == ["step", "t", "kinetic", "elastic", "fracture", "external_work", "total",
                                  "momentum_x", "momentum_y", "momentum_z", "angular_momentum_x",
                                  "angular_momentum_y", "angular_momentum_z"]


def test_homogeneous_strain_gives_its_stress_and_no_interior_force():
    """The patch test: u = A x with a symmetric A gives the strain A in every
    tetrahedron, the stress lambda tr(A) I + 2 mu A, and zero internal force at
    interior vertices (the rows of the P1 gradients sum to zero)."""
    sim = FemSimulation(block())
    A = np.array([[1.0, 0.3, -0.2], [0.3, -0.5, 0.4], [-0.2, 0.4, 0.7]]) * 1e-3
    sim.displacement[:] = sim.vertices @ A.T
    sim._eps = sim._strain()
    np.testing.assert_allclose(sim._eps, np.tile([A[0, 0], A[1, 1], A[0, 1], A[2, 2], A[1, 2], A[0, 2]],
                                                 (len(sim._eps), 1)), rtol=0, atol=1e-17)
    lam, mu = 100.0 * 0.25 / (1.25 * 0.5), 100.0 / 2.5
    sigma = lam * np.trace(A) * np.eye(3) + 2 * mu * A
    np.testing.assert_allclose(sim.stresses(), np.tile([sigma[0, 0], sigma[1, 1], sigma[0, 1], sigma[2, 2],
                                                        sigma[1, 2], sigma[0, 2]], (len(sim._eps), 1)),
                               rtol=0, atol=1e-14)
    x = sim.vertices[: sim.owned]
    interior = np.all((x > 1e-9) & (x < np.array([2.0, 1.0, 1.5]) - 1e-9), axis=1)
    assert interior.sum() == 7 * 3 * 5
    f = sim._internal_force()
    assert np.abs(f[interior]).max() < 1e-15 * np.abs(f).max() * 1e3
    # The vertices on the face x = 2 together carry sigma n A there (the sum of
    # their basis functions is linear across the last layer of cells).
    right = np.abs(x[:, 0] - 2.0) < 1e-9
    np.testing.assert_allclose(f[right].sum(axis=0), sigma[:, 0] * 1.0 * 1.5, rtol=1e-12)


def test_walls_hold_their_components_in_3d():
    """A fixed back wall holds every component of the vertices on z = z0
    (the body's face there); a slip wall on the left holds x alone."""
    scene = block(shape=Box((-1.0, 0.0, -1.0), (2.0, 1.0, 1.5)), loads=(BodyForce((1.0, -2.0, -3.0)),),
                  walls=(Wall(side="back", type="fixed"), Wall(side="left", type="slip")))
    sim = FemSimulation(scene)
    sim.advance(5)
    x, v = sim.vertices[: sim.owned], sim.velocity
    back, left = np.abs(x[:, 2] + 1.0) < 1e-9, np.abs(x[:, 0] + 1.0) < 1e-9
    assert np.all(v[back] == 0.0)
    assert np.all(v[left & ~back, 0] == 0.0) and np.all(v[left & ~back, 1:] != 0.0)
    e = sim.energies()
    assert e["impulse_back_z"] > 0 and e["impulse_left_x"] < 0  # they push back against gravity's z and x


def test_extruded_rectangle_is_a_box_and_other_3d_shapes_are_refused():
    box = FemSimulation(block())
    extruded = FemSimulation(block(shape=Extrusion(Rectangle((0.0, 0.0), (2.0, 1.0)), 0.0, 1.5)))
    np.testing.assert_array_equal(box.vertices, extruded.vertices)
    for shape, kind in ((Sphere((0.5, 0.5, 0.5), 0.5), "'sphere'"),
                        (Extrusion(Disk((0.5, 0.5), 0.5), 0.0, 1.0), "'extrusion of a disk'")):
        with pytest.raises(SceneError) as err:
            FemSimulation(block(shape=shape))
        assert str(err.value) == (f"bodies[0].shape = {kind}: the FEM path in 3D needs a box or an"
                                  " extruded rectangle")


# -- the 1D profile through a 3D plate -----------------------------------------------


def slab_1d(l0, h, model, half_width=None):
    """``test_fem.strip_1d`` in 3D: the plate |x| <= 6 l0, two cells high and
    two deep, cut across by the patch x = 0 (a square larger than the
    plate's cross-section), B = 1e4 l0 / w.  The band is h/4 wide unless
    given: the centroids of the faces off the plane x = 0 lie h/3 from it
    (2D: the edge midpoints h/2), so a band narrower than h/3 holds only the
    face centroids on the plane."""
    w = 0.25 * h if half_width is None else half_width
    half, side = 6 * l0, 2 * h
    material = Material(name="m", E=1.0, nu=0.0, density=1.0, fracture=Fracture(Gc=0.003, l0=l0, model=model))
    return Scene(
        grid=Grid(size=(2 * half + 2 * h, side + 2 * h, side + 2 * h), h=h, origin=(-half - h, -h, -h)),
        time=Time(end=1.0), materials=(material,),
        bodies=(Body(name="slab", material="m", shape=Box((-half, 0.0, 0.0), (half, side, side))),),
        cracks=(Crack(points=((0.0, -1.0, -1.0), (0.0, side + 1.0, -1.0), (0.0, side + 1.0, side + 1.0),
                              (0.0, -1.0, side + 1.0)), B=1e4 * l0 / w, half_width=w),),
        output=Output(crack_direction=(0.0, 1.0, 0.0)),
        phase_field=PhaseField(tol=1e-10, max_iterations=5000),
    )


@pytest.mark.parametrize("model", ["AT2", "AT1"])
@pytest.mark.parametrize("division", [4, 8])
def test_3d_crack_profile_within_a_quarter_cell_of_the_exact_one(model, division):
    """The 1D profile across a planar crack through a plate of tetrahedra at
    l0 / h = 4 and 8, within 0.25 h / l0 of the exact one in the max norm over
    the vertices: the bound of the 2D test
    (test_fem.test_crack_profile_within_a_quarter_cell_of_the_exact_one).

    Measured max error / (h / l0), 3D against 2D: AT2 l0/h = 4: 0.0035 (2D
    0.0048); AT2 8: 0.0048 (0.0060); AT1 4: 0.0018 (0.0031); AT1 8: 0.0036
    (0.0043).  The crack area ``int Z dV`` over the cross-section: 0.9945,
    0.9940, 0.9998, 0.9994 (2D: 0.9944, 0.9940, 0.9997, 0.9994).  With the
    2D band (h/2) the face centroids h/3 off the plane get a third of the
    history there and hold the next vertices near 0: 0.46-0.48 h / l0, 1.8-1.9
    times the bound (tests below).
    """
    l0 = 0.5
    h = l0 / division
    sim = FemSimulation(slab_1d(l0, h, model))
    x = sim.vertices[: sim.owned, 0]
    c = sim.c.x.array[: sim.owned]
    error = np.max(np.abs(c - exact_1d(x, l0, model, 6 * l0)))
    assert error <= 0.25 * h / l0, error
    beside = np.abs(np.abs(x) - h) < 1e-9
    assert np.max(np.abs(c[beside] - exact_1d(x[beside], l0, model, 6 * l0))) < 0.025 * h / l0
    # The crack area: per unit cross-section tanh(L / 2 l0) (AT2), 1 (AT1), within 1 %.
    exact_area = (math.tanh(6 * l0 / (2 * l0)) if model == "AT2" else 1.0) * (2 * h) ** 2
    assert sim.crack_area() == pytest.approx(exact_area, rel=0.01)
    assert sim.energies()["fracture"] == pytest.approx(0.003 * sim.crack_area(), rel=1e-14)
    assert c.min() >= 0.0 and c.max() <= 1.0


def test_a_band_wider_than_a_third_of_a_cell_widens_the_3d_crack():
    """The band of the 2D test (h/2) on tetrahedra reaches the face centroids
    h/3 off the crack plane: the vertices at x = +-h go near 0 too (measured
    0.46 h / l0 off the exact profile, AT2, l0 / h = 4)."""
    l0, h = 0.5, 0.125
    sim = FemSimulation(slab_1d(l0, h, "AT2", half_width=0.5 * h))
    x = sim.vertices[: sim.owned, 0]
    error = np.max(np.abs(sim.c.x.array[: sim.owned] - exact_1d(x, l0, "AT2", 6 * l0)))
    assert 0.4 * h / l0 < error < 0.5 * h / l0


def test_3d_band_that_misses_the_mesh_is_refused():
    """A band that holds no face centroid would leave the crack out: a one-line error."""
    l0, h = 0.5, 0.125
    scene = slab_1d(l0, h, "AT2", half_width=0.05 * h)
    moved = tuple((0.5 * h, y, z) for _, y, z in scene.cracks[0].points)  # between vertex planes
    scene = Scene(**{**{f: getattr(scene, f) for f in ("grid", "time", "materials", "bodies", "output",
                                                         "phase_field")},
                     "cracks": (Crack(points=moved, B=1e3, half_width=0.05 * h),)})
    with pytest.raises(SceneError) as err:
        FemSimulation(scene)
    assert str(err.value) == ("cracks[0].half_width = 0.00625: the crack's band holds no face centroid"
                              " of the FEM mesh (h = 0.125), so it would not be imposed: widen it or"
                              " move the crack onto the body")


def test_face_centroid_rule_integrates_a_cellwise_reaction_s_row_sums():
    """On tetrahedra the reaction matrix of a cell-wise F has the exact row
    sums ``(F, N_I)`` (the rule is exact for degree 1) and, per cell, the
    entries V F / 12 on the diagonal and V F / 18 off it (exact: V F / 10,
    V F / 20)."""
    from dolfinx import fem
    from dolfinx.fem import petsc as fem_petsc
    import ufl

    material = Material(name="m", E=100.0, nu=0.25, density=7.0, fracture=Fracture(Gc=0.01, l0=0.5))
    sim = FemSimulation(block(material=material))
    cells = len(sim.history)
    rng = np.random.default_rng(3)
    sim.history[:] = rng.uniform(0.0, 1.0, cells)[:, None]
    sim._solve_phase_field()
    W = fem.FunctionSpace(sim.mesh, ("DG", 0))
    F = fem.Function(W)
    F.x.array[W.dofmap.list.array[:cells]] = 4 * 0.5 * sim.history[:, 0] / 0.01 + 1.0
    q = ufl.TestFunction(sim.V)
    exact = fem_petsc.assemble_vector(fem.form(F * q * ufl.dx))
    ones = sim._pf._M.createVecRight()
    ones.set(1.0)
    rows = sim._pf._M.createVecLeft()
    sim._pf._M.mult(ones, rows)
    np.testing.assert_allclose(rows.array, exact.array, rtol=1e-13)
    # The reaction's dof k of a cell sits at the centroid of the face opposite vertex k.
    dofs = sim._pf._reaction.function_space.tabulate_dof_coordinates()
    np.testing.assert_allclose(dofs[sim._pf._point_dof], sim._midpoints, rtol=0, atol=1e-12)


# -- the crack front and the crack area --------------------------------------------


def lattice(spacing, lo, hi):
    """Particles at the centres of the cubes of side ``spacing`` in a box."""
    axes = [np.arange(a + 0.5 * spacing, b, spacing) for a, b in zip(lo, hi)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


def test_crack_front_of_particle_data_is_its_farthest_cracked_extent():
    """On (N, 3) particle data: a crack whose front curves through the
    thickness, x <= 2 + z / 2, along e = (1, 0, 0) and along a slanted
    direction; merged over any split into parts it is the same."""
    from pfmpm.observe import CrackFront

    x = lattice(0.1, (0.0, 0.0, 0.0), (4.0, 1.0, 1.0))
    c = np.where((x[:, 0] <= 2.0 + 0.5 * x[:, 2]) & (np.abs(x[:, 1] - 0.55) < 0.01), 0.0, 1.0)
    front = CrackFront((2.0, 0.0, 0.0), threshold=0.2, samples=3, start=-1.0)
    found = front.farthest(x, c)
    # The farthest cracked particle: x = 2.45 at z = 0.95 (2 + 0.475 = 2.475).
    np.testing.assert_allclose(found, (2.45, 2.45, 0.55, 0.95), rtol=0, atol=1e-12)
    slant = CrackFront((1.0, 0.0, -1.0), threshold=0.2, samples=3)
    extent, *point = slant.farthest(x, c)
    cracked = x[c < 0.2]
    assert extent == pytest.approx(np.max(cracked @ np.array([1.0, 0.0, -1.0]) / math.sqrt(2.0)), rel=1e-14)
    rng = np.random.default_rng(1)
    parts = np.array_split(rng.permutation(len(x)), 5)
    assert CrackFront.merge([front.farthest(x[p], c[p]) for p in parts]) == found
    assert front.farthest(x, np.ones(len(x))) is None
    # Records: the front's speed is the slope of its extent over the last 3.
    for t, shift in ((0.0, 0.0), (1.0, 0.3), (2.0, 0.6), (3.0, 1.5)):
        row = front.record(t, front.farthest(x + [shift, 0.0, 0.0], c), area=0.25)
    assert row["crack_front"] == pytest.approx(2.45 + 1.5)
    assert row["crack_front_speed"] == pytest.approx(np.polyfit([1.0, 2.0, 3.0], [0.3, 0.6, 1.5], 1)[0])
    assert row["crack_area"] == 0.25
    assert front.record(4.0, None, 0.0)["crack_front"] == -1.0  # nothing cracked: its start


@pytest.mark.parametrize("model", ["AT2", "AT1"])
def test_crack_area_of_particle_data_is_the_cross_section(model):
    """(N, 3) particles of two materials (G_c 0.003 and 0.007) across the
    exact 1D profile of a planar crack x = 0, |x| <= L = 6 l0, through a
    1 x 0.8 cross-section, each with the fracture energy of the core's
    column, ``G_c V Z(c, grad c)``: their crack area is the cross-section
    times tanh(L / 2 l0) (AT2) or 1 (AT1), to the midpoint rule's error on
    the profile (measured 2e-4 at l0 / spacing = 10)."""
    from pfmpm.post.tip import crack_area

    l0, spacing = 0.5, 0.05
    x = lattice(spacing, (-3.0, 0.0, 0.0), (3.0, 1.0, 0.8))
    r = np.abs(x[:, 0])
    if model == "AT2":
        a = 6 * l0 / (2 * l0)
        d = np.cosh(a - r / (2 * l0)) / np.cosh(a)
        slope = np.sinh(a - r / (2 * l0)) / np.cosh(a) / (2 * l0)
        Z = d * d / (4 * l0) + l0 * slope ** 2
        exact = math.tanh(a)
    else:
        d = np.where(r <= 4 * l0, (1 - r / (4 * l0)) ** 2, 0.0)
        slope = np.where(r <= 4 * l0, 2 * (1 - r / (4 * l0)) / (4 * l0), 0.0)
        Z = 3 * d / (16 * l0) + 0.75 * l0 * slope ** 2
        exact = 1.0
    gc = np.where(x[:, 1] < 0.5, 0.003, 0.007)
    energy = gc * spacing ** 3 * Z
    assert crack_area(energy, gc) == pytest.approx(exact * 1.0 * 0.8, rel=1e-3)
    assert crack_area(energy[gc == 0.003], 0.003) == pytest.approx(exact * 0.5 * 0.8, rel=1e-3)


def test_3d_fem_run_writes_the_crack_front_and_area(tmp_path):
    """A run of a cracked 3D plate: ``energies.csv`` has the crack-front
    columns, the front is the crack's edge as the phase field makes it
    (within a cell of the patch's edge, x = 0.5), the area is the fracture
    energy over G_c; the XDMF series holds the 3 x 3 stress."""
    from pfmpm.output import read_csv

    l0, h = 0.5, 0.25
    material = Material(name="m", E=100.0, nu=0.2, density=1.0, fracture=Fracture(Gc=0.01, l0=l0))
    scene = Scene(grid=Grid(size=(3.0, 2.5, 1.5), h=h, origin=(-0.5, -0.5, -0.5)), time=Time(end=0.2),
                  materials=(material,), output=Output(every=2, energies_every=1, crack_direction=(1.0, 0.0, 0.0)),
                  bodies=(Body(name="b", material="m", shape=Box((0.0, 0.0, 0.0), (2.0, 1.5, 0.5))),),
                  cracks=(Crack(points=((-0.5, 0.75, -0.5), (0.5, 0.75, -0.5), (0.5, 0.75, 1.0),
                                        (-0.5, 0.75, 1.0)), B=1e3),))
    sim = FemSimulation(scene)
    result = sim.run(tmp_path, progress=False)
    assert result.status == "completed"
    e = read_csv(tmp_path / "energies.csv")
    for column in ("crack_front", "crack_front_x", "crack_front_y", "crack_front_z", "crack_front_speed",
                   "crack_area", "momentum_z", "angular_momentum_z"):
        assert column in e
    assert 0.5 - h <= e["crack_front"][0] <= 0.5 + h
    np.testing.assert_allclose(e["crack_area"], e["fracture"] / 0.01, rtol=1e-12)
    assert e["crack_area"][-1] == pytest.approx(sim.crack_area(), rel=1e-12)
    assert (tmp_path / "fields.xdmf").exists()
    import xml.etree.ElementTree as ElementTree
    names = {g.get("Name") for g in ElementTree.parse(tmp_path / "fields.xdmf").getroot().iter("Grid")}
    assert {"c", "displacement", "stress", "history"} <= names and "stress_zz" not in names


def test_2d_crack_tip_looks_along_the_scene_s_direction():
    """In 2D ``output.crack_direction`` is optional: unset, the tip looks
    along the first crack's last segment, as before; set, along it."""
    from pfmpm.observe import CrackTip

    flat = {"name": "plate", "grid": {"size": [6.0, 6.0], "h": 1.0}, "time": {"end": 1.0},
            "materials": [{"name": "m", "E": 100.0, "nu": 0.3, "density": 1.0, "fracture": {"Gc": 1.0, "l0": 2.0}}],
            "bodies": [{"name": "b", "material": "m", "shape": {"type": "rectangle", "min": [0, 0], "max": [6, 6]}}],
            "cracks": [{"points": [[0.0, 3.0], [2.0, 3.0]]}]}
    tip = CrackTip.for_scene(Scene.from_dict(flat))
    np.testing.assert_array_equal(tip.direction, [1.0, 0.0])
    tip = CrackTip.for_scene(Scene.from_dict(flat, overrides=["output.crack_direction=[0.0, 2.0]"]))
    np.testing.assert_array_equal(tip.direction, [0.0, 1.0])
    np.testing.assert_array_equal(tip.origin, [2.0, 3.0])


def test_two_ranks_reproduce_one_in_3d(tmp_path):
    """``mpirun -n 2 python -m pfmpm.fem`` on a cracked 3D plate pulled apart
    (tests/data/fem3d_cracked_slab.toml: 576 tetrahedra, the crack runs
    through the plate in 1.5 time units) gives the serial energies and crack
    area to 1e-8 of their largest value (measured 1e-12 and 5e-15), and the
    same crack front."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    from pfmpm.output import read_csv
    from test_fem import _mpirun

    env = dict(os.environ, OMP_NUM_THREADS="1")
    if os.geteuid() == 0:
        env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    scene = Path(__file__).parent / "data" / "fem3d_cracked_slab.toml"
    runs = {}
    for name, launcher in (("serial", [sys.executable]), ("mpi", _mpirun() + [sys.executable])):
        out = tmp_path / name
        proc = subprocess.run(launcher + ["-m", "pfmpm.fem", str(scene), "--quiet", "--out", str(out)],
                              env=env, capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr[-2000:]
        runs[name] = read_csv(out / "energies.csv")
    serial, mpi = runs["serial"], runs["mpi"]
    for column in ("kinetic", "elastic", "fracture", "external_work", "crack_area"):
        scale = np.abs(serial[column]).max()
        assert np.abs(serial[column] - mpi[column]).max() <= 1e-8 * scale, column
    np.testing.assert_array_equal(serial["crack_front"], mpi["crack_front"])
    assert serial["crack_front"][-1] == 2.0  # through the plate
