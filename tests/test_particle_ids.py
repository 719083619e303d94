"""Particle ids: a function of where a particle was seeded, the same when the
lattice is seeded a box at a time, unique across bodies, ascending in the
arrays (which the core checks), written to the output; and the Python state
kept by id: rows found from ids, seeded positions read back from them, the
particles of body regions, initial damage and loads."""

import itertools

import numpy as np
import pytest

from pfmpm import Scene, Simulation
from pfmpm.scene import Body, Box, Disk, Grid, Material, Rectangle, Ring, Sphere, Time, seeding

GLASS = {"name": "glass", "E": 32000.0, "nu": 0.2, "density": 2450.0}


def plane_scene():
    """Three bodies whose bounding boxes overlap, one with a hole, on a grid
    away from the origin, 2 and 3 particles per cell."""
    return Scene(
        grid=Grid(size=(12.0, 8.0), h=0.5, origin=(-1.0, 2.0)),
        time=Time(end=1.0),
        materials=[Material(**GLASS)],
        bodies=[Body("plate", "glass", Rectangle((0.0, 3.0), (7.0, 6.25)), holes=(Disk((3.0, 4.5), 1.0),),
                     particles_per_cell=3),
                Body("ring", "glass", Ring((8.0, 6.0), 1.0, 2.1)),
                Body("disk", "glass", Disk((5.0, 8.0), 1.3), particles_per_cell=3)],
    )


def solid_scene():
    """A box and a sphere in 3D, 2 particles per cell and direction."""
    return Scene(
        grid=Grid(size=(6.0, 5.0, 4.0), h=0.5),
        time=Time(end=1.0),
        materials=[Material(**GLASS)],
        bodies=[Body("box", "glass", Box((0.5, 0.5, 0.5), (3.0, 2.25, 2.0))),
                Body("ball", "glass", Sphere((4.0, 3.0, 2.0), 1.4))],
    )


def boxes(ranges, splits):
    """The boxes of cells that cut ``ranges`` at ``splits`` (per direction, the
    cuts inside it), widened by one cell beyond the ranges on the outer sides."""
    edges = [[a - 1, *cuts, b + 1] for (a, b), cuts in zip(ranges, splits)]
    return list(itertools.product(*[list(zip(e[:-1], e[1:])) for e in edges]))


@pytest.mark.parametrize("make, splits", [
    (plane_scene, [(3, 4, 9), (2, 5)]),
    (solid_scene, [(2, 5), (3,), (1, 6)]),
], ids=["2D", "3D"])
def test_box_seeding_gives_the_whole_seeding_ids(make, splits):
    """Each body seeded a box at a time, the boxes cutting its lattice in every
    direction: together, sorted by id, the same positions and ids, bit for bit,
    as the whole body."""
    scene = make()
    xs, ids = seeding.seed(scene)
    for b, (body, base) in enumerate(zip(scene.bodies, seeding.id_bases(scene))):
        whole = seeding.cell_range(body, scene.grid)
        parts = [batch for box in boxes(whole, [tuple(whole[d][0] + c for c in cut) for d, cut in enumerate(splits)])
                 for batch in seeding.seed_body(body, scene.grid, base, box)]
        x = np.concatenate([p[0] for p in parts])
        i = np.concatenate([p[1] for p in parts])
        order = np.argsort(i, kind="stable")
        assert len(parts) > 4
        np.testing.assert_array_equal(i[order], ids[b])
        np.testing.assert_array_equal(x[order], xs[b])


def test_a_box_needs_a_range_per_direction():
    scene = plane_scene()
    with pytest.raises(ValueError, match=r"^box = \(\(0, 4\),\): must be 2 \(first, end\) cell ranges"):
        next(seeding.seed_body(scene.bodies[0], scene.grid, 0, ((0, 4),)))


def test_ids_are_the_lattice_positions():
    """A particle's id is its body's base plus its place in the body's
    bounding lattice: cell (the last direction fastest) times n^dim plus its
    sub-position (x fastest), read back from its position."""
    scene = plane_scene()
    g = scene.grid
    xs, ids = seeding.seed(scene)
    for body, base, x, i in zip(scene.bodies, seeding.id_bases(scene), xs, ids):
        n = body.particles_per_cell
        (i0, i1), (j0, j1) = seeding.cell_range(body, g)
        sub = np.rint((x - g.origin) / g.h * n - 0.5).astype(np.int64)  # sub-cell centre indices
        cell, a = np.divmod(sub, n)
        number = ((cell[:, 0] - i0) * (j1 - j0) + (cell[:, 1] - j0)) * n * n + a[:, 1] * n + a[:, 0]
        np.testing.assert_array_equal(i, base + number)
        assert i.dtype == np.int64


def test_ids_are_unique_and_ascend_across_bodies():
    for scene in (plane_scene(), solid_scene()):
        _, ids = seeding.seed(scene)
        sizes = [seeding.lattice_size(b, scene.grid) for b in scene.bodies]
        bases = seeding.id_bases(scene)
        assert bases == [sum(sizes[:k]) for k in range(len(sizes))]
        for base, size, i in zip(bases, sizes, ids):
            assert base <= i.min() and i.max() < base + size
        every = np.concatenate(ids)
        assert np.all(np.diff(every) > 0)
    # A hole and the ring leave lattice positions out: the ids are sparse.
    scene = plane_scene()
    assert seeding.count(scene) < sum(seeding.lattice_size(b, scene.grid) for b in scene.bodies)


def test_simulation_holds_the_seeding_ids_and_the_core_checks_their_order():
    scene = plane_scene()
    sim = Simulation(scene)
    np.testing.assert_array_equal(sim.particles.id, np.concatenate(seeding.seed(scene)[1]))
    np.testing.assert_array_equal(sim.particles.id, scene.particles()["id"])
    column = next(c for c in sim.particles.columns() if c["name"] == "id")
    assert (column["dtype"], column["output"]) == ("int64", "id")
    ids = sim.particles.id
    ids[[7, 8]] = ids[[8, 7]]
    with pytest.raises(ValueError, match=rf"^particle 8: id {ids[8]} after id {ids[7]} \(the particles must"
                                         r" be in ascending id order\)$"):
        sim.solver.restore(sim.solver.state())


# -- Python state kept by id (docs/particle-ids.md, "Python state by id") ----

def test_rows_of_follows_the_ids_in_any_subset_and_order():
    """The rows of ids in local arrays that hold an id-sorted subset of the
    particles, the ids asked for in any order: each row holds its id; a run
    of consecutive rows in order is a slice; an id not held is named."""
    rng = np.random.default_rng(3)
    every = np.concatenate(seeding.seed(plane_scene())[1])  # sparse: ids != rows
    local = np.sort(rng.choice(every, size=len(every) // 3, replace=False))
    wanted = rng.permutation(local)[:40]
    rows = seeding.rows_of(local, wanted)
    np.testing.assert_array_equal(local[rows], wanted)
    assert seeding.rows_of(local, local[10:25]) == slice(10, 25)
    assert seeding.rows_of(local, local[:0]) == slice(0, 0)
    gone = np.setdiff1d(every, local)[5]
    with pytest.raises(ValueError, match=rf"^particle id {gone}: no particle here has it$"):
        seeding.rows_of(local, np.append(wanted, gone))
    with pytest.raises(ValueError, match=rf"^particle id {every[-1] + 1}: no particle here has it$"):
        seeding.rows_of(local, [every[-1] + 1])


@pytest.mark.parametrize("make", [plane_scene, solid_scene], ids=["2D", "3D"])
def test_seeded_positions_read_the_ids_back(make):
    """The positions at t = 0 from the ids alone, bit for bit the seeding's,
    for the ids in any order; an id past the lattices or at a lattice
    position that the shape leaves out is named."""
    scene = make()
    xs, ids = seeding.seed(scene)
    every, x = np.concatenate(ids), np.concatenate(xs)
    np.testing.assert_array_equal(seeding.seeded_positions(scene, every), x)
    order = np.random.default_rng(4).permutation(len(every))[:100]
    np.testing.assert_array_equal(seeding.seeded_positions(scene, every[order]), x[order])
    end = sum(seeding.lattice_size(b, scene.grid) for b in scene.bodies)
    with pytest.raises(ValueError, match=rf"^particle id {end}: outside the lattices of the scene's bodies"
                                         rf" \(ids 0 to {end - 1}\)$"):
        seeding.seeded_positions(scene, [every[0], end])
    left_out = np.setdiff1d(np.arange(ids[0][0], ids[0][-1]), ids[0])[0]  # a hole's or outside the shape
    with pytest.raises(ValueError, match=rf"^particle id {left_out}: a lattice position that body"
                                         rf" '{scene.bodies[0].name}' leaves out"):
        seeding.seeded_positions(scene, [left_out])


def test_the_displacement_is_from_the_seeded_position_of_each_id():
    sim = Simulation(plane_scene())
    x0 = np.concatenate(seeding.seed(sim.scene)[0])
    sim.particles.x[:] += np.linspace(0.0, 0.1, len(x0))[:, None]
    np.testing.assert_array_equal(sim.displacement(), sim.particles.x - x0)


def two_bodies(**tables) -> Scene:
    """A plate with a hole and a disk, of a material with damage, on a grid
    away from the origin: the disk's ids start at the plate's lattice size,
    and both bodies' ids are sparse, so no row is its id and no index into a
    body is its id less the body's base."""
    rock = {"name": "rock", "model": "neo_hookean", "E": 100.0, "nu": 0.3, "density": 2.0,
            "damage": {"model": "rankine", "sigma_f": 1.0, "Gf": 0.01}}
    return Scene.from_dict({
        "grid": {"size": [12.0, 8.0], "h": 0.5, "origin": [-1.0, 2.0]},
        "time": {"end": 1.0},
        "materials": [rock],
        "bodies": [{"name": "plate", "material": "rock", "particles_per_cell": 3,
                    "shape": {"type": "rectangle", "min": [0.0, 3.0], "max": [5.0, 6.25]},
                    "holes": [{"type": "disk", "center": [2.5, 4.5], "radius": 1.0}]},
                   {"name": "disk", "material": "rock",
                    "shape": {"type": "disk", "center": [8.5, 6.0], "radius": 1.3}}],
        **tables})


def test_particle_lists_and_faces_pick_their_particles_by_index_in_the_body():
    """A prescribed region's and an initial damage's ``particles``, indices
    into a body's particles in seeding order, are the rows of the ids at
    those places of the body's seeding; a face is the rows of its edge
    layer's ids."""
    scene = two_bodies(
        prescribed=[{"name": "pins", "body": "disk", "particles": [30, 0, 7], "velocity": [0.0, 0.0]},
                    {"name": "lid", "body": "disk", "face": "top", "velocity": [0.0, 0.0]},
                    {"name": "corner", "body": "plate", "particles": [4], "velocity": [0.0, 0.0]}],
        initial_damage=[{"body": "disk", "particles": [2, 7, 40], "D": 0.5},
                        {"body": "plate", "particles": [1], "D": 0.25}])
    sim = Simulation(scene)
    xs, ids = seeding.seed(scene)
    first = len(xs[0])  # the disk's first row
    base = seeding.id_bases(scene)[1]
    p = sim.particles
    assert not np.array_equal(ids[1][[0, 7, 30]], base + np.array([0, 7, 30]))
    assert np.flatnonzero(p.held_by & 1).tolist() == [first, first + 7, first + 30]
    assert np.flatnonzero(p.held_by & 4).tolist() == [4]
    top = xs[1][:, 1] >= xs[1][:, 1].max() - 0.51 * scene.bodies[1].spacing(scene.grid.h)
    np.testing.assert_array_equal(p.id[np.flatnonzero(p.held_by & 2)], ids[1][top])
    assert np.flatnonzero(p.damage == 0.5).tolist() == [first + 2, first + 7, first + 40]
    assert np.flatnonzero(p.damage == 0.25).tolist() == [1]
    assert np.count_nonzero(p.damage) == 4


def test_loads_with_an_amplitude_find_their_particles_by_id_each_step():
    """A ramped traction on the second body's top, a ramped body force on
    all bodies and a steady traction on the first body's right edge: after a
    step, the external force of each particle is what its loads give it at
    the step's midpoint."""
    ramp = {"type": "ramp", "time": 1.0}
    scene = two_bodies(loads=[
        {"type": "traction", "body": "disk", "edge": "top", "traction": [0.0, -3.0], "amplitude": ramp},
        {"type": "body_force", "acceleration": [0.0, -10.0], "amplitude": ramp},
        {"type": "traction", "body": "plate", "edge": "right", "traction": [2.0, 0.0]}])
    sim = Simulation(scene)
    xs, _ = seeding.seed(scene)
    sim.advance(1)
    a = scene.loads[0].amplitude(0.5 * sim.dt)
    spacing = [body.spacing(scene.grid.h) for body in scene.bodies]
    mass = [2.0 * s * s for s in spacing]  # density x (h/n)^2, thickness 1
    top = np.zeros(len(sim.particles), dtype=bool)
    top[len(xs[0]):] = xs[1][:, 1] >= xs[1][:, 1].max() - 0.51 * spacing[1]
    right = np.zeros(len(sim.particles), dtype=bool)
    right[:len(xs[0])] = xs[0][:, 0] >= xs[0][:, 0].max() - 0.51 * spacing[0]
    body = sim.particles.body
    expected = np.zeros((len(sim.particles), 2))
    expected[right, 0] = 2.0 * spacing[0]
    expected[top, 1] += a * -3.0 * spacing[1]
    expected[:, 1] += a * -10.0 * np.take(mass, body)
    np.testing.assert_allclose(sim.particles.fext, expected, rtol=1e-14, atol=0.0)
