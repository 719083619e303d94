"""The measures of pfmpm.post and of the benchmarks (benchmarks/*/measure.py) on manufactured data: each gives the number it
must, and reads cracks with the scene's ``output.crack_threshold``."""

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from benchmarks.brazilian.measure import (contact_distance, disk_fragments, disk_speed, failed_fraction,
                                          platen_penetration, wall_excursion)
from benchmarks.disk_beam.measure import cone_index, running_crack
from pfmpm.post.arms import crack_directions, new_crack
from pfmpm.post.fragments import (closest_approach, count_fragments, domain_gap, fragment_sizes,
                                  fragments, mean_speed, median_size, particle_domains,
                                  size_distribution)
from pfmpm.observe import CrackTip
from pfmpm.scene import Scene

DEMOS = Path(__file__).resolve().parents[1] / "demos"
DISK_BEAM = ["grid.h=1.0", "materials.beam.fracture.l0=2.0", "materials.disk.fracture.l0=2.0",
             "bodies.beam.particles_per_cell=1", "bodies.disk.particles_per_cell=1"]
RINGS = ["grid.h=2.5", "materials.steel.fracture.l0=2.5", "bodies.A.particles_per_cell=1",
         "bodies.B.particles_per_cell=1"]
BRAZILIAN = ["grid.h=0.5"]
BORDEN = ["grid.h=1.0", "materials.concrete.fracture.l0=2.0", "bodies.plate.particles_per_cell=1"]


def lattice(x0, x1, y0, y1, step):
    """Points of a square lattice of ``step`` over [x0, x1) x [y0, y1)."""
    x, y = np.meshgrid(np.arange(x0, x1, step), np.arange(y0, y1, step))
    return np.column_stack([x.ravel(), y.ravel()])


# -- the running crack of the disk-beam impact ------------------------------------


def test_running_crack_reads_the_energy_between_start_and_end():
    # G_c t = 10.6066 x 2 = 21.2132 mJ per mm of rise; the beam is 10 mm deep.
    scene = Scene.from_toml(DEMOS / "disk_beam.toml", DISK_BEAM)
    per_length = 10.6066 * 2.0
    t = np.arange(10.0)
    rise = np.array([0, 0, 0, 2, 4, 6, 8, 9, 9, 9], dtype=float)
    energy = 50.0 + 1.5 * per_length * rise + 3.0 * (t >= 8)  # the band widens after the end
    r = running_crack(scene, "beam", t, rise, energy)
    assert (r["start"], r["end"]) == (2, 7)  # the last sample before the crack, the first at 9 mm
    assert (r["t_start"], r["t_end"], r["rise_end"], r["depth"]) == (2.0, 7.0, 9.0, 10.0)
    assert r["running"] == pytest.approx(1.5 * per_length * 9.0, rel=1e-12)
    assert r["per_rise"] == pytest.approx(1.5, rel=1e-12)
    assert r["per_area"] == pytest.approx(1.35, rel=1e-12)  # 9 of 10 mm risen
    assert r["slope"] == pytest.approx(1.5, rel=1e-12)  # rises 2, 4, 6, 8 mm: 20-80 % of the depth
    # A crack there from the first sample starts the count there.
    assert running_crack(scene, "beam", t, rise + 1.0, energy)["start"] == 0
    assert running_crack(scene, "beam", t, np.zeros(10), energy) == {}
    assert math.isnan(running_crack(scene, "beam", t[:3], [0, 10, 10], energy[:3])["slope"])


# -- the cone index -----------------------------------------------------------------


def test_cone_index_counts_crack_at_mid_depth_off_the_impact_line():
    scene = Scene.from_toml(DEMOS / "disk_beam.toml", DISK_BEAM)  # beam 48 x 10 mm, thickness 2
    x = lattice(0.25, 48.0, 0.25, 10.0, 0.5)
    body, volume = np.zeros(len(x), dtype=np.int32), np.full(len(x), 0.5)
    c = np.ones(len(x))
    c[np.abs(x[:, 0] - 24.0) < 1.9] = 0.0  # the flexural crack under the impact
    c[(x[:, 1] < 2.5) | (x[:, 1] > 7.5)] = 0.0  # crack in the top and bottom quarters
    assert cone_index(scene, x, body, c, volume, "beam", 24.0) == (0, 0.0)
    flank = (np.abs(x[:, 0] - 14.25) < 0.1) & (np.abs(x[:, 1] - 5.25) < 1.6)  # 7 points at x = 14.25
    c[flank] = 0.15
    assert cone_index(scene, x, body, c, volume, "beam", 24.0) == (1, pytest.approx(7 * 0.5 / 2.0))
    stricter = Scene.from_toml(DEMOS / "disk_beam.toml", DISK_BEAM + ["output.crack_threshold=0.1"])
    assert cone_index(stricter, x, body, c, volume, "beam", 24.0) == (0, 0.0)
    # The disk's particles do not count.
    assert cone_index(scene, x, np.ones(len(x), dtype=np.int32), c, volume, "beam", 24.0) == (0, 0.0)


# -- fragments ----------------------------------------------------------------------


def test_fragments_are_linked_sets_of_intact_particles():
    a, b = lattice(0.0, 5.0, 0.0, 5.0, 1.0), lattice(10.0, 15.0, 0.0, 5.0, 1.0)
    debris, small = np.array([[30.0, 0.0], [31.0, 0.0], [32.0, 0.0]]), lattice(40.0, 42.0, 0.0, 2.0, 1.0)
    assert count_fragments(np.vstack([a, b, debris, small]), 1.0) == 3  # 3 points are debris; 4 are not
    assert count_fragments(np.vstack([a, b]), 5.0) == 1  # links up to 1.5 spacings: 6 apart < 7.5
    assert count_fragments(np.zeros((0, 2)), 1.0) == 0


def test_fragments_per_body_cut_at_the_scene_threshold_and_closest_approach():
    scene = Scene.from_toml(DEMOS / "two_rings.toml", RINGS)  # particle spacing 2.5 mm
    ring_a = lattice(0.0, 50.0, 0.0, 25.0, 2.5)
    ring_b = ring_a + [60.0, 0.0]  # 12.5 mm = 5 spacings from ring A
    x = np.vstack([ring_a, ring_b])
    body = np.repeat(np.array([0, 1], dtype=np.int32), len(ring_a))
    c = np.ones(len(x))
    assert fragments(scene, x, body, c) == {"A": 1, "B": 1}
    c[(body == 0) & (np.abs(x[:, 0] - 25.0) < 2.0)] = 0.19  # a crack across ring A at x = 25
    assert fragments(scene, x, body, c) == {"A": 2, "B": 1}
    looser = Scene.from_toml(DEMOS / "two_rings.toml", RINGS + ["output.crack_threshold=0.1"])
    assert fragments(looser, x, body, c) == {"A": 1, "B": 1}
    assert closest_approach(scene, x, body) == pytest.approx(5.0)


def test_domain_gap_of_deformed_particle_domains():
    """The interpenetration measure of checks B4 and W3: 0 for domains that
    touch (face to face, offset along the face, or compressed), the depth
    of an overlap, in cells, and the domains of F = I + epsilon."""
    scene = Scene.from_toml(DEMOS / "two_rings.toml", RINGS)  # h = spacing = 2.5 mm
    s = 2.5
    below = lattice(0.0, 25.0, 0.0, 10.0, s)
    top = below[:, 1].max()
    above = below + [0.0, top + s]  # ring B's bottom row one spacing above A's top row
    body = np.repeat(np.array([0, 1], dtype=np.int32), len(below))
    square = (np.tile([0.5 * s, 0.0], (2 * len(below), 1)), np.tile([0.0, 0.5 * s], (2 * len(below), 1)))

    def gap(x, r1=square[0], r2=square[1]):
        return domain_gap(scene, x, body, r1, r2)

    assert gap(np.vstack([below, above])) == pytest.approx(0.0, abs=1e-12)
    assert gap(np.vstack([below, above + [0.5 * s, 0.0]])) == pytest.approx(0.0, abs=1e-12)
    assert gap(np.vstack([below, above - [0.0, 0.1 * s]])) == pytest.approx(-0.1)
    assert gap(np.vstack([below, above + [0.3 * s, 0.2 * s]])) == pytest.approx(0.2)
    # A's particles squeezed to half their height: its top face comes down
    # by s / 4, so B's particles may come s / 4 nearer before they touch,
    # which closest_approach reads as a quarter-spacing overlap.
    squeezed = square[1].copy()
    squeezed[body == 0] *= 0.5
    x = np.vstack([below, above - [0.0, 0.25 * s]])
    assert gap(x, square[0], squeezed) == pytest.approx(0.0, abs=1e-12)
    assert closest_approach(scene, x, body) == pytest.approx(0.75)
    assert gap(x) == pytest.approx(-0.25)
    # The domains of a small strain: r_1 = s/2 (1 + e_xx, e_xy), r_2 = s/2 (e_xy, 1 + e_yy).
    strain = np.tile([0.02, -0.5, 0.01], (len(body), 1))
    r1, r2 = particle_domains(scene, SimpleNamespace(body=body, material=np.zeros(len(body), np.int32),
                                                     strain=strain))
    assert np.allclose(r1, [0.5 * s * 1.02, 0.5 * s * 0.01]) and np.allclose(r2, [0.5 * s * 0.01, 0.25 * s])
    # B raised by 1 mm: half-height domains leave s + 1 - 2 (s / 4) between the rows.
    assert domain_gap(scene, np.vstack([below, above + [0.0, 1.0]]), body, r1, r2) == pytest.approx(
        (0.5 * s + 1.0) / s, rel=1e-3)


def test_fragment_sizes_are_equivalent_diameters_of_linked_sets():
    # h = 1, 2 x 2 particles per cell (spacing 0.5, area 0.25, mass 0.5 each),
    # linked within 0.75: lattice (0.5) and diagonal (0.707) neighbours join.
    a = lattice(0.0, 2.0, 0.0, 2.0, 0.5)  # 16 particles: A = 4
    b = lattice(3.0, 4.0, 0.0, 3.0, 0.5)  # 12, one empty column (1.0 apart) from a: A = 3
    diagonal = np.array([[10.0, 0.0], [10.5, 0.5], [11.0, 1.0]])  # a chain of diagonal neighbours
    single = np.array([[20.0, 0.0]])
    x = np.vstack([a, b, diagonal, single])
    sizes, masses = fragment_sizes(x, np.full(len(x), 0.25), np.full(len(x), 0.5), 0.75)
    order = np.argsort(sizes)
    expected = np.sqrt(4.0 * np.array([0.25, 0.75, 3.0, 4.0]) / math.pi)  # 0.564, 0.977, 1.954, 2.257
    assert sizes[order] == pytest.approx(expected, rel=1e-14)
    assert masses[order] == pytest.approx([0.5, 1.5, 6.0, 8.0], rel=1e-14)
    # 0.7 no longer joins diagonal neighbours (0.707): the chain falls apart.
    assert len(fragment_sizes(x, np.full(len(x), 0.25), np.ones(len(x)), 0.7)[0]) == 6
    assert fragment_sizes(np.zeros((0, 2)), [], [], 0.75)[0].size == 0


def test_size_distribution_and_mass_weighted_median():
    sizes, masses = np.array([2.0, 0.5, 1.0, 0.01]), np.array([3.0, 1.0, 4.0, 100.0])
    s, f = size_distribution(sizes, masses, 0.05)  # the 0.01 one is below the smallest size
    assert s.tolist() == [0.5, 1.0, 2.0]
    assert f == pytest.approx([1 / 8, 5 / 8, 1.0], rel=1e-15)
    assert median_size(sizes, masses, 0.05) == 1.0  # 5/8 of the mass in sizes <= 1
    assert median_size(sizes, np.array([3.0, 1.0, 3.0, 0.0]), 0.05) == 1.0  # exactly 1/2 at 1
    assert median_size(sizes, np.array([5.0, 1.0, 3.0, 0.0]), 0.05) == 2.0
    assert math.isnan(median_size(sizes, masses, 10.0))
    assert median_size(sizes, masses, 0.0) == 0.01  # unfiltered, the dust holds most of the mass
    v = np.array([[3.0, 4.0], [0.0, -1.0]])
    assert mean_speed(v, [1.0, 3.0]) == pytest.approx((5.0 + 3.0) / 4.0, rel=1e-15)


def brazilian_particles():
    """The particles of the Brazilian disk scene at h = 0.5 (two per cell), at t = 0."""
    from types import SimpleNamespace
    from pfmpm.simulation import Simulation

    scene = Scene.from_toml(DEMOS / "brazilian.toml", BRAZILIAN)
    p = Simulation(scene).particles
    cols = {k: np.array(getattr(p, k)) for k in ("x", "v", "mass", "volume", "damage", "body")}
    return scene, SimpleNamespace(**cols)


def test_disk_fragments_of_a_disk_cut_in_two():
    scene, p = brazilian_particles()  # disk radius 5, spacing 0.25, thickness 2
    disk = p.body == 0
    area = p.volume[disk].sum() / 2.0
    one = disk_fragments(scene, p)
    assert one["fragments"] == 1 and one["intact"] == pytest.approx(1.0, rel=1e-14)
    assert one["d50"] == pytest.approx(math.sqrt(4 * area / math.pi), rel=1e-14)
    # A vertical crack one particle wide (D = 1) at x = -1.125, and a damaged
    # (D = 0.5) column beside it: D <= 1e-6 gives two pieces, left of x = -1.25
    # and right of -0.75; D < 1 joins the damaged column to the right one.
    crack = disk & (np.abs(p.x[:, 0] + 1.125) < 0.01)
    damaged = disk & (np.abs(p.x[:, 0] + 0.875) < 0.01)
    p.damage[crack], p.damage[damaged] = 1.0, 0.5
    left, right = disk & (p.x[:, 0] < -1.25), disk & (p.x[:, 0] > -0.75)
    two = disk_fragments(scene, p)
    sizes = np.sqrt(4 * np.array([p.volume[left].sum(), p.volume[right].sum()]) / 2.0 / math.pi)
    assert two["fragments"] == 2 and two["sizes"] == pytest.approx(np.sort(sizes), rel=1e-14)
    m = np.array([p.mass[left].sum(), p.mass[right].sum()])
    assert two["fractions"][0] == pytest.approx(m.min() / m.sum(), rel=1e-14)
    assert two["d50"] == pytest.approx(sizes[1], rel=1e-14)  # the right piece holds over half the mass
    unfailed = disk_fragments(scene, p, intact="unfailed")
    assert unfailed["fragments"] == 2
    assert unfailed["sizes"][1] == pytest.approx(
        math.sqrt(4 * p.volume[right | damaged].sum() / 2.0 / math.pi), rel=1e-14)
    assert unfailed["intact"] == pytest.approx(1.0 - p.mass[crack].sum() / p.mass[disk].sum(), rel=1e-14)
    # The fully damaged area fraction: the crack's particles over the disk's.
    assert failed_fraction(scene, p) == pytest.approx(p.volume[crack].sum() / p.volume[disk].sum(), rel=1e-14)
    # The mean speed counts every disk particle, the platens none.
    p.v[disk] = [0.0, 2.0]
    p.v[crack] = [0.0, 4.0]
    p.v[~disk] = [100.0, 0.0]
    expected = (2.0 * p.mass[disk & ~crack].sum() + 4.0 * p.mass[crack].sum()) / p.mass[disk].sum()
    assert disk_speed(scene, p) == pytest.approx(expected, rel=1e-14)
    assert two["mean_speed"] == 0.0
    with pytest.raises(ValueError, match="intact"):
        disk_fragments(scene, p, intact="cracked")


def test_brazilian_contact_walls_and_platens():
    scene, p = brazilian_particles()  # h = 0.5, spacing 0.25
    assert contact_distance(scene, [[0.0, 5.0], [0.0, -5.0], [0.0, 0.0], [3.0, 1.0]]) == pytest.approx(
        [0.0, 0.0, 5.0, 5.0], rel=1e-15)
    # At t = 0 the outermost platen particles lie half a spacing inside the
    # walls at x = -6, 6, and the disk's top and bottom particles half a
    # spacing below (above) the platen faces: -1/4 cell each.
    assert wall_excursion(scene, p.x) == pytest.approx(-0.25, rel=1e-12)
    x0 = p.x.copy()
    for name in ("top", "bottom"):
        assert platen_penetration(scene, x0, p.x, p.body, name) == pytest.approx(-0.25, rel=1e-12)
    x = x0.copy()
    top = np.argmax(np.where(p.body == 0, x0[:, 1], -np.inf))  # the disk's highest particle
    x[top, 1] += 0.25  # a quarter cell into the platen
    assert platen_penetration(scene, x0, x, p.body, "top") == pytest.approx(0.25, rel=1e-12)
    assert platen_penetration(scene, x0, x, p.body, "bottom") == pytest.approx(-0.25, rel=1e-12)
    # The platen bends: its face follows its particles.
    x[p.body == 1, 1] += 0.1 * x0[p.body == 1, 0] ** 2 / 36.0
    assert platen_penetration(scene, x0, x, p.body, "top") == pytest.approx(0.25 - 0.1 * x0[top, 0] ** 2 / 36 / 0.5,
                                                                            rel=1e-12)
    x[0, 0] = 6.3  # 0.3 mm past the right wall
    assert wall_excursion(scene, x) == pytest.approx(0.6, rel=1e-12)


# -- crack directions ---------------------------------------------------------------


def test_crack_directions_of_an_arm_along_a_weak_direction():
    scene = Scene.from_toml(DEMOS / "borden_cubic.toml", BORDEN)  # notch tip (50, 20), l0 = 2
    x = lattice(0.125, 100.0, 0.125, 40.0, 0.25)
    c = np.ones(len(x))
    tip = np.array([50.0, 20.0])
    u = np.array([math.cos(math.radians(-30.0)), math.sin(math.radians(-30.0))])
    rel = x - tip
    c[(rel @ u > 0) & (np.abs(rel @ [-u[1], u[0]]) < 0.3)] = 0.0  # one arm at -30 degrees
    c0 = np.where((x[:, 0] < 50.0) & (np.abs(x[:, 1] - 20.0) < 0.5), 0.0, 1.0)  # the notch band
    r = crack_directions(scene, x, new_crack(c0, np.minimum(c, c0), 0.2))
    assert r["weak_directions"] == pytest.approx([60.0, 150.0, 240.0, 330.0], abs=0.1)
    (only,) = r["tips"]
    assert only["tip"] == (50.0, 20.0)
    assert only["angle"] == pytest.approx(330.0, abs=0.5) and only["off_weak"] < 0.5
    assert list(only["arms"]) == [10.0, 20.0, 40.0, 80.0]  # 5, 10, 20, 40 l0
    assert only["arms"][10.0] == pytest.approx([330.0], abs=1.0)
    assert only["arms"][20.0] == pytest.approx([330.0], abs=1.0)
    assert only["arms"][80.0] == []  # beyond the plate


# -- the crack tip -------------------------------------------------------------------


def test_crack_tip_takes_the_scene_threshold():
    scene = Scene.from_toml(DEMOS / "borden_plate.toml", BORDEN + ["output.crack_threshold=0.35"])
    tip = CrackTip.for_scene(scene)
    assert tip.threshold == 0.35
    assert tuple(tip.origin) == (50.0, 20.0) and tuple(tip.direction) == (1.0, 0.0)
    xy, c = np.array([[60.0, 20.0], [55.0, 20.0]]), np.array([0.3, 0.1])
    assert tip.locate(xy, c) == (60.0, 20.0, 10.0)  # 0.3 is cracked at 0.35


# -- Kalthoff-Winkler: the crack from the notch tip (H&H section 3.2) ---------------

KW_SMOKE = ["grid.h=2.0", "bodies.target.holes.0.max=[50.0, 29.0]"]


def kw_band(tip, angle_deg, r0, r1, spacing, width):
    """Points of a band along a ray from ``tip`` at ``angle_deg``, ``width`` wide."""
    u = np.array([math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))])
    n = np.array([-u[1], u[0]])
    s, w = np.meshgrid(np.arange(r0, r1, spacing), np.arange(-width / 2, width / 2 + 1e-9, spacing))
    return tip + s.ravel()[:, None] * u + w.ravel()[:, None] * n, w.ravel()


def test_kalthoff_winkler_notch_tip_and_crack_angles():
    from benchmarks.kalthoff_winkler.measure import crack_angles, from_face, notch_tip

    scene = Scene.from_toml(DEMOS / "kalthoff_winkler.toml")
    tip, direction, half = notch_tip(scene)
    assert tip.tolist() == [50.0, 26.0] and direction.tolist() == [1.0, 0.0] and half == 1.0
    # From the tip face, the segment x = 50, 25 <= y <= 27: on it, beside it, ahead of it.
    points = [[50.0, 25.5], [50.0, 28.0], [53.0, 26.0], [54.0, 30.0], [47.0, 29.0]]
    assert from_face(points, tip, direction, half) == pytest.approx([0.0, 1.0, 3.0, 5.0, 3.6055512755])
    # One row of failed particles at 60 degrees, a second crack below the notch's
    # line (not the crack that leaves it upwards) and partial damage around.
    row = tip + np.outer(np.arange(1.0, 40.0, 1.3), [0.5, math.sqrt(3) / 2])
    below = tip + np.outer(np.arange(1.0, 40.0, 1.3), [0.5, -math.sqrt(3) / 2])
    x = np.vstack([row, below, row + [0.3, 0.0]])
    damage = np.concatenate([np.ones(len(row)), np.ones(len(below)), np.full(len(row), 0.99)])
    bearing, line = crack_angles(x, damage, tip, direction)
    assert bearing == pytest.approx(60.0, abs=1e-9) and line == pytest.approx(60.0, abs=1e-9)
    # En echelon: from 15 mm on the row steps 4 mm sideways. The bearing turns
    # less than the line, which tilts towards the offset.
    step = np.where(np.hypot(*(row - tip).T)[:, None] > 15.0, [4.0, 0.0], [0.0, 0.0])
    bearing, line = crack_angles(row + step, np.ones(len(row)), tip, direction)
    assert 50.0 < bearing < 60.0 and line < bearing - 5.0  # 54.9 and 48.0
    assert all(math.isnan(a) for a in crack_angles(x, np.zeros(len(x)), tip, direction))


def test_kalthoff_winkler_record_follows_the_band_from_the_notch_tip():
    from benchmarks.kalthoff_winkler.measure import CrackRecord, from_face, report

    scene = Scene.from_toml(DEMOS / "kalthoff_winkler.toml", KW_SMOKE)  # h = 2, tip (50, 27)
    tip = np.array([50.0, 27.0])
    band, offset = kw_band(tip, 60.0, 0.5, 25.0, 0.5, 4.0)
    # Partial damage across the band, failed particles on its axis every 4 mm
    # (farther apart than the particles link), and far off a spall of failed
    # particles that never reaches the notch tip.
    damage = np.where(np.abs(offset) < 1.0, 0.7, 0.6)
    axis = np.flatnonzero(np.abs(offset) < 1e-9)[::8]  # from 0.5 mm, every 4 mm
    damage[axis] = 1.0
    spall = lattice(80.0, 100.0, 0.0, 1.0, 0.5)
    x = np.vstack([band, spall, lattice(0.0, 100.0, 60.0, 62.0, 5.0)])
    d = np.concatenate([damage, np.ones(len(spall)), np.zeros(len(x) - len(band) - len(spall))])
    record = CrackRecord(scene, len(x))
    record.sample(0.0, x, np.zeros(len(x)), 1.0)
    reach = float(np.hypot(*(band[axis] - tip).T).max())
    record.sample(10.0, x, d, 1.0 + 1e-12)
    assert record.rows[-1]["tip"] == pytest.approx(reach)
    assert record.rows[-1]["arms"] == [1, 1, 0]  # the band crosses 10 and 20 mm, not 30
    face = from_face(band[axis], tip, [1.0, 0.0], 2.0)
    assert record.first == {"t": 10.0, "distance": pytest.approx(float(face.min()))}
    # A branch from 12 mm at 110 degrees: two arms at 20 mm.
    fork = tip + 12.0 * np.array([0.5, math.sqrt(3) / 2])
    branch, _ = kw_band(fork, 110.0, 0.5, 15.0, 0.5, 2.0)
    x2, d2 = np.vstack([x, branch]), np.concatenate([d, np.full(len(branch), 0.8)])
    record2 = CrackRecord(scene, len(x2))
    record2.sample(20.0, x2, d2, 1.0)
    assert record2.rows[-1]["arms"][:2] == [1, 2]
    run = {"rows": record.rows, "first": record.first, "passed": record.passed, "momentum_x0": 1.0}
    out = report(run, scene.grid.h)
    assert out["momentum_drift"] == pytest.approx(1e-12, rel=1e-3)
    assert out["initiation_near_tip"] is True
    assert out["single_until"] == 10.0 and out["single_crack"] is False
    assert math.isnan(out["angle"])  # the tip never passed 30 mm


def test_kalthoff_winkler_speed_is_the_slope_over_the_window():
    from benchmarks.kalthoff_winkler.measure import speed

    rows = [{"t": t, "tip": max(0.0, 2.0 * (t - 30.0))} for t in np.arange(0.0, 60.0, 0.5)]
    assert speed(rows, (40.0, 50.0)) == pytest.approx(2.0, rel=1e-12)
    assert math.isnan(speed(rows, (10.0, 20.0)))  # no crack yet


def test_body_fields_keeps_the_bodies_apart_without_partitioning():
    from benchmarks.common.self_contact import body_fields, variants

    scene = Scene.from_toml(DEMOS / "kalthoff_winkler.toml")
    sf = body_fields(scene)
    assert sf.contact.partition == "bodies" and sf.contact.friction == 0.1
    assert [(p.bodies, p.friction) for p in sf.contact.pairs] == [(("target", "impactor"), 0.0)]
    assert sf.bodies == scene.bodies and sf.materials == scene.materials
    assert variants(Scene.from_toml(DEMOS / "billet.toml"))["multi_field"] == body_fields(
        Scene.from_toml(DEMOS / "billet.toml"))
    # The reference meets by the scene's contact rule (the wedge's: the paper's,
    # on approach alone).
    wedge = Scene.from_toml(DEMOS / "wedge_disk_block.toml")
    assert wedge.contact.touch_fill == 0.0 and body_fields(wedge).contact.touch_fill == 0.0
    with pytest.raises(ValueError, match="damage_gradient"):
        body_fields(sf)
