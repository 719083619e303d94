"""Modified Charpy impact (Homel & Herbold 2017, section 3.3, Figs. 13-14): checks C1-C7.

Runs the charpy scene (``pfmpm/scenes/charpy.toml``) as the cases below, one
after the other, each into ``--out/<case>``, and measures each with
:mod:`benchmarks.charpy.measure`:

- ``elastic_h1``: striker and bar elastic (the bar of the striker's
  material), h = 1 mm (check C1);
- ``dfg_h<h>`` and ``sf_h<h>``: the damage-gradient partition and the single
  field (``contact.partition = "bodies"``) at h = 1, 0.5, 0.25 mm (C2, C3);
- ``sep<D>_h0.5``: D-bar_min = 0.01 and 0.125 at h = 0.5 (with ``dfg_h0.5``,
  0.25: C4);
- ``lch<k>_h0.5``: l_ch = 0.5 and 2 times the default (2 h) at h = 0.5 (with
  ``dfg_h0.5``: C5);
- ``gf22.3_h1``: the damage-gradient run at h = 1 with Table III's printed
  G_f = 22.3 mJ/mm^2;
- ``v<v>_h<h>``: the damage-gradient run with faster strikers, 0.03 mm/us at
  h = 1, 0.5, 0.25 and 0.04 mm/us at h = 1 and 0.5 (the grid widened to
  x = 24, which the bar reaches at 0.04 mm/us);
- ``eq21_h<h>``: the damage-gradient run whose faces part by eq. 21 alone,
  as the paper's (``contact.parting = "failed"``), at h = 1, 0.5 and 0.25.

Each case chosen with ``--cases`` (default all) is run, and then every case
that has a completed run in ``--out`` is measured (so cases can be run one
at a time, and ``--cases`` alone measures what is there).

At each resolution the striker starts one particle spacing (h / 2) from the
bar. C6 (one crack band from the notch root, under 2 cells wide) is
measured on the set D = 1 (``C6``) and on D >= 0.5 (``C6_half``), C7
(momentum) on every run. The measures go to ``--out/results.json``, the
checks to ``--out/checks.json`` and the energy histories to
``--out/energy_histories.png`` (Fig. 13: E - KE0 against time, E = kinetic +
stored, SF and DFG at the three resolutions, with -G_f A_f and C2's band),
and the tables of docs/verification/charpy.md to
``--out/benchmark_results.json`` (:mod:`benchmarks.common.results`).

    .venv/bin/python benchmarks/charpy/study.py --out out/charpy
    .venv/bin/python benchmarks/charpy/study.py --out out/charpy --cases dfg_h0.25 sf_h0.25
    .venv/bin/python benchmarks/charpy/study.py --out out/charpy --cases   # measures only, no run
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

if str(Path(__file__).resolve().parents[2]) not in sys.path:  # run as a file: the root holds ``benchmarks``
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

import numpy as np  # noqa: E402

from benchmarks.charpy.measure import (contact_end, crack_band, energy_balance,  # noqa: E402
                                       fracture_energy, momentum_error)
from benchmarks.common import results as results_file  # noqa: E402
from pfmpm import plots, scenes  # noqa: E402
from pfmpm.output import read_csv  # noqa: E402
from pfmpm.post.frames import read_frame, series  # noqa: E402
from pfmpm.scene import Scene  # noqa: E402
from pfmpm.simulation import Simulation  # noqa: E402

RESOLUTIONS = (1.0, 0.5, 0.25)
"""Cell sizes h (mm) of the resolution study (benchmarks section 5, proposed)."""
SWEEP_H = 0.5
"""The sweeps' cell size (Fig. 14)."""
CRACKED = 0.5
"""C6 is also measured on the set D >= this: with the partition a crack's faces
part (eq. 21) before most of its particles reach D = 1."""


def at(h: float, *sets: str) -> list[str]:
    """Overrides of a run at cell size ``h``: the striker one particle spacing
    (h / 2) from the bar."""
    return [f"grid.h={h}", f"bodies.striker.shape.center=[{-10.0 - h / 2}, 27.5]", *sets]


def cases() -> dict[str, list[str]]:
    """Every case of the study: name -> its overrides of the scene."""
    out = {"elastic_h1": at(1.0, "bodies.target.material=striker", "output.every=20")}
    for h in RESOLUTIONS:
        out[f"dfg_h{h:g}"] = at(h)
        out[f"sf_h{h:g}"] = at(h, "contact.partition=bodies")
    for d in (0.01, 0.125):
        out[f"sep{d:g}_h{SWEEP_H:g}"] = at(SWEEP_H, f"contact.separability={d}")
    for k in (0.5, 2.0):
        out[f"lch{k:g}_h{SWEEP_H:g}"] = at(SWEEP_H, f"materials.target.damage.l_ch={k * 2 * SWEEP_H}")
    out["gf22.3_h1"] = at(1.0, "materials.target.damage.Gf=22.3")
    for v, resolutions in ((0.03, RESOLUTIONS), (0.04, RESOLUTIONS[:2])):
        for h in resolutions:
            out[f"v{v:g}_h{h:g}"] = at(h, f"bodies.striker.velocity=[{v}, 0.0]", "grid.size=[48.0, 64.0]")
    for h in RESOLUTIONS:
        out[f"eq21_h{h:g}"] = at(h, "contact.parting=failed")
    return out


def measure(scene: Scene, run: Path) -> dict:
    """The measures of one finished run: its energy balance, momentum, crack
    band (at the last snapshot, in the reference configuration) and contact checks."""
    e = read_csv(run / "energies.csv")
    summary = json.loads((run / "summary.json").read_text())
    t_end, last = series(run)[-1]
    frame = read_frame(t_end, last)
    damaged = scene.material_of(scene.body("target")).damage is not None
    after = None if damaged else contact_end(scene, run)
    report = {"energy": energy_balance(e, after=after), "contact_end": after,
              "momentum": momentum_error(e), "status": summary["status"], "steps": summary["steps"],
              "wall_s": summary["wall_s"], "particles": len(frame.x),
              "violations": summary["contact"]["violations"],
              "GfAf": fracture_energy(scene) if damaged else None, "h": scene.grid.h,
              "l_ch": scene.material_of(scene.body("target")).damage.length(scene.grid) if damaged else None,
              "separability": scene.contact.separability}
    if damaged:
        x0 = frame.x - frame.data["displacement"][:, :2]
        report["band"] = crack_band(scene, x0, frame.data["damage"], frame.data["body"])
        report["band_half"] = crack_band(scene, x0, frame.data["damage"], frame.data["body"],
                                         threshold=CRACKED)
    return report


def checks(results: dict) -> dict:
    """Checks C1-C7 of benchmarks section 5 on the cases measured (a check whose
    cases are missing is left out)."""
    def dE(name):
        return results[name]["energy"]["dE"]

    out = {}
    ga = fracture_energy(Scene.from_toml(scenes.path("charpy")))  # 354.1 mJ
    if "elastic_h1" in results:
        r = results["elastic_h1"]["energy"]
        out["C1"] = {"loss": r["loss"], "overshoot": r["overshoot"],
                     "pass": 0.005 <= r["loss"] <= 0.045 and r["overshoot"] < 0.01}
    out["C7"] = {"momentum": {n: r["momentum"] for n, r in results.items()},
                 "pass": all(r["momentum"] < 1e-9 for r in results.values())}
    dfg = [f"dfg_h{h:g}" for h in RESOLUTIONS if f"dfg_h{h:g}" in results]
    if dfg:
        ke0 = results[dfg[0]]["energy"]["KE0"]
        lo, hi = 0.9 * ga, 1.1 * ga + 0.025 * ke0
        out["C2"] = {"dE": {n: dE(n) for n in dfg}, "range": [lo, hi],
                     "pass": all(lo <= dE(n) <= hi for n in dfg)}
    fast = sorted(n for n in results if n.startswith("v"))
    if fast:  # C2's band of the benchmark's striker, [0.9, 1.17] G_f A_f, at faster ones
        lo, hi = 0.9 * ga, 1.1 * ga + 0.025 * 1005.3
        out["C2_fast"] = {"dE_over_GfAf": {n: dE(n) / ga for n in fast}, "range": [lo / ga, hi / ga],
                          "pass": all(lo <= dE(n) <= hi for n in fast)}
    both = [h for h in RESOLUTIONS if f"dfg_h{h:g}" in results and f"sf_h{h:g}" in results]
    if both:
        diff = {f"h{h:g}": dE(f"sf_h{h:g}") - dE(f"dfg_h{h:g}") for h in both}
        coarse, fine = diff[f"h{both[0]:g}"], diff[f"h{both[-1]:g}"]
        out["C3"] = {"sf_minus_dfg": diff, "over_GfAf": {k: v / ga for k, v in diff.items()},
                     "pass": coarse >= 0.05 * ga and (len(both) == 1 or abs(fine) < abs(coarse))}
    sep = [n for n in (f"sep0.01_h{SWEEP_H:g}", f"sep0.125_h{SWEEP_H:g}", f"dfg_h{SWEEP_H:g}")
           if n in results]
    spread = None
    if len(sep) == 3:
        values = [dE(n) for n in sep]
        spread = max(values) - min(values)
        out["C4"] = {"dE": dict(zip(("0.01", "0.125", "0.25"), values)), "spread_over_GfAf": spread / ga,
                     "pass": spread <= 0.02 * ga}
    lch = [n for n in (f"lch0.5_h{SWEEP_H:g}", f"dfg_h{SWEEP_H:g}", f"lch2_h{SWEEP_H:g}") if n in results]
    if len(lch) == 3:
        values = [dE(n) for n in lch]
        falls = values[0] > values[1] > values[2]
        out["C5"] = {"dE": dict(zip(("0.5", "1", "2"), values)),
                     "range_over_GfAf": (max(values) - min(values)) / ga,
                     "pass": falls and (spread is None or max(values) - min(values) > spread)}
    for key, band in (("C6", "band"), ("C6_half", "band_half")):
        bands = {n: r[band] for n, r in results.items() if not n.startswith(("sf", "elastic"))}
        if bands:
            out[key] = {"bands": {n: {k: b[k] for k in ("paths", "from_root", "across", "width")}
                                  for n, b in bands.items()},
                        "pass": all(b["paths"] == 1 and b["from_root"] and b["across"] == 1.0
                                    and b["width"] < 2.0 for b in bands.values())}
    return dict(sorted(out.items()))


def tables(results: dict, report: dict) -> dict:
    """The tables of docs/verification/charpy.md: ``runs``, the energy of each
    case in units of G_f A_f, and ``checks``, C1-C7 with what they require."""
    ga = fracture_energy(Scene.from_toml(scenes.path("charpy")))

    def energy(name, key):
        return f"{results[name]['energy'][key] / ga:.3f}" if name in results else ""

    def verdict(check):
        return "pass" if report[check]["pass"] else "**fails**"

    runs = []
    for h in RESOLUTIONS:
        cells = [energy(f"{m}_h{h:g}", k) for m, keys in (("dfg", ("dE", "damage", "numerical")),
                                                          ("sf", ("dE", "damage")),
                                                          ("eq21", ("dE", "damage", "numerical")))
                 for k in keys]
        if any(cells):
            runs.append([f"h = {h:g}", *cells])
    for v in (0.03, 0.04):
        names = [n for n in (f"v{v:g}_h{h:g}" for h in RESOLUTIONS) if n in results]
        if names:
            hs = " / ".join(f"{results[n]['h']:g}" for n in names)
            runs.append([f"v0 = {v:g} mm/us, h = {hs}",
                         *(" / ".join(energy(n, k) for n in names) for k in ("dE", "damage", "numerical")),
                         *[""] * 5])
    if "gf22.3_h1" in results:
        runs.append(["G_f = 22.3, h = 1", *(energy("gf22.3_h1", k) for k in ("dE", "damage", "numerical")),
                     *[""] * 5])
    if "elastic_h1" in results:
        e = results["elastic_h1"]["energy"]
        runs.append(["elastic, h = 1", f"{e['dE'] / ga:.3f} ({100 * e['loss']:.2f} % of KE0)", "0", *[""] * 6])
    checks = []
    if "C1" in report:
        c = report["C1"]
        checks.append(["C1: elastic impact, h = 1: loss; largest E after the striker leaves",
                       f"{100 * c['loss']:.2f} %; {100 * c['overshoot']:+.1f} %", "0.5-4.5 %; < +1 %",
                       verdict("C1")])
    if "C2" in report:
        c = report["C2"]
        hs = " / ".join(f"{results[n]['h']:g}" for n in c["dE"])
        checks.append([f"C2: DFG dE, h = {hs}", " / ".join(f"{v / ga:.3f}" for v in c["dE"].values())
                       + " G_f A_f", f"[{c['range'][0] / ga:.2f}, {c['range'][1] / ga:.2f}]", verdict("C2")])
    if "C2_fast" in report:
        c = report["C2_fast"]
        checks.append(["C2 at faster strikers (" + ", ".join(c["dE_over_GfAf"]) + ")",
                       " / ".join(f"{v:.3f}" for v in c["dE_over_GfAf"].values()),
                       f"[{c['range'][0]:.2f}, {c['range'][1]:.2f}]", verdict("C2_fast")])
    if "C3" in report:
        c = report["C3"]
        hs = " / ".join(k[1:] for k in c["over_GfAf"])
        checks.append([f"C3: dE_SF - dE_DFG, h = {hs}",
                       " / ".join(f"{v:+.3f}" for v in c["over_GfAf"].values()) + " G_f A_f",
                       ">= +0.05 at h = 1, smaller at 0.25", verdict("C3")])
    if "C4" in report:
        c = report["C4"]
        checks.append([f"C4: dE at D-bar_min = {' / '.join(c['dE'])}, h = {SWEEP_H:g}",
                       " / ".join(f"{v:.3f}" for v in c["dE"].values())
                       + f" mJ: spread {c['spread_over_GfAf']:.2g} G_f A_f", "< 0.02", verdict("C4")])
    if "C5" in report:
        c = report["C5"]
        checks.append([f"C5: dE at l_ch = {' / '.join(c['dE'])} x the default, h = {SWEEP_H:g}",
                       " / ".join(f"{v:.1f}" for v in c["dE"].values())
                       + f" mJ; range {c['range_over_GfAf']:.2f} G_f A_f", "falls, by more than C4's spread",
                       verdict("C5")])
    for key, on in (("C6", "D = 1"), ("C6_half", f"D >= {CRACKED:g}")):
        if key in report:
            bands = {n: b for n, b in report[key]["bands"].items() if n.startswith("dfg")}
            checks.append([f"C6 on {on} (DFG, h = {' / '.join(n[5:] for n in bands)})",
                           " / ".join(f"{b['paths']} band(s), {b['width']:.1f} cells wide" for b in bands.values()),
                           "one band, < 2 cells", verdict(key)])
    c = report["C7"]
    checks.append([f"C7: momentum, max |p - p0| / |p0| over the {len(c['momentum'])} runs",
                   f"<= {max(c['momentum'].values()):.1e}", "< 1e-9", verdict("C7")])
    return {"runs": results_file.table(
                ["run", "dE", "damage", "numerical (and friction)", "dE, SF", "damage, SF", "dE, eq. 21 alone",
                 "damage, eq. 21 alone", "numerical, eq. 21 alone"], runs),
            "checks": results_file.table(["check", "measured", "required", ""], checks)}


def figure(results: dict, out: Path) -> None:
    """Fig. 13: the system's energy E = kinetic + stored against time, SF and DFG
    at each resolution, as E - KE0 (each run's own KE0), with -G_f A_f and the
    band of check C2."""
    plt = plots.plt
    fig, ax = plt.subplots(figsize=(7, 4.5))
    colours = dict(zip(RESOLUTIONS, ("tab:blue", "tab:orange", "tab:green")))
    ga = fracture_energy(Scene.from_toml(scenes.path("charpy")))
    for h in RESOLUTIONS:
        for kind, style in (("dfg", "-"), ("sf", "--")):
            name = f"{kind}_h{h:g}"
            if name in results:
                e = read_csv(out / name / "energies.csv")
                energy = e["kinetic"] + e["elastic"]
                ax.plot(e["t"], energy - energy[0], style, color=colours[h], lw=1,
                        label=f"{kind.upper()}, h = {h:g} mm")
    ke0 = next((r["energy"]["KE0"] for r in results.values()), 1005.3)
    ax.axhline(-ga, color="k", lw=0.8, ls=":", label=f"-G_f A_f = -{ga:.1f} mJ")
    ax.axhspan(-(1.1 * ga + 0.025 * ke0), -0.9 * ga, color="gold", alpha=0.3, lw=0, label="C2")
    ax.set_xlabel("t (us)")
    ax.set_ylabel("E - KE0 (mJ), E = kinetic + stored")
    ax.set_title("Modified Charpy: the system's energy (H&H Fig. 13)")
    ax.legend(fontsize=8, loc="lower left")
    fig.tight_layout()
    fig.savefig(out / "energy_histories.png", dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="*", default=None, metavar="CASE",
                        help="cases to run (default all; none: only measure the runs in --out)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="more overrides of every case's scene, after its own")
    parser.add_argument("--out", default="out/charpy")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    every = cases()
    chosen = list(every) if args.cases is None else args.cases
    unknown = [c for c in chosen if c not in every]
    if unknown:
        parser.error(f"unknown case {unknown[0]!r}: one of {', '.join(every)}")
    for name in chosen:
        scene = Scene.from_toml(scenes.path("charpy"), every[name] + args.set)
        # A case asked for is run again: its folder is the study's own.
        result = Simulation(scene).run(out / name, progress=False, overwrite=True)
        if result.status != "completed":
            raise SystemExit(f"{name}: {result.status}: {result.error}")
        print(f"{name}: {result.steps} steps in {result.wall_s:.0f} s", flush=True)
    results = {}
    for name, sets in every.items():
        summary = out / name / "summary.json"
        if summary.exists() and json.loads(summary.read_text())["status"] == "completed":
            results[name] = measure(Scene.from_toml(scenes.path("charpy"), sets + args.set), out / name)
            r = results[name]
            print(f"{name}: dE = {r['energy']['dE']:.1f} mJ (damage {r['energy']['damage']:.1f}, "
                  f"numerical {r['energy']['numerical']:.1f}), loss {r['energy']['loss']:.4f}, "
                  f"momentum {r['momentum']:.2e}")
    (out / "results.json").write_text(json.dumps(results, indent=1))
    report = checks(results) if results else {}
    (out / "checks.json").write_text(json.dumps(report, indent=1))
    if report:
        results_file.write(out, "charpy", "docs/verification/charpy.md", __file__, argv, tables(results, report))
    figure(results, out)
    for key, value in report.items():
        print(key, "pass" if value["pass"] else "FAIL",
              json.dumps({k: v for k, v in value.items() if k != "pass"}))
    return report


if __name__ == "__main__":
    main()
