"""A steel sphere fragmenting a thick alumina disk (Homel & Herbold 2017,
section 4, Fig. 20) at two resolutions, with its checks.

``--h H`` runs the scene (src/pfmpm/scenes/sphere_disk.toml) at ``grid.h =
H`` with that resolution's Weibull seed (:data:`SEEDS`) as ``pfmpm run``
(checkpoints every 500 steps) under ``/usr/bin/time -v`` into ``OUT/h<H>``,
unless that folder holds the completed run already (``--resume`` continues
a stopped one), then measures it (:mod:`benchmarks.sphere_disk.measure`) and
writes ``OUT/h<H>.json``:

- the momentum's largest change over the impact momentum (<= 1e-10: no walls,
  no loads);
- the energy balance: 1 - (kinetic + elastic + damage + friction) / KE0 at
  the end and its largest over the run (the issue asks 2 %);
- the fragments of the disk's intact particles at the end (D <= 1e-6, and
  D below full damage): count, largest, d50 (mass-weighted median size);
- the particles of one piece inside another (pieces from the reference
  configuration; none allowed) and the closest approach of two pieces;
- the run's wall time and peak memory (maximum resident set size);
- a picture of the fragments, ``OUT/fragments_h<H>.png``.

``--bitwise`` runs the coarse scene to ``--bitwise-end`` us on 1 and on 2
threads and against itself resumed from a checkpoint halfway, and compares
the bits (``OUT/bitwise.json``). ``--report`` makes the table of every
``h*.json`` and ``bitwise.json``, the d50 ratio across the resolutions
(<= 1.5 asked), ``OUT/sphere_disk_fragments.png`` (the cumulative
distributions) and ``OUT/benchmark_results.json``.

    OMP_NUM_THREADS=2 .venv/bin/python benchmarks/sphere_disk/study.py --h 1.0 --out out/sphere_disk
    OMP_NUM_THREADS=2 .venv/bin/python benchmarks/sphere_disk/study.py --h 0.5 --out out/sphere_disk
    OMP_NUM_THREADS=2 .venv/bin/python benchmarks/sphere_disk/study.py --bitwise --out out/sphere_disk
    .venv/bin/python benchmarks/sphere_disk/study.py --report --out out/sphere_disk
"""

from __future__ import annotations

import argparse
import json
import math
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

if str(Path(__file__).resolve().parents[2]) not in sys.path:  # run as a file: the root holds ``benchmarks``
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks.common import results as results_file  # noqa: E402
from benchmarks.sphere_disk.measure import (INTACT, disk_fragments, energy_balance, impact_momentum,  # noqa: E402
                                            inside_other, material_fragments, momentum_error, render)
from pfmpm import scenes  # noqa: E402
from pfmpm.output import read_csv  # noqa: E402
from pfmpm.post.fragments import linked_sets  # noqa: E402
from pfmpm.post.frames import read_frame, series  # noqa: E402
from pfmpm.scene import Scene  # noqa: E402

SEEDS = {1.0: 1, 0.5: 2}
"""The Weibull seed of each resolution (the scene's comments); 0 at any other."""
MOMENTUM, BALANCE, D50_RATIO = 1e-10, 0.02, 1.5
"""The checks' bounds: momentum over the impact momentum, energy over KE0, d50 max/min."""
CHECKPOINT_EVERY = 500


def overrides(h: float) -> list[str]:
    """The ``--set`` values of resolution ``h``."""
    return [f"grid.h={h:g}", f"materials.alumina.damage.weibull.seed={SEEDS.get(h, 0)}"]


def pfmpm_command() -> list[str]:
    """``pfmpm`` of this interpreter's environment."""
    return [sys.executable, "-m", "pfmpm.cli"]


def peak_memory(time_file: Path) -> float | None:
    """Maximum resident set size (bytes) from ``/usr/bin/time -v``'s report."""
    if not time_file.exists():
        return None
    m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", time_file.read_text())
    return 1024.0 * int(m[1]) if m else None


def run(h: float, out: Path, sets: list[str], resume: bool) -> Path:
    """The run at resolution ``h`` in ``out/h<h>``, made unless complete."""
    folder, timing = out / f"h{h:g}", out / f"h{h:g}.time"
    summary = folder / "summary.json"
    if summary.exists() and json.loads(summary.read_text())["status"] == "completed":
        return folder
    args = (["run", "--resume", str(folder)] if resume else
            ["run", str(scenes.path("sphere_disk")), "--out", str(folder), "--overwrite",
             "--checkpoint-every", str(CHECKPOINT_EVERY), *(w for s in overrides(h) + sets for w in ("--set", s))])
    out.mkdir(parents=True, exist_ok=True)
    subprocess.run(["/usr/bin/time", "-v", "-o", str(timing), *pfmpm_command(), *args, "--quiet"], check=True)
    return folder


def measure(folder: Path) -> dict:
    """The checks of one run folder."""
    scene = Scene.from_toml(folder / "scene.toml")
    h = scene.grid.h
    e = read_csv(folder / "energies.csv")
    summary = json.loads((folder / "summary.json").read_text())
    p0 = impact_momentum(scene)
    t, path = series(folder)[-1]
    frame = read_frame(t, path, 3)
    d = frame.data
    x, body, damage, volume = frame.x, d["body"].astype(int), d["damage"], d["volume"]
    X = x - d["displacement"]
    mass = scene.particles()["mass"]
    record = {"h": h, "seed": SEEDS.get(h, 0), "particles": len(x), "steps": summary["steps"],
              "t_end": summary["t_end"], "dt": summary["dt"], "threads": summary["threads"],
              "wall_s": summary["wall_s"], "peak_bytes": peak_memory(folder.parent / f"{folder.name}.time"),
              "impact_momentum": p0, "momentum_error": momentum_error(e, p0), "energy": energy_balance(e),
              "sphere_momentum_end": float(e["momentum_z_sphere"][-1] / e["momentum_z"][0]),
              "fragments": {}, "inside": {}}
    for intact in INTACT:
        f = disk_fragments(scene, x, volume, mass, damage, body, intact)
        record["fragments"][intact] = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in f.items()}
        labels = material_fragments(scene, X, damage, body, intact)
        record["inside"][intact] = inside_other(x, labels, 0.5 * h) | {
            "pieces": int(len(np.unique(labels[labels >= 0])))}
    # The picture: the disk's fragments in the current configuration, each its colour.
    sphere = body == 1
    intact = (body == 0) & (damage <= INTACT["undamaged"])
    labels = np.full(len(x), -1)
    labels[intact] = linked_sets(x[intact], 0.75 * h)
    f = record["fragments"]["undamaged"]
    render(folder.parent / f"fragments_h{h:g}.png", x, labels, sphere,
           f"sphere on disk, h = {h:g} mm, t = {t:.1f} us: {f['fragments']} fragments of at least 1 mm"
           f" (d50 {f['d50']:.2f} mm); failed particles light grey, the sphere dark")
    return record


def state_bytes(sim) -> bytes:
    p = sim.particles
    return b"".join(np.ascontiguousarray(getattr(p, k)).tobytes() for k in ("x", "v", "stress", "damage", "F"))


def bitwise(out: Path, end: float) -> dict:
    """1 against 2 threads, and a run resumed from its checkpoint against the
    uninterrupted one, on the coarse scene to ``end`` us."""
    from pfmpm import _core
    from pfmpm.cli import main
    from pfmpm.simulation import Simulation

    sets = overrides(1.0) + [f"time.end={end:g}"]
    scene = Scene.from_toml(scenes.path("sphere_disk"), sets)
    steps = scene.steps()
    before = _core.num_threads()
    states = {}
    try:
        for threads in (1, 2):
            _core.set_num_threads(threads)
            sim = Simulation(scene)
            sim.solver.adaptive_threads = False
            sim.advance(steps)
            states[threads] = state_bytes(sim)
            last = sim
    finally:
        _core.set_num_threads(before)
    p = last.particles
    full, part = out / "bitwise_full", out / "bitwise_part"
    for folder in (full, part):
        shutil.rmtree(folder, ignore_errors=True)
    half = steps // 2
    args = ["run", str(scenes.path("sphere_disk")), *(w for s in sets + [f"output.every={half}"] for w in ("--set", s)),
            "--quiet"]
    main([*args, "--out", str(full), "--checkpoint-every", str(half), "--keep", "5"])
    shutil.copytree(full, part)
    for name in sorted((part / "checkpoints").glob("*.h5"))[1:]:
        name.unlink()
    main(["run", "--resume", str(part), "--quiet"])
    files = sorted(p.name for p in full.iterdir() if p.suffix in (".csv", ".vtu", ".pvd"))
    same = {name: (full / name).read_bytes() == (part / name).read_bytes() for name in files}
    record = {"end": end, "steps": steps, "resumed_at": half, "threads_identical": states[1] == states[2],
              "resumed_identical": all(same.values()), "files": same,
              "failed": int(np.count_nonzero(np.asarray(p.damage) >= 1.0 - 1e-4)),
              "damaged": int(np.count_nonzero(np.asarray(p.damage) > 0.0)),
              "sphere_momentum": float(last.energies()["momentum_z_sphere"] / last.energies()["momentum_z"])}
    (out / "bitwise.json").write_text(json.dumps(record, indent=1))
    return record


def spread(values) -> float:
    v = np.array(values, dtype=float)
    return float(v.max() / v.min()) if len(v) > 1 and np.all(np.isfinite(v)) and v.min() > 0 else math.nan


def report(out: Path, argv: list[str] | None = None) -> dict:
    """The table of every ``h*.json`` and ``bitwise.json`` in ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    records = sorted((json.loads(p.read_text()) for p in out.glob("h*.json")), key=lambda r: -r["h"])
    bits = json.loads((out / "bitwise.json").read_text()) if (out / "bitwise.json").exists() else None
    ratio = {k: spread([r["fragments"][k]["d50"] for r in records]) for k in INTACT}
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for r in records:
        for k, style in (("undamaged", "-"), ("unfailed", "--")):
            f = r["fragments"][k]
            if f["sizes"]:
                ax.step([f["sizes"][0]] + f["sizes"], [0.0] + f["fractions"], style, where="post",
                        label=f"h = {r['h']:g} mm, {k}")
    ax.set_xscale("log")
    ax.set_xlabel("fragment size, equivalent diameter (mm)")
    ax.set_ylabel("cumulative mass fraction")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "sphere_disk_fragments.png", dpi=110)
    plt.close(fig)

    def fmt(v, spec):
        return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else format(v, spec)

    cols = [""] + [f"h = {r['h']:g} mm" for r in records]
    rows = [["particles; steps to t (us)"] + [f"{r['particles']:,}; {r['steps']:,} to {r['t_end']:.2f}"
                                               for r in records],
            ["wall time on 2 threads (s); peak memory (MB, B per particle)"]
            + [f"{r['wall_s']:.0f}; {fmt(r['peak_bytes'] and r['peak_bytes'] / 1e6, '.0f')},"
               f" {fmt(r['peak_bytes'] and r['peak_bytes'] / r['particles'], '.0f')}" for r in records],
            [f"**momentum**: largest change / impact momentum (<= {MOMENTUM:g})"]
            + [f"{r['momentum_error']:.1e}" for r in records],
            ["energy at the end / KE0: kinetic, elastic, damage, friction"]
            + [", ".join(f"{r['energy'][k]:.3f}" for k in ("kinetic", "elastic", "damage", "friction"))
               for r in records],
            [f"**energy balance**: 1 - their sum at the end; largest over the run (<= {BALANCE:g})"]
            + [f"{r['energy']['balance']:.3f}; {r['energy']['largest']:.3f}" for r in records],
            ["sphere's momentum at the end / impact momentum"] + [f"{r['sphere_momentum_end']:+.3f}" for r in records],
            ["failed volume fraction of the disk"] + [f"{r['fragments']['undamaged']['failed']:.3f}" for r in records]]
    for k in INTACT:
        rows.append([f"fragments >= 1 mm ({k}): count, largest (mm), d50 (mm), mass fraction in them"]
                    + [f"{r['fragments'][k]['fragments']}, {r['fragments'][k]['largest']:.2f},"
                       f" {r['fragments'][k]['d50']:.2f}, {r['fragments'][k]['intact']:.3f}" for r in records])
    for k in INTACT:
        rows.append([f"**inside another piece** ({k}): particles; closest two pieces (spacings); pieces"]
                    + [f"{r['inside'][k]['inside']}; {r['inside'][k]['closest']:.2f}; {r['inside'][k]['pieces']}"
                       for r in records])
    checks = results_file.table(cols, rows)
    summary = [["**d50 max/min across the resolutions** (<= 1.5): undamaged, unfailed",
                f"{fmt(ratio['undamaged'], '.2f')}, {fmt(ratio['unfailed'], '.2f')}"]]
    if bits:
        summary.append([f"**bitwise**, coarse to {bits['end']:g} us ({bits['steps']} steps, {bits['damaged']} damaged,"
                        f" {bits['failed']} failed): 1 = 2 threads; resumed at step {bits['resumed_at']} ="
                        " uninterrupted", f"{bits['threads_identical']}; {bits['resumed_identical']}"])
    tables = {"checks": checks, "summary": results_file.table(["check", "value"], summary)}
    record = results_file.write(out, "sphere_disk", "docs/verification/sphere-disk.md", __file__, argv, tables)
    # The commands that made the runs it reports, then its own.
    made = [r["command"] for r in records if r.get("command")] + ([bits["command"]] if bits and bits.get("command")
                                                                  else [])
    record["commands"] = made + record["commands"]
    (out / results_file.FILE).write_text(results_file.dumps(record))
    return {"records": records, "d50_ratio": ratio, "bitwise": bits, "tables": tables}


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--h", type=float, action="append", help="grid.h of a run (repeat for several)")
    parser.add_argument("--set", action="append", default=[], help="further scene overrides of the runs")
    parser.add_argument("--resume", action="store_true", help="continue the stopped run of --h")
    parser.add_argument("--bitwise", action="store_true", help="1 against 2 threads, resumed against uninterrupted")
    parser.add_argument("--bitwise-end", type=float, default=6.0, help="end time of the bitwise runs (us)")
    parser.add_argument("--report", action="store_true", help="the table of the runs measured in --out")
    parser.add_argument("--out", type=Path, default=Path("out/sphere_disk"))
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    for h in args.h or []:
        record = measure(run(h, args.out, args.set, args.resume))
        record["command"] = results_file.command(__file__, argv)
        (args.out / f"h{h:g}.json").write_text(json.dumps(record, indent=1))
        print(json.dumps({k: v for k, v in record.items() if k != "fragments"}, default=float))
    if args.bitwise:
        record = bitwise(args.out, args.bitwise_end)
        record["command"] = results_file.command(__file__, argv)
        (args.out / "bitwise.json").write_text(json.dumps(record, indent=1))
        print(json.dumps(record))
    if args.report:
        r = report(args.out, argv)
        for t in r["tables"].values():
            for row in t["rows"]:
                print(" | ".join(row))
        return r
    return {}


if __name__ == "__main__":
    main()
