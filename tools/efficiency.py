"""The efficiency study of Homel & Herbold 2017, section 3.5 and Fig. 19
(shared/benchmarks-homel-herbold.md section 7, checks E1-E5): wall time per
step of the Brazilian disk against particle count, with damage-gradient
partitioning (DFG) and without (SF), on 1 and 2 threads, per stage
(pfmpm.post.efficiency; docs/performance/efficiency.md).

    .venv/bin/python tools/efficiency.py [SCENE] [--k 1 1.5 2 3 4] [--steps 200]
        [--warmup 50] [--rounds 3] [--threads 1 2] [--paint-time 10 | --no-paint]
        [--until T] [--set KEY=VALUE ...] [--out out/efficiency] [--smoke]

SCENE defaults to the shipped ``brazilian`` scene; spacing h = h0 / k with h0
its grid.h. Writes OUT/efficiency.csv (one row per timed run, as it goes),
OUT/checks.json (E1-E5 on wall and on CPU time) and OUT/fig19.png, and prints the medians and checks.
``--smoke`` is the suite's (tests/test_efficiency.py, on the coarse disk of
tests/data/efficiency_disk.toml): two sizes, a few steps, one round.
"""

import argparse
import json
import sys
from pathlib import Path

from pfmpm import scenes
from pfmpm.post import efficiency
from pfmpm.scene import Scene, SceneError


def parse(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene", nargs="?", help="scene file (default: the shipped brazilian scene)")
    p.add_argument("--k", type=float, nargs="+", default=[1, 1.5, 2, 3, 4],
                   help="refinements: spacing h0 / k")
    p.add_argument("--h0", type=float, help="the spacing at k = 1 (default: the scene's grid.h)")
    p.add_argument("--steps", type=int, default=200, help="timed steps per run")
    p.add_argument("--warmup", type=int, default=50, help="steps before the timed ones")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    p.add_argument("--paint-time", type=float, default=10.0,
                   help="start every run from the damage of a DFG run at the coarsest size at this time")
    p.add_argument("--no-paint", action="store_true", help="start from t = 0 as the scene is")
    p.add_argument("--until", type=float,
                   help="time from the warm-up to this time instead of --steps steps (with --no-paint: "
                        "the whole run, the paper's measure)")
    p.add_argument("--interleave", type=int, metavar="N",
                   help="advance the two partitions' runs N steps at a time in turn, in one "
                        "process (a slow drift of the machine then falls on both)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="scene override")
    p.add_argument("--out", type=Path, default=Path("out/efficiency"))
    p.add_argument("--smoke", action="store_true",
                   help="k = 1 and 1.5, 2 + 3 steps, one round, paint at 4 us")
    a = p.parse_args(argv)
    if a.interleave is not None and a.interleave < 1:
        p.error(f"--interleave = {a.interleave}: must be at least 1 step")
    if a.smoke:
        a.k, a.warmup, a.steps, a.rounds, a.paint_time = [1.0, 1.5], 2, 3, 1, 4.0
    return a


def main(argv=None) -> dict:
    a = parse(argv)
    try:
        path = Path(a.scene) if a.scene else scenes.path("brazilian")
        scene = Scene.from_toml(path, a.set)
    except (FileNotFoundError, SceneError) as err:
        sys.exit(f"efficiency: {err}")
    h0 = a.h0 or scene.grid.h
    a.out.mkdir(parents=True, exist_ok=True)

    def progress(row):
        print(f"round {row['round']} k = {row['k']:g}: {row['particles']} particles, "
              f"{efficiency.METHODS[row['dfg']].upper()} on {row['threads']} thread(s): "
              f"{1e3 * row['seconds']:.2f} ms/step (load {row['load']:.1f})", flush=True)

    rows = efficiency.study(scene, a.k, h0, steps=a.steps, warmup=a.warmup, rounds=a.rounds,
                            threads=a.threads, paint_time=None if a.no_paint else a.paint_time,
                            csv_path=a.out / "efficiency.csv", progress=progress, until=a.until,
                            chunk=a.interleave)
    result = efficiency.checks(rows)
    cpu = efficiency.checks(rows, time="cpu_seconds")
    (a.out / "checks.json").write_text(json.dumps({"wall": result, "cpu": cpu}, indent=2, default=str) + "\n")
    efficiency.figure(rows, a.out / "fig19.png")
    print("\nmedians, ms per step: particles, method, threads: total | " + " ".join(efficiency.STAGES)
          + " | " + " ".join(efficiency.DFG_BLOCKS) + " | kernel fields per step")
    for (n, d, t), v in efficiency.medians(rows).items():
        print(f"{n:8d} {efficiency.METHODS[d]:3s} {t}: {1e3 * v['seconds']:8.3f} | "
              + " ".join(f"{1e3 * v[s]:.3f}" for s in efficiency.STAGES) + " | "
              + " ".join(f"{1e3 * v[b]:.3f}" for b in efficiency.DFG_BLOCKS) + f" | {v['evaluated']:.0f}")
    for name in ("E1", "E2", "E3", "E4", "E5"):
        print(f"{name}: {result[name]}")
    print(f"slopes: {result['slopes']}")
    print(f"on CPU time: E2 {cpu['E2']}, slopes {cpu['slopes']}")
    return result


if __name__ == "__main__":
    main()
