"""Particle ids: a function of where a particle was seeded, the same when the
lattice is seeded a box at a time, unique across bodies, ascending in the
arrays (which the core checks), written to the output."""

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
