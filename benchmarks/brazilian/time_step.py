"""Dynamic Brazilian disk: the time step the scene needs (a diagnostic).

pfmpm fixes dt at t = 0 from ``time.cfl`` and stops a run once some
particle's P-wave speed plus speed, c_p + |v_p|, exceeds kappa h / dt (the
Courant number dt (c_p + |v_p|) / (kappa h) above 1). This script runs the
scene (damage gradient, or ``--single-field``) at one resolution with that
check switched off and prints, every ``--every`` us, the largest Courant
number so far, the particle that sets it (damage D, J, the squared
principal stretches b1 >= b2 of B = F F^T), the energies and the fully
damaged fraction of the disk. A run at ``time.cfl = a`` with the check on
stops about when the printed Courant number, times a over this run's cfl,
passes 1. Writes ``time_step_<method>_h<h>.csv`` to ``--out``.

    .venv/bin/python benchmarks/brazilian/time_step.py --h 0.1875 --out out/brazilian_dt
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import numpy as np

if str(Path(__file__).resolve().parents[2]) not in sys.path:  # run as a file: the root holds ``benchmarks``
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks.brazilian.measure import failed_fraction  # noqa: E402
from benchmarks.common.self_contact import body_fields  # noqa: E402
from pfmpm import scenes  # noqa: E402
from pfmpm.scene import Scene  # noqa: E402
from pfmpm.simulation import Simulation  # noqa: E402

SEEDS = {0.1875: 1, 0.09375: 2, 0.0625: 3}
"""The Weibull seed of each resolution (the scene's comments)."""


def principal_b(F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The eigenvalues b1 >= b2 of B = F F^T per particle (F as xx, xy, yx, yy)."""
    bxx, byy = F[:, 0] ** 2 + F[:, 1] ** 2, F[:, 2] ** 2 + F[:, 3] ** 2
    bxy = F[:, 0] * F[:, 2] + F[:, 1] * F[:, 3]
    mean, radius = (bxx + byy) / 2, np.hypot((bxx - byy) / 2, bxy)
    return mean + radius, mean - radius


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--h", type=float, default=0.1875, choices=sorted(SEEDS))
    parser.add_argument("--single-field", action="store_true", help="contact.partition = bodies")
    parser.add_argument("--every", type=float, default=1.0, help="us between rows")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--out", default="out/brazilian_dt")
    args = parser.parse_args(argv)
    scene = Scene.from_toml(scenes.path("brazilian"),
                            [f"grid.h={args.h}", f"materials.ceramic.damage.weibull.seed={SEEDS[args.h]}"]
                            + args.set)
    if args.single_field:
        scene = body_fields(scene)
    method = "single_field" if args.single_field else "damage_gradient"
    sim = Simulation(scene)
    sim.solver.set_stability_length(0.0)  # the diagnostic: follow the speeds past the limit
    p, dt, length = sim.particles, scene.dt(), scene.critical_length()
    rows, worst, steps = [], 0.0, scene.steps()
    marks = [min(steps, int(round(k * args.every / dt)))
             for k in range(1, int(np.ceil(scene.time.end / args.every - 1e-9)) + 1)]
    print(f"{method} h = {args.h}: {len(p)} particles, dt = {dt:.4g}, {steps} steps, cfl {scene.time.cfl}")
    for mark in marks:
        while sim.step < mark:
            sim.advance(min(10, mark - sim.step))
            worst = max(worst, sim.solver.fastest_signal())
        speed = np.hypot(p.v[:, 0], p.v[:, 1])
        b1, b2 = principal_b(p.F)
        e = sim.energies()
        row = {"t": sim.time, "courant_max": dt * worst / length,
               "courant_now": dt * sim.solver.fastest_signal() / length,
               "finite": bool(np.isfinite(p.x).all() and np.isfinite(p.v).all()),
               "failed_fraction": failed_fraction(scene, p),
               "b1_max": float(b1.max()), "b2_min": float(b2.min()),
               "b1_max_intact": float(b1[p.damage < 1.0].max()),
               "speed_max": float(speed.max())}
        row.update({k: e[k] for k in ("kinetic", "elastic", "external_work", "damage_dissipation",
                                      "friction_dissipation", "total")})
        rows.append(row)
        i = int(np.argmax(b1))
        print(f"t {row['t']:6.2f}  Courant max {row['courant_max']:.3f} now {row['courant_now']:.3f}"
              f"  b1 max {row['b1_max']:.4g} (D {p.damage[i]:.3f}, J {p.J[i]:.3f}, b2 {b2[i]:.3g})"
              f"  b1 max of D < 1 {row['b1_max_intact']:.3g}  failed {row['failed_fraction']:.3f}"
              f"  kinetic {e['kinetic']:.4g} elastic {e['elastic']:.4g} work {e['external_work']:.4g}"
              f" total {e['total']:.4g}", flush=True)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / f"time_step_{method}_h{args.h}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return rows


if __name__ == "__main__":
    main()
