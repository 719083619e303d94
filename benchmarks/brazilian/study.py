"""Dynamic Brazilian disk (Homel & Herbold 2017, section 3.4, Figs. 15-18): checks Z1-Z6.

At each resolution (``grid.h`` with its Weibull seed, :data:`SEEDS`) runs
the scene with damage-gradient partitioning (DFG, the scene as it is) and
the single field (SF, :func:`benchmarks.common.self_contact.body_fields`) on the
same Weibull field, side by side step by step until both have a fully
damaged particle, then each to the end, and measures
(``shared/benchmarks-homel-herbold.md`` section 6):

- Z1: where the first particle to reach D = 1 started, from the nearer
  platen-disk contact point (within 1.5 mm), and how far it then is from
  the nearest platen particle;
- Z2: the largest difference of the DFG and SF particle positions,
  velocities, stresses and damage over the steps up to the first nonzero D
  (and on to the first D = 1), which must be round-off;
- Z3: the time at which the fully damaged fraction of the disk's area
  reaches 5 % (DFG earlier);
- Z4, Z5: the mass-weighted median fragment size d50 and the mean speed of
  the disk at t = 10 us (DFG) and 15 us (SF), their max/min over the
  resolutions (DFG <= 1.5 and <= 1.25, with a smaller spread than SF; SF
  d50 falling with refinement);
- Z6: how far particles pass the side walls or into a platen (<= 0.5 cell),
  and that the run reached t_end with finite values.

A run that the stability check stops (docs/verification/brazilian-time-step.md)
is measured up to where it stopped. Writes
``h<h>.json`` per resolution and then, from every ``h*.json`` in ``--out``,
``brazilian.json`` (the checks), ``brazilian.csv`` (one row per run) and
``brazilian_fragments.png`` (the cumulative fragment-size distributions at
the analysis times, Fig. 18, with the mean speeds), ``brazilian_damage.png``
(the damage at the analysis times) and the table of
docs/verification/brazilian.md, ``benchmark_results.json``
(:mod:`benchmarks.common.results`).

    .venv/bin/python benchmarks/brazilian/study.py --h 0.1875 --out out/brazilian
    .venv/bin/python benchmarks/brazilian/study.py --report --out out/brazilian
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

if str(Path(__file__).resolve().parents[2]) not in sys.path:  # run as a file: the root holds ``benchmarks``
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks.brazilian.measure import (contact_distance, disk_fragments, disk_speed,  # noqa: E402
                                          failed_fraction, platen_penetration, wall_excursion)
from benchmarks.common import results as results_file  # noqa: E402
from benchmarks.common.self_contact import body_fields  # noqa: E402
from pfmpm import SimulationError, scenes  # noqa: E402
from pfmpm.post.fragments import failed  # noqa: E402
from pfmpm.scene import Scene  # noqa: E402
from pfmpm.simulation import Simulation  # noqa: E402

SEEDS = {0.1875: 1, 0.09375: 2, 0.0625: 3}
"""The Weibull seed of each resolution (the scene's comments); 0 at any other."""
PAPER_H = {0.1875: 0.181, 0.09375: 0.094, 0.0625: 0.063}
"""The paper's resolution next to each of ours (section 3.4)."""
METHODS = ("damage_gradient", "single_field")
ANALYSIS = {"damage_gradient": 10.0, "single_field": 15.0}
"""The times (us) at which the paper compares the fragments (section 3.4)."""
TIMES = (5.0, 10.0, 15.0, 20.0)
"""Fragment analyses of both methods, besides those of :data:`ANALYSIS`."""
FAILED = 0.05
"""Z3: the fully damaged area fraction whose time is compared."""
Z1_RADIUS, Z4_D50, Z4_SPEED, Z6_DEPTH = 1.5, 1.5, 1.25, 0.5
"""The checks' bounds: mm, max/min ratios, cells."""
STATE = ("x", "v", "stress", "damage")
"""The particle columns Z2 compares."""


def copy_of(p) -> dict:
    """The particle columns the measures read, copied."""
    return {k: np.array(getattr(p, k)) for k in ("x", "v", "mass", "volume", "damage", "body")}


def sample(scene: Scene, sim: Simulation, x0: np.ndarray) -> dict:
    """The measures of one step: failed fraction, mean speed, Courant number, Z6."""
    p = sim.particles
    return {"t": sim.time, "step": sim.step, "failed": failed_fraction(scene, p),
            "mean_speed": disk_speed(scene, p),
            "courant": scene.dt() * sim.solver.fastest_signal() / scene.critical_length(),
            "wall": wall_excursion(scene, p.x),
            "platen": max(platen_penetration(scene, x0, p.x, p.body, name) for name in ("top", "bottom")),
            "finite": bool(np.isfinite(p.x).all() and np.isfinite(p.v).all())}


def analyse(scene: Scene, p) -> dict:
    """:func:`disk_fragments` with both intact definitions, as JSON."""
    out = {}
    for intact in ("undamaged", "unfailed"):
        f = disk_fragments(scene, p, intact=intact)
        out[intact] = {"d50": f["d50"], "fragments": f["fragments"], "intact": f["intact"],
                       "sizes": f["sizes"].tolist(), "fractions": f["fractions"].tolist()}
    out["mean_speed"] = f["mean_speed"]
    out["failed"] = failed_fraction(scene, p)
    return out


def run_resolution(h: float, sets: list[str], samples: int, out: Path, analysis: dict | None = None,
                   progress=print) -> dict:
    """Both methods at one resolution; returns (and writes) ``h<h>.json``.

    ``analysis`` (default :data:`ANALYSIS`) gives each method's time of Z4
    and Z5; fragments are analysed then and at :data:`TIMES`.
    """
    analysis = dict(analysis or ANALYSIS)
    scene = Scene.from_toml(scenes.path("brazilian"),
                            [f"grid.h={h}", f"materials.ceramic.damage.weibull.seed={SEEDS.get(h, 0)}"] + sets)
    variants = {"damage_gradient": scene, "single_field": body_fields(scene)}
    sims = {m: Simulation(s) for m, s in variants.items()}
    steps, dt = scene.steps(), scene.dt()
    x0 = sims["damage_gradient"].particles.x.copy()
    every = max(1, steps // samples)
    analysis_steps = {min(steps, int(round(t / dt))): t for t in sorted(set(TIMES) | set(analysis.values()))
                      if t <= scene.time.end + 1e-9}
    record = {"analysis_times": analysis, "h": h, "paper_h": PAPER_H.get(h), "seed": SEEDS.get(h, 0), "particles": len(x0), "dt": dt,
              "steps": steps, "cfl": scene.time.cfl, "sets": sets, "runs": {}}
    runs = {m: {"samples": [], "analysis": {}, "first_failure": None, "stopped": None, "t_end": None}
            for m in METHODS}
    snapshots = {}

    def measure(m):
        sim, r = sims[m], runs[m]
        if sim.step % every == 0 or sim.step in analysis_steps:
            r["samples"].append(sample(variants[m], sim, x0))
        if sim.step in analysis_steps:
            t = analysis_steps[sim.step]
            r["analysis"][f"{t:g}"] = analyse(variants[m], sim.particles)
            snapshots[f"{m}_{t:g}"] = copy_of(sim.particles)
        if r["first_failure"] is None and failed(sim.particles.damage).any():
            x, body = sim.particles.x, sim.particles.body
            broken = np.flatnonzero(failed(sim.particles.damage))
            platens = x[body != body[broken[0]]]
            r["first_failure"] = {"t": sim.time, "step": sim.step, "particles": broken.tolist(),
                                  "x0": x0[broken].tolist(),
                                  "distance": contact_distance(scene, x0[broken]).tolist(),
                                  "to_platen": [float(np.hypot(*(platens - x[k]).T).min()) for k in broken]}

    # Side by side, step by step, until both have a fully damaged particle (Z1, Z2).
    identity = {"first_damage_step": None, "to_first_damage": dict.fromkeys(STATE, 0.0),
                "to_first_failure": dict.fromkeys(STATE, 0.0)}
    start = time.perf_counter()
    for m in METHODS:
        measure(m)
    a, b = sims["damage_gradient"].particles, sims["single_field"].particles
    while (sims["damage_gradient"].step < steps and not any(r["stopped"] for r in runs.values())
           and any(r["first_failure"] is None for r in runs.values())):
        for m in METHODS:
            try:
                sims[m].advance(1)
            except SimulationError as err:
                runs[m]["stopped"] = str(err)
        diff = {k: float(np.max(np.abs(getattr(a, k) - getattr(b, k)))) for k in STATE}
        for k in STATE:
            identity["to_first_failure"][k] = max(identity["to_first_failure"][k], diff[k])
            if identity["first_damage_step"] is None:
                identity["to_first_damage"][k] = max(identity["to_first_damage"][k], diff[k])
        if identity["first_damage_step"] is None and max(a.damage.max(), b.damage.max()) > 0.0:
            identity["first_damage_step"] = sims["damage_gradient"].step
            identity["first_damage_t"] = sims["damage_gradient"].time
        for m in METHODS:
            measure(m)
    identity["scale"] = {"x": float(np.max(np.abs(x0))), "v": float(np.max(np.abs(a.v))),
                         "stress": float(np.max(np.abs(a.stress))), "damage": 1.0}
    shared = time.perf_counter() - start
    record["identity"] = identity
    for m in METHODS:
        sim, r = sims[m], runs[m]
        start = time.perf_counter()
        try:
            while r["stopped"] is None and sim.step < steps:
                sim.advance(min(every - sim.step % every, steps - sim.step,
                                min((s - sim.step for s in analysis_steps if s > sim.step), default=steps)))
                measure(m)
        except SimulationError as err:
            r["stopped"] = str(err)
        r["t_end"] = sim.time
        r["wall_s"] = shared / 2 + time.perf_counter() - start
        r["contact"] = {k: v for k, v in sim.solver.contact_stats().items() if k.startswith("C")}
        progress(f"h = {h} {m}: t = {sim.time:.3f} us, {sim.step} steps, {r['wall_s']:.0f} s"
                 + (f", stopped: {r['stopped']}" if r["stopped"] else ""))
    record["runs"] = runs
    out.mkdir(parents=True, exist_ok=True)
    (out / f"h{h}.json").write_text(json.dumps(record, indent=1))
    np.savez_compressed(out / f"h{h}.npz", x0=x0, **{f"{key}_{k}": v for key, cols in snapshots.items()
                                                      for k, v in cols.items() if k in ("x", "damage", "body")})
    return record


def crossing(samples: list[dict], key: str, level: float) -> float:
    """The first time ``key`` reaches ``level`` (linear between samples; NaN if never)."""
    t = np.array([s["t"] for s in samples])
    y = np.array([s[key] for s in samples])
    above = np.flatnonzero(y >= level)
    if len(above) == 0:
        return math.nan
    k = above[0]
    if k == 0:
        return float(t[0])
    return float(t[k - 1] + (level - y[k - 1]) * (t[k] - t[k - 1]) / (y[k] - y[k - 1]))


def spread(values: list[float]) -> float:
    """max / min of positive values (NaN if any is missing)."""
    v = np.array(values, dtype=float)
    return float(v.max() / v.min()) if len(v) and np.all(np.isfinite(v)) and v.min() > 0 else math.nan


def report(out: Path) -> dict:
    """Checks Z1-Z6 from every ``h*.json`` in ``out``; writes the table and figures."""
    records = sorted((json.loads(p.read_text()) for p in out.glob("h*.json")), key=lambda r: -r["h"])
    rows, checks = [], {"resolutions": [r["h"] for r in records], "paper_resolutions": [r["paper_h"] for r in records]}
    z = {f"Z{k}": {} for k in range(1, 7)}
    for r in records:
        h = r["h"]
        ident = r["identity"]
        z["Z2"][h] = {"first_damage_t": ident.get("first_damage_t"),
                      "to_first_damage": ident["to_first_damage"], "to_first_failure": ident["to_first_failure"],
                      "pass": all(v == 0.0 or v <= 1e-12 * ident["scale"][k]
                                  for k, v in ident["to_first_damage"].items())}
        t5 = {}
        for m, run in r["runs"].items():
            first = run["first_failure"]
            t5[m] = crossing(run["samples"], "failed", FAILED)
            last = run["samples"][-1]
            row = {"h": h, "paper_h": r["paper_h"], "method": m, "particles": r["particles"],
                   "steps": r["steps"], "t_end": run["t_end"], "stopped": bool(run["stopped"]),
                   "wall_s": run["wall_s"],
                   "first_failure_t": first["t"] if first else math.nan,
                   "first_failure_distance": min(first["distance"]) if first else math.nan,
                   "t_failed_5pct": t5[m],
                   "failed_end": last["failed"],
                   "courant_max": max(s["courant"] for s in run["samples"]),
                   "wall_max": max(s["wall"] for s in run["samples"]),
                   "platen_max": max(s["platen"] for s in run["samples"]),
                   "finite": all(s["finite"] for s in run["samples"])}
            for t, a in run["analysis"].items():
                row[f"d50_{t}"] = a["undamaged"]["d50"]
                row[f"d50_unfailed_{t}"] = a["unfailed"]["d50"]
                row[f"fragments_{t}"] = a["undamaged"]["fragments"]
                row[f"speed_{t}"] = a["mean_speed"]
            row.update({k: v for k, v in run["contact"].items()})
            rows.append(row)
            z["Z1"][f"{m} {h}"] = {"t": row["first_failure_t"], "distance": row["first_failure_distance"],
                                   "to_platen": min(first["to_platen"]) if first else math.nan,
                                   "pass": bool(row["first_failure_distance"] <= Z1_RADIUS)}
            z["Z6"][f"{m} {h}"] = {"t_end": run["t_end"], "wall": row["wall_max"], "platen": row["platen_max"],
                                   "finite": row["finite"], "stopped": run["stopped"],
                                   "pass": bool(row["finite"] and row["wall_max"] <= Z6_DEPTH
                                                and row["platen_max"] <= Z6_DEPTH and not run["stopped"])}
        z["Z3"][h] = {"damage_gradient": t5["damage_gradient"], "single_field": t5["single_field"],
                      "pass": bool(t5["damage_gradient"] < t5["single_field"])}
    analysis = records[0]["analysis_times"] if records else ANALYSIS
    for m, t in analysis.items():
        key = f"{t:g}"
        d50 = [next((x.get(f"d50_{key}", math.nan) for x in rows if x["h"] == h and x["method"] == m))
               for h in checks["resolutions"]]
        speed = [next((x.get(f"speed_{key}", math.nan) for x in rows if x["h"] == h and x["method"] == m))
                 for h in checks["resolutions"]]
        z["Z4"][m] = {"t": t, "d50": d50, "mean_speed": speed, "d50_spread": spread(d50),
                      "speed_spread": spread(speed)}
    # Both methods at every analysis time (the paper's SF time may lie past where a run stopped).
    z["Z4"]["by_time"] = {}
    for t in sorted({float(k) for x in rows for k in (c[4:] for c in x if c.startswith("d50_") and
                                                       not c.startswith("d50_unfailed"))}):
        key = f"{t:g}"
        z["Z4"]["by_time"][key] = {
            m: {"d50_spread": spread([x.get(f"d50_{key}", math.nan) for x in rows if x["method"] == m]),
                "speed_spread": spread([x.get(f"speed_{key}", math.nan) for x in rows if x["method"] == m])}
            for m in METHODS}
    dfg, sf = z["Z4"]["damage_gradient"], z["Z4"]["single_field"]
    z["Z4"]["pass"] = bool(dfg["d50_spread"] <= Z4_D50 and dfg["speed_spread"] <= Z4_SPEED
                           and dfg["d50_spread"] < sf["d50_spread"] and dfg["speed_spread"] < sf["speed_spread"])
    d50 = sf["d50"]
    z["Z5"] = {"d50": d50, "pass": bool(len(d50) > 1 and all(b < a for a, b in zip(d50, d50[1:])))}
    checks.update(z)
    (out / "brazilian.json").write_text(json.dumps(checks, indent=1, default=float))
    keys = list(dict.fromkeys(k for row in rows for k in row))
    with open(out / "brazilian.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    figures(records, analysis, out)
    return checks, table(records, rows, checks)


def table(records: list[dict], rows: list[dict], checks: dict) -> dict:
    """The table of docs/verification/brazilian.md: a column per resolution,
    a row per measure (DFG / SF where both)."""
    def run(h, m):
        return next(x for x in rows if x["h"] == h and x["method"] == m)

    def both(h, cell):
        return " / ".join(cell(run(h, m)) for m in METHODS)

    def small(v):
        return "0" if v == 0.0 else f"{v:.1e}"

    z1 = {r["h"]: checks["Z1"][f"damage_gradient {r['h']}"] for r in records}
    times = sorted({float(c[4:]) for x in rows for c in x if c.startswith("d50_") and not c.startswith("d50_unf")})
    t_end = max(r["steps"] * r["dt"] for r in records) if records else 0.0
    out = [[f"steps to {t_end:.3g} us; reached, DFG / SF"]
           + [f"{r['steps']:,}; " + both(r["h"], lambda x: f"{x['t_end']:.1f}") for r in records],
           ["first D > 0 (us)"] + [f"{checks['Z2'][r['h']]['first_damage_t']:.3f}"
                                   if checks["Z2"][r["h"]]["first_damage_t"] is not None else "" for r in records],
           ["**Z1**: first D = 1: t (us), where it started from the contact point (mm), then from the nearest "
            "platen particle (mm)"]
           + [", ".join(f"{z1[r['h']][k]:.3g}" for k in ("t", "distance", "to_platen")) for r in records],
           ["**Z2**: max |DFG - SF| up to the first D > 0: x (mm), v (mm/us), stress (MPa), D"]
           + [", ".join(small(checks["Z2"][r["h"]]["to_first_damage"][k]) for k in STATE) for r in records],
           [f"**Z3**: fully damaged area {100 * FAILED:g} % at, DFG / SF (us)"]
           + [" / ".join(f"{checks['Z3'][r['h']][m]:.2f}" for m in METHODS) for r in records]]
    for t in times:
        out.append([f"at {t:g} us: d50 (mm), fragments, speed, DFG / SF"]
                   + [both(r["h"], lambda x: f"{x.get(f'd50_{t:g}', math.nan):.3g}, "
                           f"{x.get(f'fragments_{t:g}', 0)}, {x.get(f'speed_{t:g}', math.nan):.3g}")
                      for r in records])
    out.append(["fully damaged area at the end, DFG / SF"]
               + [both(r["h"], lambda x: f"{x['failed_end']:.2f}") for r in records])
    out.append(["**Z6**: farthest past a wall (cells); deepest into a platen (cells), DFG / SF; all finite"]
               + [both(r["h"], lambda x: f"{x['wall_max']:.3f}") + "; " + both(r["h"], lambda x: f"{x['platen_max']:.3f}")
                  + "; " + ("yes" if all(run(r["h"], m)["finite"] for m in METHODS) else "no") for r in records])
    out.append(["C.1-C.4 violations, DFG (SF: all 0)" if all(
        run(r["h"], "single_field").get(c, 0) == 0 for r in records for c in ("C1", "C2", "C3", "C4"))
        else "C.1-C.4 violations, DFG / SF"]
               + [", ".join(str(run(r["h"], "damage_gradient").get(c, "")) for c in ("C1", "C2", "C3", "C4"))
                  for r in records])
    columns = [""] + [f"h = {r['h']:g}" + (f" (paper {r['paper_h']:g})" if r["paper_h"] else "") for r in records]
    return results_file.table(columns, out)


def figures(records: list[dict], analysis: dict, out: Path) -> None:
    """Fig. 18: the cumulative fragment-size distributions at the analysis
    times (and the single field's at the DFG time), one curve per
    resolution, mean speeds in the legend; and the damage of the disk then."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    # The analysis times, and the single field also at the DFG's (where every run gets to).
    panels = list(analysis.items())
    if analysis["single_field"] != analysis["damage_gradient"]:
        panels.insert(1, ("single_field", analysis["damage_gradient"]))
    fig, axes = plt.subplots(1, len(panels), figsize=(5 * len(panels), 4), sharey=True)
    for ax, (m, t) in zip(axes, panels):
        for r in records:
            a = r["runs"][m]["analysis"].get(f"{t:g}")
            if a is None:
                continue
            color = None  # the resolution's colour, for both of its curves
            for intact, style in (("undamaged", "-"), ("unfailed", ":")):
                s, f = a[intact]["sizes"], a[intact]["fractions"]
                label = (f"h = {r['h']:g} mm ({r['paper_h']}): v = {a['mean_speed']:.3f} mm/us"
                         if intact == "undamaged" else None)
                (line,) = ax.step(s, f, style, where="post", label=label, color=color)
                color = line.get_color()
        ax.set_xscale("log")
        ax.set_xlabel("fragment size sqrt(4A/pi) (mm)")
        ax.set_title(f"{m.replace('_', ' ')}, t = {t:g} us")
        ax.legend(fontsize=7, loc="upper left")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("cumulative mass fraction")
    fig.suptitle("Brazilian disk fragments (solid: D <= 1e-6, dotted: D < 1)", fontsize=9)
    fig.tight_layout()
    fig.savefig(out / "brazilian_fragments.png", dpi=120)
    plt.close(fig)

    fig, axes = plt.subplots(len(records), len(panels), figsize=(4 * len(panels), 4 * len(records)),
                             squeeze=False)
    for row, r in zip(axes, records):
        data = np.load(out / f"h{r['h']}.npz")
        for ax, (m, t) in zip(row, panels):
            key = f"{m}_{t:g}"
            ax.set_aspect("equal")
            ax.set_title(f"{m.replace('_', ' ')}, h = {r['h']:g}, t = {t:g} us", fontsize=8)
            ax.set_xlim(-6, 6)
            ax.set_ylim(-7.5, 7.5)
            if f"{key}_x" not in data:
                ax.text(0.5, 0.5, "not reached", transform=ax.transAxes, ha="center")
                continue
            x, d, b = data[f"{key}_x"], data[f"{key}_damage"], data[f"{key}_body"]
            points_per_mm = ax.get_window_extent().width / fig.dpi * 72.0 / 12.0
            size = max(1.0, (points_per_mm * r["h"] / 2) ** 2)  # a marker per particle spacing
            ax.scatter(x[b != 0, 0], x[b != 0, 1], s=size, c="0.7", marker="s", lw=0)
            dots = ax.scatter(x[b == 0, 0], x[b == 0, 1], s=size, c=d[b == 0], cmap="YlOrRd", vmin=-0.2,
                              vmax=1, marker="s", lw=0)
            fig.colorbar(dots, ax=ax, shrink=0.6, label="damage D", ticks=[0.0, 0.5, 1.0])
    fig.tight_layout()
    fig.savefig(out / "brazilian_damage.png", dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--h", type=float, action="append",
                        help="a resolution to run (repeatable; default the three of SEEDS)")
    parser.add_argument("--report", action="store_true", help="only combine the h*.json in --out")
    parser.add_argument("--samples", type=int, default=400, help="samples of the measures per run")
    parser.add_argument("--at", type=float, nargs=2, metavar=("DFG", "SF"),
                        default=[ANALYSIS["damage_gradient"], ANALYSIS["single_field"]],
                        help="times (us) of the Z4 and Z5 fragment analyses")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--out", default="out/brazilian")
    args = parser.parse_args(argv)
    out = Path(args.out)
    if not args.report:
        for h in args.h or sorted(SEEDS, reverse=True):
            run_resolution(h, args.set, args.samples, out, dict(zip(METHODS, args.at)))
    checks, rows = report(out)
    results_file.write(out, "brazilian", "docs/verification/brazilian.md", __file__, argv, {"checks": rows})
    for k in ("Z1", "Z2", "Z3", "Z4", "Z5", "Z6"):
        print(k, json.dumps(checks[k], default=float))
    return checks


if __name__ == "__main__":
    main()
