"""The Borden plate as a slab (src/pfmpm/scenes/borden_slab.toml) against
the 2D run it extrudes, and with free faces.

``--case plane`` runs the coarse 2D plate (h = 1 mm, l0 = 2 mm, 3 x 3
particles per cell) 4 mm thick, ``--case slab`` the slab between slip
walls, both to 80 us with dt = 0.09 us and the phase field solved to 1e-12
(so that the two differ by round-off, not by the solver's tolerance), one
row of energies.csv per step. ``--case free`` runs the slab without its
walls (the scene's dt and tolerance) and records, at 50, 65 and 80 us, the
crack front of each layer of particles through the thickness: the largest
x of a particle with c below the scene's crack threshold. ``--report``
compares: the largest relative gap of the slab's energies from the plane
run's until initiation (1e-10 asked) and after it, the initiation times,
the largest distance between the two runs' crack fronts along x through
80 us (one cell asked; the plane run records the front beside its tip, the
cracked point farthest from the notch tip, which is another point near the
notch and after the crack branches), the free slab's front per layer and its spread, and each
run's wall time and peak memory per particle; it writes
``OUT/benchmark_results.json`` for the page.

    OMP_NUM_THREADS=2 .venv/bin/python benchmarks/borden_slab/study.py --case plane --out out/borden_slab
    OMP_NUM_THREADS=2 .venv/bin/python benchmarks/borden_slab/study.py --case slab --out out/borden_slab
    OMP_NUM_THREADS=2 .venv/bin/python benchmarks/borden_slab/study.py --case free --out out/borden_slab
    .venv/bin/python benchmarks/borden_slab/study.py --report --out out/borden_slab
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

if str(Path(__file__).resolve().parents[2]) not in sys.path:  # run as a file: the root holds ``benchmarks``
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks.common import results as results_file  # noqa: E402
from pfmpm import Simulation, scenes  # noqa: E402
from pfmpm.bench import peak_rss_bytes, rss_bytes  # noqa: E402
from pfmpm.observe import CrackFrontObserver, default_observers  # noqa: E402
from pfmpm.output import read_csv  # noqa: E402
from pfmpm.post.tip import branch_time, initiation_time  # noqa: E402
from pfmpm.scene import Scene  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
DT, TOL, END = 0.09, 1e-12, 80.0
"""The fixed step and the solver tolerance of the plane and slab runs, and their end (us)."""
FRONT_TIMES = (50.0, 65.0, 80.0)
COMPARED = ("kinetic", "elastic", "fracture", "external_work", "total")
ENERGY_GAP, TIP_GAP = 1e-10, 1.0
"""The issue's bounds: relative energy gap until initiation, tip distance in cells (h = 1 mm)."""


def case_scene(case: str) -> Scene:
    """The scene of a case."""
    fixed = [f"time.dt={DT}", f"phase_field.tol={TOL}", f"time.end={END}", "output.energies_every=1",
             "output.particles=false"]
    if case == "plane":
        return Scene.from_toml(ROOT / "demos" / "borden_plate.toml",
                               ["grid.h=1.0", "materials.concrete.fracture.l0=2.0", "thickness=4.0",
                                "output.snapshots=[]", "output.crack_direction=[1.0, 0.0]", *fixed])
    slab = scenes.path("borden_slab")
    if case == "slab":
        return Scene.from_toml(slab, fixed)
    return Scene.from_toml(slab, ["walls=[]", "output.particles=false"])


def fronts(sim: Simulation, threshold: float) -> list[dict]:
    """The crack front of each layer of particles through the thickness: the
    largest x of its particles with c < threshold."""
    x, c = sim.particles.x, sim.particles.c
    z0 = np.round(sim.particles.x[:, 2] - sim.displacement()[:, 2], 6)  # the layer of the reference lattice
    rows = []
    for z in np.unique(z0):
        cracked = (z0 == z) & (c < threshold)
        rows.append({"z": float(z), "front_x": float(x[cracked, 0].max()) if cracked.any() else None})
    return rows


def run(case: str, out: Path) -> None:
    before = rss_bytes()
    scene = case_scene(case)
    start = time.perf_counter()
    record: dict = {"case": case}
    if case == "free":
        sim = Simulation(scene)
        record["particles"] = len(sim.particles)
        record["fronts"] = {}
        for t in FRONT_TIMES:
            sim.advance(int(round((t - sim.time) / scene.dt())))
            record["fronts"][f"{t:g}"] = fronts(sim, scene.output.crack_threshold)
    else:
        sim = Simulation(scene)
        record["particles"] = len(sim.particles)
        # The 2D run records the 3D front's measure too (the farthest cracked point along x).
        observers = default_observers(sim) + ([CrackFrontObserver(sim)] if case == "plane" else [])
        result = sim.run(out / case, progress=False, overwrite=True, observers=observers)
        record["status"] = result.status
    record["wall_s"] = time.perf_counter() - start
    peak = peak_rss_bytes()
    record["peak_bytes_per_particle"] = (peak - before) / record["particles"]
    (out / f"{case}.json").write_text(json.dumps(record, indent=1))
    print(json.dumps({k: v for k, v in record.items() if k != "fronts"}))


def report(out: Path) -> dict:
    a, b = read_csv(out / "plane" / "energies.csv"), read_csv(out / "slab" / "energies.csv")
    n = min(len(a["t"]), len(b["t"]))
    assert np.allclose(a["t"][:n], b["t"][:n], rtol=0, atol=1e-9), "the runs' rows differ in time"
    t_init = initiation_time(a)
    before = a["t"][:n] <= t_init
    gap = {k: np.abs(a[k][:n] - b[k][:n]) / np.abs(a[k][:n]).max() for k in COMPARED}
    gap_before = max(float(g[before].max()) for g in gap.values())
    gap_after = max(float(g.max()) for g in gap.values())
    # The 3D front against the same measure of the 2D run (the cracked point
    # farthest along x), and against the 2D tip (the one farthest from the
    # notch tip), a different point near the notch and after the branching.
    t_branch = branch_time(a, case_scene("plane").cracks[0])
    tip = np.abs(a["crack_front_x"][:n] - b["crack_front_x"][:n])
    other = np.abs(a["crack_tip_x"][:n] - b["crack_front_x"][:n])
    runs = {c: json.loads((out / f"{c}.json").read_text()) for c in ("plane", "slab", "free")}
    free = runs["free"]["fronts"]
    spread = {t: max(r["front_x"] for r in rows) - min(r["front_x"] for r in rows) for t, rows in free.items()}
    rows = [
        ["energies.csv, slab against plane, until initiation", f"{gap_before:.1e}", f"<= {ENERGY_GAP:g}",
         "pass" if gap_before <= ENERGY_GAP else "fail"],
        ["energies.csv, through 80 us", f"{gap_after:.1e}", "", ""],
        ["initiation, plane / slab (us)", f"{t_init:.3f} / {initiation_time(b):.3f}", "", ""],
        ["crack front along x, slab against plane, largest distance through 80 us (mm)", f"{tip.max():.2e}",
         f"<= {TIP_GAP:g} cell", "pass" if tip.max() <= TIP_GAP else "fail"],
        [f"the 2D tip (farthest from the notch tip) against the slab's front, through 80 us (branching at"
         f" {t_branch:.2f} us) (mm)", f"{other.max():.3f}", "", ""],
        ["fracture energy at 80 us, plane / slab (mJ)", f"{a['fracture'][n - 1]:.5f} / {b['fracture'][n - 1]:.5f}",
         "", ""],
    ]
    for t, rows_t in free.items():
        xs = ", ".join(f"{r['front_x']:.2f}" for r in rows_t)
        rows.append([f"free faces, front x per layer at {t} us (z = 0 .. 4)", xs,
                     f"spread {spread[t]:.2f} mm", ""])
    for c, r in runs.items():
        rows.append([f"{c}: particles, wall time (s), peak bytes per particle",
                     f"{r['particles']}, {r['wall_s']:.0f}, {r['peak_bytes_per_particle']:.0f}", "", ""])
    table = results_file.table(["check", "value", "bound", "verdict"], rows)
    results_file.write(out, "borden_slab", "docs/verification/borden-slab.md", __file__, None, {"slab": table})
    for row in rows:
        print(" | ".join(row))
    return {"gap_before": gap_before, "tip": float(tip.max())}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", choices=["plane", "slab", "free"])
    parser.add_argument("--report", action="store_true")
    parser.add_argument("--out", type=Path, default=Path("out/borden_slab"))
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.case:
        run(args.case, args.out)
    if args.report:
        report(args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
