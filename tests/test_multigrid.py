"""The multigrid preconditioner of the phase-field CG (``phase_field.preconditioner``)
and the export of the assembled system (``Solver.phase_field_system``)."""

import dataclasses

import numpy as np
import pytest
import scipy.sparse as sp

from pfmpm.scene import PhaseField
from pfmpm.simulation import Simulation
from test_anisotropy import notched_plate


def with_solver(scene, **settings):
    return dataclasses.replace(scene, phase_field=dataclasses.replace(scene.phase_field, **settings))


def system(sim):
    """K (scipy CSR), F and c of the last solve."""
    d = sim.solver.phase_field_system()
    n = len(d["nodes"])
    K = sp.csr_matrix((d["value"], d["column"], d["row_start"]), shape=(n, n))
    return K, d["rhs"], d["solution"]


@pytest.mark.parametrize("fourth", [False, True])
def test_exported_system_is_the_one_solved(fourth):
    """K is symmetric, c meets the tolerance, and without history every row of
    K sums to its F (the gradient terms vanish on a partition of unity, eq. 57),
    so c = 1 solves it. (Second order without the bound: the bounded solve's
    c meets K c = F only on its free nodes.)"""
    scene = with_solver(notched_plate(False), tol=1e-8)
    if not fourth:
        scene = dataclasses.replace(scene, materials=(dataclasses.replace(
            scene.materials[0], fracture=dataclasses.replace(scene.materials[0].fracture,
                                                             anisotropy=None, bound=False)),))
    sim = Simulation(scene)
    K, F, c = system(sim)
    assert K.shape == (1156, 1156) and abs(K - K.T).max() == 0.0
    assert np.linalg.norm(F - K @ c) <= 1e-8 * np.linalg.norm(F)
    assert c.min() < 0.1  # the notch
    plain = Simulation(dataclasses.replace(scene, cracks=()))
    K0, F0, c0 = system(plain)
    assert np.abs(K0 @ np.ones(len(F0)) - F0).max() <= 1e-12 * abs(K0).max()
    np.testing.assert_allclose(c0, 1.0, rtol=0, atol=1e-12)


def cold_solve(preconditioner, tol):
    sim = Simulation(with_solver(notched_plate(False), tol=tol, max_iterations=20000,
                                 preconditioner=preconditioner))
    return sim.particles.c.copy(), sim.solver.phase_field_stats()


def test_multigrid_cold_solve_takes_a_tenth_of_the_gauss_seidel_iterations():
    """The cold solve of the notched plate (1156 unknowns, cubic gamma_1212 = 74
    at 30 degrees): 774 Jacobi and 240 Gauss-Seidel iterations, 13 with the
    V-cycle, whose c agrees with a 1e-12 solve's to 3e-9."""
    c, stats = cold_solve("multigrid", 1e-6)
    _, ssor = cold_solve("ssor", 1e-6)
    tight, tight_stats = cold_solve("jacobi", 1e-12)
    assert stats["fourth_order"] and stats["unknowns"] == 1156
    assert stats["last_iterations"] <= 20
    assert ssor["last_iterations"] >= 10 * stats["last_iterations"]
    assert tight_stats["last_residual"] <= 1e-12
    assert np.abs(c - tight).max() < 1e-7


def test_multigrid_run_stays_within_the_tolerance_of_gauss_seidel():
    """Five steps of the notched plate pulled apart: the phase field and the
    energies of a multigrid run agree with a Gauss-Seidel run's to the solver
    tolerance (measured: c to 3.4e-7, the energies to 3e-8), with 6.8
    iterations per solve against 137."""
    runs = {}
    for preconditioner in ("ssor", "multigrid"):
        sim = Simulation(with_solver(notched_plate(False), preconditioner=preconditioner))
        sim.advance(5)
        runs[preconditioner] = (sim.particles.c.copy(), sim.energies(), sim.solver.phase_field_stats())
    (c, e, s), (cm, em, sm) = runs["ssor"], runs["multigrid"]
    assert np.abs(c - cm).max() < 3e-6
    assert em["fracture"] == pytest.approx(e["fracture"], rel=1e-6)
    assert em["elastic"] == pytest.approx(e["elastic"], rel=1e-6)
    assert sm["iterations"] / sm["solves"] < 10 < s["iterations"] / s["solves"]


def test_the_default_preconditioner_of_the_fourth_order_model_is_multigrid():
    assert PhaseField().preconditioner == "automatic"
    default = Simulation(notched_plate(False))
    explicit = Simulation(with_solver(notched_plate(False), preconditioner="multigrid"))
    assert np.array_equal(default.particles.c, explicit.particles.c)
    assert default.solver.phase_field_stats() == explicit.solver.phase_field_stats()
