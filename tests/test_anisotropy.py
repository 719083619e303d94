"""The fourth-order anisotropic phase field (eqs. 4-8, 55, 57): the polar
surface energy against the paper's values and a numerical minimisation, the
1D profile of the MPM solver against the analytic one, rotation, and input
errors."""

import dataclasses
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from pfmpm import _core, anisotropy, cli
from pfmpm.post.arms import crack_arms, propagation_angle
from pfmpm.scene import (Anisotropy, Body, Crack, Fracture, Grid, Material, PhaseField, Rectangle,
                         Scene, SceneError, Time, Traction)
from pfmpm.simulation import Simulation

# -- G_c(theta), eq. 8 ----------------------------------------------------------

# (G-bar_c, gamma, (G_c,min, G_c,max)) quoted by Kakouris & Triantafyllou 2019.
PUBLISHED = {
    "borden-cubic": (0.002121, "1,0,0;0,1,0;0,0,74", (0.003, 0.0049)),
    "borden-orthotropic": (0.002121, "1,0,0;0,80,0;0,0,74", (0.003, 0.0067)),
    "composite": (4.175, "1,0,0;0,2900,0;0,0,74", (5.9067, 30.9044)),
    "disk-beam-iii": (7.5, "80,0,0;0,1,0;0,0,74", (10.6066, 23.6892)),
}


@pytest.mark.parametrize("case", PUBLISHED)
def test_polar_command_reproduces_the_published_extremes(case, tmp_path, capsys):
    gc_bar, gamma, (gc_min, gc_max) = PUBLISHED[case]
    out = tmp_path / "polar.csv"
    assert cli.main(["polar", "--gamma", gamma, "--gc-bar", str(gc_bar), "--phi", "30",
                     "--out", str(out)]) == 0
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    assert out.read_text().splitlines()[0] == "theta_deg,gc,inv_gc"
    assert table[0, 0] == 0.0 and table[-1, 0] == 360.0
    np.testing.assert_allclose(table[:, 2], 1.0 / table[:, 1], rtol=1e-14)
    assert table[:, 1].min() == pytest.approx(gc_min, rel=0.005)
    assert table[:, 1].max() == pytest.approx(gc_max, rel=0.005)
    assert out.with_suffix(".png").stat().st_size > 0
    assert "Gc_min" in capsys.readouterr().out


@pytest.mark.parametrize("g", (0.5, 1.0, 7.0))
@pytest.mark.parametrize("phi", (0.0, 23.0, 90.0))
def test_isotropic_fourth_order_is_independent_of_direction(g, phi):
    gamma = Anisotropy("isotropic4", g1111=g).matrix()
    gc = anisotropy.surface_energy(gamma, 2.0, np.linspace(0, 360, 721), phi)
    np.testing.assert_allclose(gc, 2.0 * math.sqrt(1 + math.sqrt(g)), rtol=1e-13)
    assert anisotropy.weak_directions(gamma, phi).size == 0


def test_zero_gamma_gives_the_reference_value_exactly():
    gc = anisotropy.surface_energy(np.zeros((3, 3)), 0.0035, np.linspace(0, 360, 97), 17.0)
    assert np.all(gc == 0.0035)


@pytest.mark.parametrize("gamma_n", (0.05, 0.3, 1.0, 5.0, 80.0))
def test_closed_form_is_the_minimum_of_the_1d_functional(gamma_n):
    """Minimise 2 int_0^X (d^2/4 + d'^2 + gamma_n d''^2) with d(0) = 1, d'(0) = 0
    by finite differences on [0, 50 l0], as the paper evaluates eq. 8."""
    X, n = 50.0, 20000
    dx = X / n
    # Unknowns d_1..d_n; d_0 = 1 and the ghost d_-1 = d_1 (d'(0) = 0).
    D1 = sp.diags([-np.ones(n), np.ones(n)], [0, 1], shape=(n, n + 1)) / dx  # on [d_0..d_n]
    D2 = sp.diags([np.ones(n - 1), -2 * np.ones(n - 1), np.ones(n - 1)], [0, 1, 2],
                  shape=(n - 1, n + 1)) / dx**2
    w = np.full(n + 1, dx)
    w[[0, -1]] = dx / 2
    # The second difference at x = 0 with the ghost: 2 (d_1 - d_0) / dx^2.
    row0 = sp.csr_matrix(([-2.0 / dx**2, 2.0 / dx**2], ([0, 0], [0, 1])), shape=(1, n + 1))
    D2 = sp.vstack([row0, D2])
    w2 = np.full(n, dx)
    w2[0] = dx / 2
    A = (0.25 * sp.diags(w) + D1.T @ sp.diags(np.full(n, dx)) @ D1
         + gamma_n * D2.T @ sp.diags(w2) @ D2).tocsr()
    # Fix d_0 = 1: solve for the rest.
    d = np.ones(n + 1)
    d[1:] = spla.spsolve(A[1:, 1:].tocsc(), -A[1:, 0].toarray().ravel())
    energy = 2 * d @ (A @ d)
    assert energy == pytest.approx(float(anisotropy.surface_energy_ratio(gamma_n)), rel=2e-3)
    x = np.arange(n + 1) * dx
    near = x < 10 * max(1.0, gamma_n ** 0.25)
    np.testing.assert_allclose(d[near], anisotropy.profile(gamma_n, x[near], 1.0), atol=2e-3)


@pytest.mark.parametrize("phi", (45.0, 30.0, 0.0, -20.0))
def test_the_fibres_carry_the_least_surface_energy(phi):
    """Section 5.4: fibres at phi (clockwise from x) with gamma_1111 = 1 and
    gamma_2222 = 2900 have G_c,min = 5.9067 along the fibres and G_c,max =
    30.9044 across them; the one weak direction is the fibre line."""
    gamma = anisotropy.parse_gamma(PUBLISHED["composite"][1])
    along, across = anisotropy.surface_energy(gamma, 4.175, [-phi, 90.0 - phi], phi)
    assert along == pytest.approx(5.9067, rel=0.005)
    assert across == pytest.approx(30.9044, rel=0.005)
    weak = anisotropy.weak_directions(gamma, phi)
    off = (weak + phi) % 180.0
    assert weak.size == 2 and np.all(np.minimum(off, 180.0 - off) < 0.1)


def test_core_rotation_uses_the_polar_convention():
    gamma = [[1.0, 0.3, 0.1], [0.3, 80.0, 0.2], [0.1, 0.2, 74.0]]
    f = _core.Fracture(1.0, 1.0, 0.0, gamma)
    assert f.fourth_order and not _core.Fracture(1.0, 1.0).fourth_order
    for phi_deg in (0.0, 30.0, -45.0, 90.0, 123.0):
        G = np.array(f.rotated(math.radians(phi_deg)))
        for theta in (0.0, 20.0, 77.0, 135.0, 300.0):
            a = math.radians(theta)
            nx, ny = -math.sin(a), math.cos(a)  # the crack normal
            m = np.array([nx * nx, ny * ny, nx * ny])
            assert m @ G @ m == pytest.approx(
                float(anisotropy.normal_coefficient(gamma, theta, phi_deg)), rel=1e-13)


# -- the MPM phase field of a straight crack (eqs. 55, 57) --------------------


def crack_strip(h, l0, anisotropy_table, orientation=0.0, n=4):
    """A strip along x cut by a crack on x = 0, pinned by a large history (B)."""
    L, W, margin = 16 * l0, 4 * h, 3 * h
    return Scene(
        grid=Grid(size=(2 * L + 2 * margin, W + 2 * margin), h=h, origin=(-L - margin, -margin)),
        time=Time(end=1.0),
        materials=(Material("m", 1.0, 0.2, 1.0, fracture=Fracture(Gc=2.5, l0=l0,
                                                                   anisotropy=anisotropy_table)),),
        bodies=(Body("strip", "m", Rectangle(min=(-L, 0.0), max=(L, W)), particles_per_cell=n,
                     orientation=orientation),),
        cracks=(Crack(points=((0.0, -1.0), (0.0, W + 1.0)), B=1e8, half_width=h / n),),
        phase_field=PhaseField(tol=1e-9, max_iterations=20000),
    )


@pytest.mark.parametrize("table, orientation", [
    (Anisotropy("isotropic4"), 0.0),                                     # gamma_n = 1
    (Anisotropy("orthotropic", g1111=0.3, g2222=5.0, g1212=1.0), 0.0),   # gamma_n = 5
    (Anisotropy("orthotropic", g1111=0.3, g2222=5.0, g1212=1.0), 90.0),  # gamma_n = 0.3
])
def test_one_dimensional_fourth_order_profile(table, orientation):
    l0, h = 1.0, 0.25
    sim = Simulation(crack_strip(h, l0, table, orientation))
    assert sim.solver.phase_field_stats()["fourth_order"]
    gamma_n = float(anisotropy.normal_coefficient(table.matrix(), 90.0, orientation))
    x, c, V = sim.particles.x[:, 0], sim.particles.c, sim.particles.volume
    exact = anisotropy.profile(gamma_n, x, l0)
    error = math.sqrt(np.sum(V * ((1 - c) - exact) ** 2) / np.sum(V * exact**2))
    assert error < 0.01
    per_length = sim.energies()["fracture"] / (2.5 * 4 * h)
    assert per_length == pytest.approx(float(anisotropy.surface_energy_ratio(gamma_n)), rel=0.02)


def test_zero_gamma_does_no_fourth_order_work():
    """An explicit isotropic2 table is the second-order model, bit for bit."""
    plain = Simulation(crack_strip(0.25, 1.0, None))
    zero = Simulation(crack_strip(0.25, 1.0, Anisotropy("isotropic2")))
    assert not zero.solver.phase_field_stats()["fourth_order"]
    assert "fourth_order_phase_field" not in zero.modules()
    assert np.array_equal(plain.particles.c, zero.particles.c)
    assert plain.energies()["fracture"] == zero.energies()["fracture"]


# -- the SSOR-preconditioned CG of the fourth-order system ---------------------


def cold_solve(tol):
    """The first (cold) solve of the notched cubic plate below at tolerance tol."""
    scene = dataclasses.replace(notched_plate(False),
                                phase_field=PhaseField(tol=tol, max_iterations=20000))
    sim = Simulation(scene)
    return sim.particles.c.copy(), sim.solver.phase_field_stats()


def test_ssor_cg_reaches_the_tight_solution_in_a_third_of_the_jacobi_iterations():
    """The cold solve of the notched plate (1156 unknowns, gamma_1212 = 74)
    took 774 Jacobi-preconditioned CG iterations; with symmetric Gauss-Seidel it
    takes 240. Its solution at tol = 1e-6 agrees with a 1e-12 solve to 2e-7."""
    c, stats = cold_solve(1e-6)
    tight, tight_stats = cold_solve(1e-12)
    assert stats["fourth_order"] and stats["unknowns"] == 1156
    assert stats["last_iterations"] < 300
    assert tight_stats["last_residual"] <= 1e-12
    assert np.abs(c - tight).max() < 1e-5


def test_ssor_cg_is_bitwise_the_same_with_one_or_two_threads():
    script = ("import sys, hashlib; sys.path.insert(0, sys.argv[1]); "
              "from test_anisotropy import notched_plate; from pfmpm.simulation import Simulation; "
              "sim = Simulation(notched_plate(False)); sim.advance(5); "
              "print(hashlib.sha256(sim.particles.c.tobytes()).hexdigest(), "
              "sim.solver.phase_field_stats()['iterations'])")
    runs = [subprocess.run([sys.executable, "-c", script, str(Path(__file__).parent)],
                           env={**os.environ, "OMP_NUM_THREADS": str(n), "OMP_WAIT_POLICY": "passive",
                                "PFMPM_ADAPTIVE_THREADS": "0"},
                           capture_output=True, text=True, timeout=300) for n in (1, 2)]
    assert all(r.returncode == 0 for r in runs), runs[0].stderr + runs[1].stderr
    assert runs[0].stdout == runs[1].stdout


# -- rotation and crack direction in a dynamic run ----------------------------


def notched_plate(turned: bool, h=0.5, L=8.0):
    """A square plate with an edge notch to its centre pulled apart at 1 MPa,
    cubic surface energy at 30 degrees; ``turned``: all of it turned 90 degrees
    counter-clockwise about the centre (so the orientation drops by 90)."""
    turn = (lambda p: (-p[1], p[0])) if turned else tuple
    edges = ("left", "right") if turned else ("top", "bottom")
    loads = tuple(Traction(body="plate", edge=e, traction=turn(t))
                  for e, t in zip(edges, ((0.0, 1.0), (0.0, -1.0))))
    cubic = Anisotropy("cubic", g1111=1.0, g1212=74.0)
    return Scene(
        grid=Grid(size=(2 * L + 2, 2 * L + 2), h=h, origin=(-L - 1, -L - 1)),
        time=Time(end=12.0), plane="strain",
        materials=(Material("c", 32000.0, 0.2, 2450.0,
                            fracture=Fracture(Gc=0.002121, l0=2 * h, anisotropy=cubic)),),
        bodies=(Body("plate", "c", Rectangle(min=(-L, -L), max=(L, L)),
                     orientation=30.0 - (90.0 if turned else 0.0)),),
        cracks=(Crack(points=(turn((-L, 0.0)), turn((0.0, 0.0)))),),
        loads=loads, phase_field=PhaseField(max_iterations=20000),
    )


def test_turning_the_problem_turns_the_crack():
    runs = []
    for turned in (False, True):
        sim = Simulation(notched_plate(turned))
        sim.advance(sim.scene.steps())
        runs.append((sim.particles.x.copy(), sim.particles.c.copy()))
    (xa, ca), (xb, cb) = runs
    back = np.column_stack([xb[:, 1], -xb[:, 0]])  # turn run b back, clockwise
    cracked_a, cracked_b = xa[ca < 0.2], back[cb < 0.2]
    assert len(cracked_a) > 20
    # Every cracked point of one run lies within a cell of a cracked point of the other.
    h = 0.5
    for p, q in ((cracked_a, cracked_b), (cracked_b, cracked_a)):
        gap = np.sqrt(((p[:, None, :] - q[None, :, :]) ** 2).sum(-1)).min(axis=1)
        assert gap.max() <= h
    # The crack leaves the notch along a weak direction of 1/G_c(theta).
    angle = propagation_angle(xa, ca, (0.0, 0.0), (1.0, 0.0), 1.0, 4.0, threshold=0.2) % 360.0
    weak = anisotropy.weak_directions(Anisotropy("cubic", g1111=1.0, g1212=74.0).matrix(), 30.0)
    assert np.min(np.abs((weak - angle + 180.0) % 360.0 - 180.0)) < 10.0


def test_crack_direction_measures_on_synthetic_cracks():
    """Two straight arms from a notch tip at (2, 1), at +35 and -50 degrees."""
    g = np.stack(np.meshgrid(np.arange(-10, 12, 0.1), np.arange(-10, 12, 0.1)), -1).reshape(-1, 2)
    tip = np.array([2.0, 1.0])
    c = np.ones(len(g))
    for deg in (35.0, -50.0):
        u = np.array([math.cos(math.radians(deg)), math.sin(math.radians(deg))])
        along, across = (g - tip) @ u, (g - tip) @ np.array([-u[1], u[0]])
        c[(along > 0) & (np.abs(across) < 0.15)] = 0.0
    notch = (g[:, 0] < tip[0]) & (np.abs(g[:, 1] - tip[1]) < 0.15)
    c[notch] = 0.0
    arms = crack_arms(g, c, tip, radius=5.0, width=0.2, threshold=0.2)
    assert sorted(arms) == pytest.approx([35.0, 180.0, 310.0], abs=1.0)
    single = np.where((g[:, 1] > tip[1] - 0.01) | notch, c, 1.0)  # only the +35 arm and the notch
    assert propagation_angle(g, single, tip, (1.0, 0.0), 1.0, 6.0, threshold=0.2) == pytest.approx(35.0, abs=1.0)
    assert math.isnan(propagation_angle(g, np.ones(len(g)), tip, (1.0, 0.0), 1.0, 6.0, threshold=0.2))


# -- input errors ------------------------------------------------------------


@pytest.mark.parametrize("table, path, words", [
    ({"symmetry": "hexagonal"}, "symmetry", "must be one of"),
    ({"symmetry": "cubic", "g1111": 1.0}, "g1212", "required for symmetry 'cubic'"),
    ({"symmetry": "cubic", "g1111": 1.0, "g1212": 2.0, "g2222": 3.0}, "g2222", "not used"),
    ({"symmetry": "orthotropic", "g1111": -1.0, "g2222": 1.0, "g1212": 1.0}, "g1111", ">= 0"),
    ({"symmetry": "general", "gamma": [[1, 0, 0], [0, 1, 0]]}, "gamma", "3 rows"),
    ({"symmetry": "general", "gamma": [[1, 2, 0], [0, 1, 0], [0, 0, 1]]}, "gamma", "symmetric"),
    ({"symmetry": "general", "gamma": [[1, 2, 0], [2, 1, 0], [0, 0, 1]]}, "gamma", "semi-definite"),
    ({"symmetry": "cubic", "g1111": 1.0, "g1212": 1.0, "g1122": -2.0}, "symmetry", "semi-definite"),
    ({"symmetry": "cubic", "g1111": 1.0, "g1212": 1.0, "colour": 3}, "colour", "unknown key"),
])
def test_bad_anisotropy_is_named(table, path, words):
    d = crack_strip(0.25, 1.0, None).to_dict()
    d["materials"][0]["fracture"]["anisotropy"] = table
    with pytest.raises(SceneError) as err:
        Scene.from_dict(d)
    assert f"materials[0].fracture.anisotropy.{path}" in str(err.value)
    assert words in str(err.value)


def test_fourth_order_needs_c1_splines():
    d = crack_strip(0.25, 1.0, Anisotropy("isotropic4")).to_dict()
    d["grid"]["degree"] = 1
    with pytest.raises(SceneError, match=r"materials\[0\]\.fracture\.anisotropy.*degree"):
        Scene.from_dict(d)
    grid = _core.Grid(1, [8, 8], 1.0, [0.0, 0.0])
    particles = _core.Particles(1)
    elastic = _core.LinearElastic(1.0, 0.2, 1.0, _core.Plane.strain, _core.Split.spectral)
    with pytest.raises(ValueError, match="degree must be >= 2"):
        _core.Solver(grid, particles, [elastic], 0.1,
                     [_core.Fracture(1.0, 2.0, 0.0, [[1, 0, 0], [0, 1, 0], [0, 0, 2]])])


@pytest.mark.parametrize("args, words", [
    (["--gamma", "1,0,0;0,1,0", "--gc-bar", "1"], "expected 3 rows"),
    (["--gamma", "1,0,0;0,1,x;0,0,1", "--gc-bar", "1"], "entry (2,3) = 'x'"),
    (["--gamma", "1,0,1;0,1,0;0,0,1", "--gc-bar", "1"], "symmetric"),
    (["--gamma", "1,0,0;0,1,0;0,0,1", "--gc-bar", "0"], "--gc-bar 0: must be > 0"),
])
def test_polar_command_rejects_bad_input(args, words, tmp_path, capsys):
    assert cli.main(["polar", *args, "--out", str(tmp_path / "p.csv")]) == 2
    assert words in capsys.readouterr().err
    assert not (tmp_path / "p.csv").exists()


def test_fem_path_refuses_the_fourth_order_term():
    from pfmpm.fem import FemSimulation

    with pytest.raises(SceneError, match=r"materials\[0\]\.fracture\.anisotropy.*second-order"):
        FemSimulation(crack_strip(0.25, 1.0, Anisotropy("cubic", g1111=1.0, g1212=2.0)))


def test_run_reports_an_unconverged_initial_solve_without_a_traceback(tmp_path):
    scene = Path(__file__).resolve().parents[1] / "demos" / "borden_cubic.toml"
    r = subprocess.run([sys.executable, "-m", "pfmpm.cli", "run", str(scene), "--out", str(tmp_path),
                        "--set", "grid.h=1.0", "--set", "materials.concrete.fracture.l0=2.0",
                        "--set", "phase_field.max_iterations=5"], capture_output=True, text=True)
    assert r.returncode == 1
    assert r.stderr.startswith("error: phase field: conjugate gradients stopped") and "after 5 iterations" in r.stderr
    assert "Traceback" not in r.stderr
