"""Generated two-body impacts for the bounded phase-field solve (issue 49):
a steel disk strikes a smaller glass disk that can crack (AT2 or AT1, the
bound 0 <= c <= 1 on), head-on or glancing, in plane strain, with Coulomb
contact. Each seed draws the radii, speed (20-200 m/s), offset, gap,
friction, l0 (1-2 h), Gc, Poisson ratio, energy split, B-spline degree (2
or 3) and Courant number; the run lasts until the disks have met and the
stress waves have crossed them a few times. Units mm, us, MPa.

Prints one line per run (finished, steps, phase-field solves, CG
iterations, active-set passes, hand-overs to MPRGP, seconds in the phase
field and in all) and a summary; ``--csv`` writes the lines as a table.

    OMP_NUM_THREADS=1 .venv/bin/python tools/impacts.py --seeds 0:100 --models AT2 AT1
"""

from __future__ import annotations

import argparse
import csv
import math
import time

import numpy as np

from pfmpm.scene import Scene
from pfmpm.simulation import Simulation

FIELDS = ["seed", "model", "finished", "steps", "solves", "iterations", "passes", "handovers",
          "phase_field_s", "wall_s", "error"]


def scene(seed: int, model: str, cfl_scale: float = 1.0) -> dict:
    """The scene of `seed` as a dict (Scene.from_dict), its glass disk of
    `model`, its Courant number times `cfl_scale` (to run an older pfmpm at
    today's step)."""
    r = np.random.default_rng(seed)
    h = 0.5
    R1, R2 = r.uniform(6, 10), r.uniform(3, 6)
    speed = r.uniform(0.02, 0.2)
    offset = r.uniform(-0.8, 0.8) * (R1 + R2)
    gap = r.uniform(0.5, 2.0)
    H = 2 * max(R1, R2) + abs(offset) + 12
    c1 = (R1 + 4, H / 2 - offset / 2)
    reach = R1 + R2 + gap
    dx = math.sqrt(max(reach**2 - offset**2, 0.1 * reach**2))
    c2 = (c1[0] + dx, H / 2 + offset / 2)
    W = max(2 * (R1 + R2) + 12, c2[0] + R2 + 4)
    l0 = r.choice([1.0, 1.5, 2.0]) * h
    return {
        "name": f"impact-{seed}-{model}", "plane": "strain", "units": "mm-us-MPa",
        "grid": {"size": [math.ceil(W / h) * h, math.ceil(H / h) * h], "h": h,
                 "degree": int(r.choice([2, 2, 3]))},
        "time": {"end": gap / (2 * speed) + 3 * (R1 + R2) / 5.0, "cfl": cfl_scale * float(r.uniform(0.3, 0.8))},
        "output": {"every": 10**6, "energies_every": 10**6},
        "phase_field": {"tol": 1e-6},
        "contact": {"friction": float(r.uniform(0, 0.5))},
        "materials": [
            {"name": "steel", "E": 200000.0, "nu": 0.3, "density": 7800.0},
            {"name": "glass", "E": 32000.0, "nu": float(r.uniform(0.1, 0.3)), "density": 2450.0,
             "fracture": {"Gc": float(r.uniform(0.001, 0.01)), "l0": float(l0), "model": model,
                          "split": str(r.choice(["spectral", "volumetric_deviatoric"]))}}],
        "bodies": [
            {"name": "steel", "material": "steel", "particles_per_cell": 2, "velocity": [speed, 0.0],
             "shape": {"type": "disk", "center": list(c1), "radius": R1}},
            {"name": "glass", "material": "glass", "particles_per_cell": 2, "velocity": [-speed, 0.0],
             "shape": {"type": "disk", "center": list(c2), "radius": R2}}],
    }


def run(seed: int, model: str, chunk: int = 200, cfl_scale: float = 1.0) -> dict:
    """Run the impact of `seed` to its end, or to the error that stops it."""
    sim = Simulation(Scene.from_dict(scene(seed, model, cfl_scale)))
    steps = sim.scene.steps()
    start, error = time.perf_counter(), ""
    try:
        while sim.step < steps:
            sim.advance(min(chunk, steps - sim.step))
    except Exception as err:  # the run's own one-line error, reported as a row
        error = str(err)
    stats = sim.solver.phase_field_stats()
    return {"seed": seed, "model": model, "finished": not error, "steps": sim.step,
            "solves": stats["solves"], "iterations": stats["iterations"], "passes": stats["passes"],
            "handovers": stats.get("handovers", 0),
            "phase_field_s": round(sim.solver.stage_seconds()["phase_field"], 3),
            "wall_s": round(time.perf_counter() - start, 3), "error": error}


def seeds(text: str) -> range:
    first, _, last = text.partition(":")
    return range(int(first), int(last)) if last else range(int(first), int(first) + 1)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=seeds, default=seeds("0:100"), help="FIRST:LAST (LAST excluded)")
    p.add_argument("--models", nargs="+", default=["AT2", "AT1"], choices=["AT2", "AT1"])
    p.add_argument("--csv", help="write the rows to this file")
    p.add_argument("--cfl-scale", type=float, default=1.0,
                   help="scale every Courant number (0.577 runs a pfmpm from before issue 49 at today's step)")
    args = p.parse_args(argv)
    rows = []
    for seed in args.seeds:
        for model in args.models:
            row = run(seed, model, cfl_scale=args.cfl_scale)
            rows.append(row)
            print(" ".join(f"{k}={row[k]}" for k in FIELDS if k != "error"), row["error"], flush=True)
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            writer = csv.DictWriter(f, FIELDS)
            writer.writeheader()
            writer.writerows(rows)
    done = [r for r in rows if r["finished"]]
    solves = sum(r["solves"] for r in rows)
    print(f"{len(done)} of {len(rows)} finished; {sum(r['handovers'] for r in rows)} hand-overs in "
          f"{solves} solves; {sum(r['iterations'] for r in rows) / max(solves, 1):.1f} iterations a solve; "
          f"phase field {sum(r['phase_field_s'] for r in rows):.1f} s of {sum(r['wall_s'] for r in rows):.1f} s")
    return 0 if len(done) == len(rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
