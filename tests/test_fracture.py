"""Phase-field fracture (AT2) in the MPM core: energy split, crack profile,
crack energy, irreversibility, and stability on hard cases."""

import math

import numpy as np
import pytest

from pfmpm import Scene, Simulation, _core
from pfmpm.crack import distance_to_polyline, initial_history
from pfmpm.observe import CrackTip
from pfmpm.scene import (
    Body,
    Crack,
    Fracture,
    Grid,
    Material,
    PhaseField,
    Rectangle,
    Time,
)

PLANES = ("strain", "stress")
SPLITS = ("spectral", "volumetric_deviatoric", "none")


def elastic(plane, split):
    return _core.LinearElastic(32000.0, 0.2, 2450.0, _core.Plane.__members__[plane],
                               _core.Split.__members__[split])


# -- energy split (eqs. 14-16) ------------------------------------------------


@pytest.mark.parametrize("plane", PLANES)
@pytest.mark.parametrize("split", SPLITS)
def test_split_parts_add_up_to_the_energy(plane, split):
    m = elastic(plane, split)
    eps = np.random.default_rng(1).normal(scale=1e-3, size=(2000, 3))
    plus, minus = m.split_energies(eps)
    sig = m.stresses(eps, np.ones(len(eps)))
    psi = 0.5 * (sig[:, 0] * eps[:, 0] + sig[:, 1] * eps[:, 1] + 2 * sig[:, 2] * eps[:, 2])
    assert np.all(plus >= 0) and np.all(minus >= 0)
    np.testing.assert_allclose(plus + minus, psi, rtol=1e-13, atol=1e-13 * psi.max())


@pytest.mark.parametrize("plane", PLANES)
def test_no_tensile_energy_in_pure_compression(plane):
    m = elastic(plane, "spectral")
    rng = np.random.default_rng(2)
    # Principal strains both negative, at random orientations.
    l1, l2 = -rng.uniform(1e-4, 1e-3, size=(2, 500))
    a = rng.uniform(0, np.pi, 500)
    c, s = np.cos(a), np.sin(a)
    eps = np.column_stack((l1 * c * c + l2 * s * s, l1 * s * s + l2 * c * c, (l1 - l2) * c * s))
    plus, minus = m.split_energies(eps)
    assert np.all(plus == 0.0)
    # A broken point (g = 0) still carries the full compressive stress.
    np.testing.assert_allclose(m.stresses(eps, np.zeros(500)), m.stresses(eps, np.ones(500)),
                               rtol=1e-12)


def test_volumetric_deviatoric_split_keeps_only_volume_compression():
    # Amor's split degrades shear even in compression; a pure (in-plane,
    # plane stress) volume compression carries no tensile energy.
    m = elastic("stress", "volumetric_deviatoric")
    eps = np.array([[-1e-3, -1e-3, 0.0], [-1e-3, 1e-4, 0.0]])
    plus, minus = m.split_energies(eps)
    assert plus[0] == 0.0 and plus[1] > 0.0
    mu = 32000.0 / 2.4
    dev = (-1.1e-3 / 2) ** 2 * 2  # deviator of the second strain, squared
    assert plus[1] == pytest.approx(mu * dev, rel=1e-12)


@pytest.mark.parametrize("plane", PLANES)
@pytest.mark.parametrize("split", SPLITS)
def test_stress_is_the_derivative_of_the_degraded_energy(plane, split):
    m = elastic(plane, split)
    rng = np.random.default_rng(3)
    eps = rng.normal(scale=1e-3, size=(500, 3))
    g = rng.uniform(0, 1, 500)

    def energy(e):
        plus, minus = m.split_energies(e)
        return g * plus + minus

    step = 1e-8
    sig = m.stresses(eps, g)
    for k in range(3):
        d = np.zeros(3)
        d[k] = step
        fd = (energy(eps + d) - energy(eps - d)) / (2 * step)
        if k == 2:
            fd /= 2  # psi depends on the tensor shear eps_xy through eps_xy and eps_yx
        np.testing.assert_allclose(fd, sig[:, k], rtol=0, atol=1e-6 * np.abs(sig).max())


# -- initial cracks and the crack tip -----------------------------------------


def test_initial_history_is_bordens_formula():
    crack = Crack(points=((0.0, 0.0), (2.0, 0.0), (2.0, 2.0)), B=1e3)
    fr = Fracture(Gc=3.0, l0=0.4)
    xy = np.array([[1.0, 0.0], [1.0, 0.1], [1.0, 0.25], [2.1, 1.0], [3.0, 3.0]])
    np.testing.assert_allclose(distance_to_polyline(xy, crack.points), [0, 0.1, 0.25, 0.1, math.sqrt(2)])
    peak = 1e3 * 3.0 / (4 * 0.4)
    np.testing.assert_allclose(initial_history(xy, crack, fr), [peak, peak * 0.5, 0, peak * 0.5, 0])


def test_crack_tip_position_and_speed():
    tip = CrackTip(origin=(5.0, 0.0), direction=(1.0, 0.0), threshold=0.2, samples=4)
    xs = np.linspace(0, 20, 201)
    xy = np.column_stack((xs, np.zeros_like(xs)))
    for k, t in enumerate(np.arange(6) * 0.5):
        front = 5.0 + 2.0 * t  # speed 2
        r = tip.update(t, xy, np.where(xs <= front, 0.0, 1.0))
        # One crack on the notch line: every tip is its tip.
        for track in CrackTip.TRACKS:
            assert r[f"{track}_x"] == pytest.approx(front, abs=0.051)
            assert r[f"{track}_y"] == 0.0
            if k:
                assert r[f"{track}_speed"] == pytest.approx(2.0, rel=0.03)
    # Cracked points behind the notch tip never count.
    assert tip.locate(xy, np.where(xs < 5.0, 0.0, 1.0))[2] == 0.0


def test_each_branch_keeps_its_tip():
    """Issue 21, defect 12: after a crack branches, the farthest cracked point
    jumps between the branches as they race; the left and right tips each
    follow their own branch, continuously, at its own speed."""
    tip = CrackTip(origin=(50.0, 20.0), direction=(1.0, 0.0), threshold=0.2, samples=3)
    stem = np.column_stack((np.linspace(50.0, 60.0, 101), np.full(101, 20.0)))
    angle = np.radians(15.0)
    rows = []
    for k, t in enumerate(np.arange(8.0)):
        # Branches from (60, 20) at +-15 degrees, taking turns to be the longer.
        upper, lower = 2.0 * t + (0.3 if k % 2 else 0.0), 2.0 * t + (0.0 if k % 2 else 0.3)
        arms = [np.column_stack((60 + s * np.cos(angle), 20 + sign * s * np.sin(angle)))
                for length, sign in ((upper, 1), (lower, -1)) for s in np.linspace(0.0, length, 200)[None, :]]
        xy = np.concatenate([stem, *arms])
        rows.append(tip.update(t, xy, np.zeros(len(xy))))
    crack_y = np.array([r["crack_tip_y"] for r in rows[1:]])
    assert np.any(crack_y > 20.0) and np.any(crack_y < 20.0)  # the farthest point jumps
    left = np.array([(r["left_tip_x"], r["left_tip_y"]) for r in rows])
    right = np.array([(r["right_tip_x"], r["right_tip_y"]) for r in rows])
    # Once the branches are more than BRANCH_OFFSET (1) off the line, at t = 2:
    k = np.arange(2, 8)
    np.testing.assert_allclose(left[2:, 1], 20.0 + np.sin(angle) * (2.0 * k + 0.3 * (k % 2)))
    np.testing.assert_allclose(right[2:, 1], 20.0 - np.sin(angle) * (2.0 * k + 0.3 * (k % 2 == 0)))
    # Each speed is the slope of its own tip's distance from the notch tip
    # over the last 3 records, whichever branch is ahead.
    for side, tips in (("left", left), ("right", right)):
        dist = np.hypot(tips[:, 0] - 50.0, tips[:, 1] - 20.0)
        for k in range(4, 8):
            slope = np.polyfit(np.arange(k - 2.0, k + 1.0), dist[k - 2: k + 1], 1)[0]
            assert rows[k][f"{side}_tip_speed"] == pytest.approx(slope, rel=1e-12)
            assert 1.6 < slope < 2.1


# -- the phase field of an imposed crack (eqs. 47-57) -------------------------


def crack_strip(h, l0, n, degree=2, thickness=1.0, across="x"):
    """A strip cut by a straight crack through its whole width.

    ``across="x"``: the strip lies along x and the crack is the line x = 0;
    ``"y"``: the strip lies along y... its crack is the line y = 0. The
    history band is one particle spacing wide, with a large B.
    """
    L, W, margin = 12 * l0, 4 * h, 3 * h
    lo, hi = (-L, 0.0), (L, W)
    size, origin = (2 * L + 2 * margin, W + 2 * margin), (-L - margin, -margin)
    line = ((0.0, -1.0), (0.0, W + 1.0))
    if across == "y":
        lo, hi, size, origin = lo[::-1], hi[::-1], size[::-1], origin[::-1]
        line = tuple(p[::-1] for p in line)
    return Scene(
        grid=Grid(size=size, h=h, origin=origin, degree=degree),
        time=Time(end=1.0),
        thickness=thickness,
        materials=(Material("m", 1.0, 0.2, 1.0, fracture=Fracture(Gc=2.5, l0=l0)),),
        bodies=(Body("strip", "m", Rectangle(min=lo, max=hi), particles_per_cell=n),),
        cracks=(Crack(points=line, B=1e4, half_width=h / n),),
        phase_field=PhaseField(tol=1e-10),
    )


def profile_error(sim, l0, axis=0):
    """Relative L2 error of c against 1 - exp(-|x|/(2 l0)), measured on the crack part 1 - c."""
    x, c, V = sim.particles.x[:, axis], sim.particles.c, sim.particles.volume
    exact = 1 - np.exp(-np.abs(x) / (2 * l0))
    return math.sqrt(np.sum(V * (c - exact) ** 2) / np.sum(V * (1 - exact) ** 2))


def test_one_dimensional_profile_and_crack_density():
    l0 = 1.0
    sim = Simulation(crack_strip(h=l0 / 8, l0=l0, n=4))
    assert profile_error(sim, l0) < 0.01
    # The crack density integrates to one per unit crack length (eq. 4).
    density = sim.energies()["fracture"] / (2.5 * 4 * l0 / 8)
    assert density == pytest.approx(1.0, abs=0.01)
    # The bounded solve: c in [0, 1]; a cold start frees the nodes no history
    # reaches at once, so it takes the unbounded CG's one pass.
    assert sim.particles.c.min() >= 0.0 and sim.particles.c.max() <= 1.0
    stats = sim.solver.phase_field_stats()
    assert stats["bounded"] and stats["last_passes"] == 1


def test_profile_error_falls_with_the_grid():
    l0 = 1.0
    coarse, fine = (profile_error(Simulation(crack_strip(h=h, l0=l0, n=4)), l0) for h in (l0 / 2, l0 / 4))
    assert fine < 0.6 * coarse


@pytest.mark.parametrize("degree", (2, 3))
def test_straight_crack_energy_is_gc_times_area(degree):
    l0, h, thickness = 1.0, 1.0 / 8, 2.0
    sim = Simulation(crack_strip(h=h, l0=l0, n=3, degree=degree, thickness=thickness, across="y"))
    length = 4 * h
    assert sim.energies()["fracture"] == pytest.approx(2.5 * length * thickness, rel=0.02)


@pytest.mark.parametrize("steps", (1, 3))
def test_stress_after_advance_is_the_degraded_stress_of_the_state(steps):
    # The steps inside an advance() leave a cracking particle's stress to the
    # next step's phase field; the state an advance() returns must carry the
    # stress of eq. 16 for its own strain and phase field. The strip is
    # stretched, so the strain changes in every step.
    scene = crack_strip(h=0.25, l0=1.0, n=2)
    sim = Simulation(scene)
    P = sim.particles
    P.v[:, 0] = 1e-3 * P.x[:, 0]
    sim.advance(2)
    before = P.strain.copy()
    sim.advance(steps)
    assert np.abs(P.strain - before).max() > 1e-6 * np.abs(before).max()
    c = P.c
    g = c * c  # g(c) of eq. 15 with k_f = 0
    m = _core.LinearElastic(1.0, 0.2, 1.0, _core.Plane.strain, _core.Split.spectral)
    expected = m.stresses(P.strain, g)
    np.testing.assert_allclose(P.stress, expected, rtol=1e-14, atol=1e-14 * np.abs(expected).max())
    assert g.min() < 0.5  # the crack is there: the degradation matters


def test_materials_that_cannot_crack_take_no_part():
    scene = crack_strip(h=0.25, l0=1.0, n=2)
    plain = Material("rigid", 1.0, 0.2, 1.0)
    extra = Body("block", "rigid", Rectangle(min=(-3.0, 0.0), max=(-2.0, 1.0)), particles_per_cell=2)
    scene = Scene(grid=scene.grid, time=scene.time, materials=scene.materials + (plain,),
                  bodies=scene.bodies + (extra,), cracks=(Crack(scene.cracks[0].points, body="strip",
                                                                  B=1e4, half_width=0.125),))
    sim = Simulation(scene)
    block = sim.particles.body == 1
    assert np.all(sim.particles.c[block] == 1.0) and np.all(sim.particles.history[block] == 0.0)
    assert "phase_field" in sim.modules()
    elastic_only = Simulation(Scene(grid=scene.grid, time=scene.time, materials=(plain,),
                                    bodies=(Body("block", "rigid", extra.shape),)))
    assert "phase_field" not in elastic_only.modules()
    assert elastic_only.solver.phase_field_stats()["solves"] == 0
