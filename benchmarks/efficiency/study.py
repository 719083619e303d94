"""The efficiency study of Homel & Herbold 2017, section 3.5 and Fig. 19
(shared/benchmarks-homel-herbold.md section 7, checks E1-E5): wall time per
step of the Brazilian disk against particle count, with damage-gradient
partitioning (DFG) and without (SF), on 1 and 2 threads, per stage
(benchmarks.efficiency.measure; docs/performance/efficiency.md).

    .venv/bin/python benchmarks/efficiency/study.py [SCENE] [--k 1 1.5 2 3 4] [--steps 200]
        [--warmup 50] [--rounds 3] [--threads 1 2] [--paint-time 10 | --no-paint]
        [--until T] [--set KEY=VALUE ...] [--out out/efficiency] [--smoke]

SCENE defaults to the shipped ``brazilian`` scene; spacing h = h0 / k with h0
its grid.h. Writes OUT/efficiency.csv (one row per timed run, as it goes),
OUT/checks.json (E1-E5 on wall and on CPU time), OUT/fig19.png and the
tables of docs/performance/efficiency.md (OUT/benchmark_results.json,
benchmarks.common.results), and prints the medians and checks.
``--smoke`` is the suite's (tests/test_efficiency.py, on the coarse disk of
tests/data/efficiency_disk.toml): two sizes, a few steps, one round.
"""

import argparse
import json
import sys
from pathlib import Path

if str(Path(__file__).resolve().parents[2]) not in sys.path:  # run as a file: the root holds ``benchmarks``
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks.common import results  # noqa: E402
from benchmarks.efficiency import measure as efficiency  # noqa: E402
from pfmpm import scenes  # noqa: E402
from pfmpm.scene import Scene, SceneError  # noqa: E402


def tables(rows, wall: dict, cpu: dict) -> dict:
    """The tables of docs/performance/efficiency.md: ``sizes``, the medians
    (ms per step, wall) per size, partition and thread count, and ``checks``,
    E1-E5 with their limits."""
    m = efficiency.medians(rows)
    k = {int(r["particles"]): float(r["k"]) for r in efficiency._as_rows(rows)}
    threads = sorted({t for _, _, t in m})
    sizes = sorted({n for n, _, _ in m})

    def ms(n, d, t):
        return f"{1e3 * m[(n, d, t)]['seconds']:.2f}" if (n, d, t) in m else ""

    def ratio(n, t, time="seconds"):
        both = (n, 1, t) in m and (n, 0, t) in m
        return f"{m[(n, 1, t)][time] / m[(n, 0, t)][time]:.2f}" if both else ""

    columns, body = ["k", "particles"], []
    for t in threads:
        name = f"{t} thread" + ("s" if t > 1 else "")
        columns += [f"SF, {name}", f"DFG, {name}", "DFG/SF wall (CPU)" if t == 1 else "DFG/SF"]
    columns += ["DFG blocks share, 1 thread (gradient, Alg. 1-2)", "neighbours share", "kernel fields per step"]
    for n in sizes:
        cells = [f"{k[n]:g}", f"{n:,}"]
        for t in threads:
            cells += [ms(n, 0, t), ms(n, 1, t),
                      f"{ratio(n, t)} ({ratio(n, t, 'cpu_seconds')})" if t == 1 and ratio(n, t) else ratio(n, t)]
        v = m.get((n, 1, 1))
        if v:
            cells += [f"{100 * sum(v[b] for b in efficiency.DFG_BLOCKS) / v['seconds']:.0f} % "
                      f"({100 * v['gradient'] / v['seconds']:.0f}, {100 * v['partition'] / v['seconds']:.0f})",
                      f"{100 * v['neighbours'] / v['seconds']:.3f} %", f"{v['evaluated']:,.0f}"]
        else:
            cells += ["", "", ""]
        body.append(cells)

    def status(check):
        passed = wall[check]["passed"]
        return "cannot tell" if passed is None else "met" if passed else "**not met**"

    def inside(c):
        return {n: r for n, r in c["E2"]["per_size"].items() if efficiency.E2_RANGE[0] < n < efficiency.E2_RANGE[1]}

    e1, e3, e4, e5 = wall["E1"], wall["E3"], wall["E4"], wall["E5"]
    checks = [
        ["E1 neighbour lists (staleness checks and builds) / step, DFG, every size",
         "" if e1["value"] is None else f"at most {100 * e1['value']:.2f} %", "1 %", status("E1")],
        ["E2 DFG / SF, one thread, 3.2e4 < n_p < 1.5e5",
         "wall " + " / ".join(f"{r:.2f}" for r in inside(wall).values()) + "; CPU "
         + " / ".join(f"{r:.2f}" for r in inside(cpu).values())
         + " (" + " / ".join(f"{n / 1e3:.0f}k" for n in inside(wall)) + ")", "1.6", status("E2")],
        ["E3 slope of the particle DFG block (`gradient`) against n_p",
         "" if e3["value"] is None else f"{e3['value']:.2f}", "0.9-1.15", status("E3")],
        [f"E4 DFG blocks / DFG step at the largest size ({(e4['particles'] or 0) / 1e3:.0f}k)",
         "" if e4["value"] is None else f"{100 * e4['value']:.0f} %", "40 %", status("E4")],
        ["E5 positions and velocities after the run, 1 vs 2 threads, every size and partition",
         f"{e5['compared'] - e5['value']} of {e5['compared']} the same bits", "bitwise", status("E5")],
    ]
    return {"sizes": results.table(columns, body),
            "checks": results.table(["check", "measured", "limit", "status"], checks)}


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
    results.write(a.out, "efficiency", "docs/performance/efficiency.md", __file__, argv, tables(rows, result, cpu))
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
