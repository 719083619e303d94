"""Solve pfmpm's phase-field systems with PETSc's algebraic multigrid, for the record.

Runs a scene with ``phase_field.preconditioner = "multigrid"`` to a time T,
exports the systems K c = F of the cold first solve and of the last step
(``Solver.phase_field_system``), and solves each with PETSc CG preconditioned
by Jacobi, GAMG and hypre BoomerAMG (when this PETSc has hypre) from the start
pfmpm used (c = 1 cold; the last two solutions extrapolated in time warm), to
the same stopping rule ||F - K c|| <= tol ||F||. Prints a Markdown table of
iterations and seconds (setup, solve; medians of three) beside pfmpm's
iterations on the same systems. PETSc is used here only, never by the MPM core.

    OMP_NUM_THREADS=1 .venv/bin/python tools/amg_comparison.py demos/borden_orthotropic.toml \\
        --time 15 [--set KEY=VALUE ...] [--save systems.npz]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from pfmpm.scene import Scene
from pfmpm.simulation import Simulation


def export(scene_path: str, t: float, overrides: list[str]):
    """The cold system and the last step's, each as (K parts, F, start, pfmpm iterations)."""
    scene = Scene.from_toml(scene_path, overrides=overrides + ["phase_field.preconditioner=multigrid"])
    sim = Simulation(scene)
    cold = sim.solver.phase_field_system()
    cold_iterations = sim.solver.phase_field_stats()["last_iterations"]
    steps = max(int(round(t / scene.dt())), 3)
    sim.advance(steps - 2)
    before = sim.solver.phase_field_system()
    sim.advance(1)
    last = sim.solver.phase_field_system()
    sim.advance(1)
    warm = sim.solver.phase_field_system()
    warm_iterations = sim.solver.phase_field_stats()["last_iterations"]
    # The warm start: 2 c_n - c_{n-1} on the grid nodes (a node active in neither keeps c = 1).
    nodes = scene.grid.cells[0] + scene.grid.degree, scene.grid.cells[1] + scene.grid.degree
    grids = []
    for d in (before, last):
        g = np.ones(nodes[0] * nodes[1])
        g[d["nodes"]] = d["solution"]
        grids.append(g)
    start = (2.0 * grids[1] - grids[0])[warm["nodes"]]
    return scene, {"cold": (cold, np.ones(len(cold["rhs"])), cold_iterations),
                   "warm": (warm, start, warm_iterations)}


def petsc_solve(system: dict, start: np.ndarray, pc: str, tol: float):
    """Iterations, setup and solve seconds (medians of three) of PETSc CG with `pc`."""
    from petsc4py import PETSc
    n = len(system["rhs"])
    A = PETSc.Mat().createAIJ(size=(n, n), csr=(system["row_start"].astype(PETSc.IntType),
                                                system["column"].astype(PETSc.IntType),
                                                system["value"]), comm=PETSc.COMM_SELF)
    A.setOption(PETSc.Mat.Option.SPD, True)
    b = PETSc.Vec().createWithArray(system["rhs"].copy(), comm=PETSc.COMM_SELF)
    runs = []
    for _ in range(3):
        ksp = PETSc.KSP().create(comm=PETSc.COMM_SELF)
        ksp.setType("cg")
        ksp.setOperators(A)
        ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
        ksp.setTolerances(rtol=tol, atol=0.0, max_it=100000)  # ||r|| <= tol ||b||
        ksp.setInitialGuessNonzero(True)
        ksp.getPC().setType("hypre" if pc == "boomeramg" else pc)
        if pc == "boomeramg":
            ksp.getPC().setHYPREType("boomeramg")
        x = PETSc.Vec().createWithArray(start.copy(), comm=PETSc.COMM_SELF)
        t0 = time.perf_counter()
        ksp.setUp()
        t1 = time.perf_counter()
        ksp.solve(b, x)
        t2 = time.perf_counter()
        runs.append((ksp.getIterationNumber(), t1 - t0, t2 - t1, int(ksp.getConvergedReason())))
        ksp.destroy()
    its = runs[0][0]
    return its, statistics.median(r[1] for r in runs), statistics.median(r[2] for r in runs), runs[0][3]


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene")
    parser.add_argument("--time", type=float, required=True, help="the warm system is that of this time")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--save", help="also write the systems to this .npz file")
    args = parser.parse_args(argv)
    from petsc4py import PETSc
    scene, systems = export(args.scene, args.time, args.set)
    tol = scene.phase_field.tol
    if args.save:
        np.savez(args.save, **{f"{name}_{key}": value for name, (d, start, _) in systems.items()
                               for key, value in {**d, "start": start}.items()})
    pcs = ["jacobi", "gamg"] + (["boomeramg"] if PETSc.Sys.hasExternalPackage("hypre") else [])
    print(f"{scene.name}, t = {args.time}, tol = {tol}, PETSc {'.'.join(map(str, PETSc.Sys.getVersion()))}")
    print("| system | unknowns | pfmpm multigrid iterations | PETSc CG + PC | iterations | setup s | solve s |")
    print("|---|---|---|---|---|---|---|")
    for name, (d, start, ours) in systems.items():
        for pc in pcs:
            its, setup, solve, reason = petsc_solve(d, start, pc, tol)
            note = "" if reason > 0 else f" (not converged: reason {reason})"
            print(f"| {name} | {len(d['rhs'])} | {ours} | {pc} | {its}{note} | {setup:.4f} | {solve:.4f} |")


if __name__ == "__main__":
    main()
