"""Multi-body frictional contact: each body its own discrete field (eqs. 63-77).

Two elastic disks colliding head-on and obliquely conserve momentum to round-off,
never interpenetrate and separate with their energy; a block sliding on a heavy
body stops after v0^2 / (2 mu g) and keeps its speed without friction, with the
friction dissipation closing the energy balance; the checks C.1-C.4 hold at every
contact node; a scene whose bodies never meet runs bit for bit as one field;
bad contact input is refused with the key and value named; and the disk-beam
crack-rise measure (benchmarks.disk_beam.measure) counts cracked cells from the beam's bottom face.
"""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from benchmarks.disk_beam.measure import crack_rise
from pfmpm.output import read_csv
from pfmpm.scene import (Body, BodyForce, Contact, ContactPair, Disk, Grid, Material, Output,
                         Rectangle, Scene, SceneError, Time, Wall)
from pfmpm.simulation import Simulation


def disks(offset: float, h: float = 0.0625, speed: float = 0.3, mu: float = 0.0) -> Scene:
    """Two unit disks 0.25 apart moving towards each other; ``offset`` shifts the right one up."""
    m = Material("m", 100.0, 0.3, 1.0)
    a = Body("a", "m", Disk((3.0, 3.0), 1.0), particles_per_cell=2, velocity=(speed, 0.0))
    b = Body("b", "m", Disk((5.25, 3.0 + offset), 1.0), particles_per_cell=2, velocity=(-speed, 0.0))
    return Scene(grid=Grid(size=(8.0, 6.0), h=h, degree=2), time=Time(end=3.0, cfl=0.5),
                 materials=(m,), bodies=(a, b), plane="strain", contact=Contact(friction=mu))


def cpdi(scene: Scene) -> Scene:
    """The scene with CPDI1 on the degree-1 grid."""
    return dataclasses.replace(scene, grid=dataclasses.replace(scene.grid, degree=1, shape="cpdi"))


def min_distance(x: np.ndarray, body: np.ndarray) -> float:
    """Smallest distance between a particle of body 0 and one of body 1."""
    d, _ = cKDTree(x[body == 0]).query(x[body == 1])
    return float(d.min())


# Energy after separation over the initial (docs/contact.md, "Energy"):
# head-on 0.965 at h = R/16, oblique with friction 0.968 at h = R/25.
# With CPDI1 on the degree-1 grid, obliquely with friction at h = R/16: 0.959
# (docs/contact.md, "Linear grids: CPDI only").
@pytest.mark.parametrize("offset, mu, h, shape", [(0.0, 0.0, 0.0625, "bspline"), (0.8, 0.5, 0.04, "bspline"),
                                                  (0.8, 0.5, 0.0625, "cpdi")],
                         ids=["head-on", "oblique", "oblique-cpdi"])
def test_disks_collide_conserving_momentum_without_interpenetration(offset, mu, h, shape):
    scene = disks(offset, h=h, mu=mu)
    if shape == "cpdi":
        scene = cpdi(scene)
    sim = Simulation(scene)
    p = sim.particles
    spacing = scene.grid.h / 2
    scale = float(np.sum(p.mass * np.hypot(p.v[:, 0], p.v[:, 1])))
    start = sim.energies()
    chunks, closest = 30, np.inf
    for _ in range(chunks):
        sim.advance(scene.steps() // chunks)
        e = sim.energies()
        assert abs(e["momentum_x"] - start["momentum_x"]) <= 1e-10 * scale
        assert abs(e["momentum_y"] - start["momentum_y"]) <= 1e-10 * scale
        closest = min(closest, min_distance(p.x, p.body))
    # No particle of one disk ever between particles of the other.
    assert closest > 0.5 * spacing
    stats = sim.solver.contact_stats()
    assert stats["active"] > 100 and stats["nodes"] == 0  # they met, and parted
    assert [stats[c] for c in ("C1", "C2", "C3", "C4")] == [0, 0, 0, 0]
    # Apart again with their energy, less what friction took (the normal
    # contact loses a little too: docs/contact.md).
    e = sim.energies()
    assert e["total"] == pytest.approx(start["kinetic"], rel=0.05)
    assert (e["friction_dissipation"] > 1e-3 * start["kinetic"]) == (mu > 0)
    # The disks bounced: each moves away from the other along x.
    vx = [np.average(p.v[p.body == b, 0], weights=p.mass[p.body == b]) for b in (0, 1)]
    assert vx[0] < 0 < vx[1]


def test_normal_contact_loss_shrinks_with_h():
    """The frictionless head-on disks lose energy in contact, a perfectly
    inelastic collision of the nodal masses that no column books
    (docs/contact.md, "Energy"): 0.093 of it at R/h = 8 and 0.035 at R/h = 16
    (0.013 at 32, docs/verification/sphere-disk.md). A loss that did not
    shrink with h would be the contact law's, not the resolution's."""
    lost = []
    for h in (0.125, 0.0625):
        scene = disks(0.0, h=h, mu=0.0)
        sim = Simulation(scene)
        start = sim.energies()["kinetic"]
        sim.advance(scene.steps())
        e = sim.energies()
        assert e["friction_dissipation"] == 0.0
        lost.append(1.0 - e["total"] / start)
    print(f"lost at R/h = 8, 16: {lost[0]:.4f}, {lost[1]:.4f}")
    assert lost[0] == pytest.approx(0.093, abs=0.005) and lost[1] == pytest.approx(0.035, abs=0.003)
    assert lost[0] / lost[1] > 2.0


def test_bodies_a_gap_apart_do_not_touch():
    """Two blocks a cell apart share grid nodes (Remark 4) but do not touch:
    closing slowly, they exert no force on each other while the gap stays open
    (docs/contact.md, "Touching")."""
    h, speed = 0.25, 0.01
    m = Material("m", 100.0, 0.3, 1.0)
    a = Body("a", "m", Rectangle((1.0, 1.0), (3.0, 2.0)), velocity=(speed, 0.0))
    b = Body("b", "m", Rectangle((3.0 + h, 1.0), (5.0 + h, 2.0)), velocity=(-speed, 0.0))
    # The gap closes by 2 speed t = 0.004 h.
    scene = Scene(grid=Grid(size=(6.5, 3.0), h=h, degree=2), time=Time(end=0.05, cfl=0.5),
                  materials=(m,), bodies=(a, b), plane="strain", contact=Contact(friction=0.5))
    sim = Simulation(scene)
    p = sim.particles
    mine = p.body == 0
    start = float(np.sum(p.mass[mine] * p.v[mine, 0]))
    sim.advance(scene.steps())
    stats = sim.solver.contact_stats()
    assert stats["nodes"] > 0 and stats["pairs"] > 0  # they share nodes ...
    assert stats["active"] == 0  # ... but no force acts
    assert float(np.sum(p.mass[mine] * p.v[mine, 0])) == pytest.approx(start, rel=1e-12)
    assert np.allclose(p.v[mine, 0], speed, rtol=1e-10) and np.allclose(p.v[~mine, 0], -speed, rtol=1e-10)


def block(mu: float, end: float) -> Scene:
    """A 2 x 1 block at speed 1 on a 100x heavier and stiffer slab on a fixed wall, g = 0.25."""
    soft, hard = Material("block", 1000.0, 0.3, 1.0), Material("slab", 1e5, 0.3, 100.0)
    return Scene(grid=Grid(size=(12.0, 4.0), h=0.25, degree=2), time=Time(end=end, cfl=0.5),
                 materials=(soft, hard),
                 bodies=(Body("slab", "slab", Rectangle((0.0, 0.0), (12.0, 1.0))),
                         Body("block", "block", Rectangle((1.0, 1.0), (3.0, 2.0)), velocity=(1.0, 0.0))),
                 loads=(BodyForce((0.0, -0.25), body="block"),), walls=(Wall("bottom", "fixed"),),
                 contact=Contact(friction=0.0, pairs=(ContactPair(("slab", "block"), mu),)))


def test_sliding_block_stops_after_the_coulomb_distance(tmp_path):
    mu, g, v0 = 0.5, 0.25, 1.0
    sim = Simulation(block(mu, end=10.0))  # it stops at t = v0 / (mu g) = 8
    result = sim.run(tmp_path, progress=False)
    assert result.status == "completed"
    b = sim.particles.body == 1
    moved = sim.particles.x[b, 0].mean() - 2.0
    assert moved == pytest.approx(v0**2 / (2 * mu * g), rel=0.03)
    assert np.abs(sim.particles.v[b, 0]).max() < 0.01 * v0
    e = sim.energies()
    kinetic0 = 0.5 * 2.0 * v0**2
    # Friction took the kinetic energy, and the balance closes.
    assert e["friction_dissipation"] == pytest.approx(kinetic0, rel=0.02)
    assert e["total"] == pytest.approx(kinetic0, rel=0.01)
    summary = json.loads((tmp_path / "summary.json").read_text())
    contact = summary["contact"]
    assert "contact" in summary["modules"]
    assert contact["sliding_node_pairs"] > 0 and contact["active_node_pairs"] > 0
    assert contact["violations"] == {"C1": 0, "C2": 0, "C3": 0, "C4": 0}
    header = (tmp_path / "energies.csv").read_text().splitlines()[0].split(",")
    assert header[-5:] == ["friction_dissipation", "fracture_slab", "fracture_block",
                           "contact_slab_block_x", "contact_slab_block_y"]


def test_a_slab_on_a_wall_loses_what_a_mirrored_slab_loses(tmp_path):
    """Issue 21, defect 11: the block sliding on the slab, with gravity on both,
    ends with `total` 11 % below its start at g = 0.85. The wall's work is in
    the balance (a column of energies.csv), but it is a small part of that:
    the rest is the explicit scheme's damping of the slab's settling
    vibration, which a slab twice as thick, mirrored about the wall with no
    wall at all (gravity towards its middle), loses just as much of."""
    g = 0.85
    scene = dataclasses.replace(block(0.5, end=5.0), loads=(BodyForce((0.0, -g)),),
                                output=Output(particles=False))
    sim = Simulation(scene)
    sim.run(tmp_path, progress=False)
    e = read_csv(tmp_path / "energies.csv")
    assert "wall_work" in e
    np.testing.assert_allclose(e["total"], e["kinetic"] + e["elastic"] + e["fracture"] + e["friction_dissipation"]
                               - e["external_work"] - e["wall_work"], rtol=1e-12, atol=1e-15)
    wall, lost = -e["wall_work"][-1], 1.0 - e["total"][-1]
    assert 0.08 < lost < 0.15 and 0 < wall < 0.1 * lost
    # The slab alone on the wall, and mirrored about it without one.
    hard = scene.materials[1]
    alone = dataclasses.replace(scene, materials=(hard,), bodies=(scene.bodies[0],), contact=None)
    mirrored = dataclasses.replace(alone, walls=(), bodies=(
        Body("under", "slab", Rectangle((0.0, 1.0), (12.0, 2.0))), Body("slab", "slab", Rectangle((0.0, 2.0), (12.0, 3.0)))),
        loads=(BodyForce((0.0, g), body="under"), BodyForce((0.0, -g), body="slab")))
    drift = []
    for case, share in ((alone, 1.0), (mirrored, 0.5)):
        s = Simulation(case)
        s.advance(case.steps())
        drift.append(-share * s.energies()["total"])
    assert drift[0] == pytest.approx(drift[1], rel=0.15)
    assert drift[0] == pytest.approx(lost, rel=0.15)


def test_frictionless_block_keeps_its_speed():
    sim = Simulation(block(0.0, end=5.0))
    sim.advance(sim.scene.steps())
    b = sim.particles.body == 1
    speed = np.average(sim.particles.v[b, 0], weights=sim.particles.mass[b])
    assert speed == pytest.approx(1.0, rel=0.01)
    assert sim.particles.x[b, 0].mean() - 2.0 == pytest.approx(5.0, rel=0.01)
    assert sim.energies()["friction_dissipation"] == 0.0


def test_bodies_that_never_meet_run_bit_for_bit_as_one_field():
    m = Material("m", 100.0, 0.3, 1.0)
    bodies = (Body("a", "m", Disk((2.0, 3.0), 1.0), velocity=(-0.2, 0.1)),
              Body("b", "m", Disk((6.0, 3.0), 1.0), velocity=(0.3, 0.0)))
    kw = dict(grid=Grid(size=(8.0, 6.0), h=0.25, degree=2), time=Time(end=1.0), materials=(m,),
              bodies=bodies)
    one, two = Simulation(Scene(**kw)), Simulation(Scene(**kw, contact=Contact(friction=0.3)))
    for sim in (one, two):
        sim.advance(sim.scene.steps())
    assert "contact" in two.modules() and "contact" not in one.modules()
    for name in ("x", "v", "stress", "strain", "volume"):
        assert np.array_equal(getattr(one.particles, name), getattr(two.particles, name)), name
    # One body with a [contact] table is one field: no contact record at all.
    alone = Simulation(Scene(**{**kw, "bodies": bodies[:1]}, contact=Contact(friction=0.3)))
    assert alone.solver.contact_stats() is None and "contact" not in alone.modules()


def scene_dict() -> dict:
    return {
        "grid": {"size": [8.0, 6.0], "h": 0.25},
        "time": {"end": 1.0},
        "materials": [{"name": "m", "E": 100.0, "nu": 0.3, "density": 1.0}],
        "bodies": [{"name": "a", "material": "m", "shape": {"type": "disk", "center": [2.0, 3.0], "radius": 1.0}},
                   {"name": "b", "material": "m", "shape": {"type": "disk", "center": [5.0, 3.0], "radius": 1.0}}],
        "contact": {"friction": 0.65, "pairs": [{"bodies": ["a", "b"], "friction": 0.1}]},
    }


def test_contact_table_is_read_from_a_dict():
    scene = Scene.from_dict(scene_dict())
    assert scene.contact.friction == 0.65
    assert scene.contact.friction_matrix(("a", "b")).tolist() == [[0.65, 0.1], [0.1, 0.65]]
    assert Scene.from_dict(scene.to_dict()) == scene


@pytest.mark.parametrize("override, message", [
    ("contact.friction=-0.1", r"^contact\.friction = -0\.1: must be >= 0$"),
    ("contact.mu=0.3", r"^contact\.mu: unknown key \(allowed: friction, pairs, partition, touch_fill, groups, "
                        r"separability, kernel_radius, skin, surface_detection, surface_threshold, "
                        r"surfaces, phase_field_threshold, parting\)$"),
    ("contact.touch_fill=1.5", r"^contact\.touch_fill = 1\.5: must be >= 0 and <= 1$"),
    ("contact.pairs.0.friction=-1", r"^contact\.pairs\[0\]\.friction = -1: must be >= 0$"),
    ("contact.pairs.0.bodies=['a', 'c']", r"^contact\.pairs\[0\]\.bodies\[1\] = 'c': no body with that name"),
    ("contact.pairs.0.bodies=['a', 'a']", r"^contact\.pairs\[0\]\.bodies = \['a', 'a'\]: must name two different"),
    ("grid.degree=1", r"^grid\.degree = 1: contact needs quadratic or cubic B-splines"),
    ("bodies.b.shape.center=[3.5, 3.0]", r"^bodies\[1\] = 'b': \d+ of its particles lie inside bodies\[0\] \('a'\)"),
])
def test_bad_contact_input_is_refused(override, message):
    with pytest.raises(SceneError, match=message):
        Scene.from_dict(scene_dict(), [override])


def test_contact_on_the_linear_grid_needs_cpdi():
    """Single-point linear shape functions are refused with contact (two disks
    blow up, with or without it: docs/contact.md); CPDI1 on the same grid is not."""
    scene = Scene.from_dict(scene_dict(), ["grid.degree=1", "grid.shape=cpdi"])
    assert scene.grid.degree == 1 and scene.contact is not None


def test_duplicate_pair_is_refused():
    d = scene_dict()
    d["contact"]["pairs"].append({"bodies": ["b", "a"], "friction": 0.2})
    with pytest.raises(SceneError, match=r"^contact\.pairs\[1\]\.bodies = \['b', 'a'\]: duplicate pair"):
        Scene.from_dict(d)


def test_disk_beam_crack_rise_counts_cracked_bins_from_the_bottom():
    """benchmarks.disk_beam.measure.crack_rise finds where the paper's running-crack measure
    starts and ends from the crack's rise up the impact line: the cracked
    cells counted from the bottom face until the first uncracked one."""
    root = Path(__file__).resolve().parents[1] / "demos"
    scene = Scene.from_toml(root / "disk_beam.toml", [
        "grid.h=1.0", "materials.beam.fracture.l0=2.0", "materials.disk.fracture.l0=2.0",
        "bodies.beam.particles_per_cell=1", "bodies.disk.particles_per_cell=1"])
    sim = Simulation(scene)
    p = sim.particles

    def rise():
        return crack_rise(scene, p.x, p.body, p.c, "beam", 24.0)

    line = (p.body == 0) & (np.abs(p.x[:, 0] - 24.0) < 1.0)
    assert rise() == 0.0
    p.c[line & (p.x[:, 1] < 4.0)] = 0.0
    assert rise() == 4.0
    p.c[line & (p.x[:, 1] > 2.0) & (p.x[:, 1] < 3.0)] = 1.0  # a gap in the third cell
    assert rise() == 2.0
    p.c[line] = 0.0
    assert rise() == 10.0  # through the whole depth
