"""Billet compaction (Homel & Herbold 2017, section 3.1, Fig. 8): checks B1-B4.

Runs the billet scene three ways (:func:`benchmarks.common.self_contact.variants`):
the single field (no-slip), billet and platen as two contact groups (the
multi-field reference, mu_f = 0.04) and one group whose surfaces were
flagged at t = 0 (damage-gradient self-contact, the scene as it is), and
measures at the quarter, half and end of the run:

- B1: the L2 difference of the billet's particle x velocities from the
  multi-field run, over the multi-field run's L2 norm, for the single field
  and the damage gradient;
- B2: the interface slip, u_x of the billet's top corner (1.0, 0.6) minus
  u_x of the platen particle above it;
- B3: violations of the contact checks C.1-C.4 (C.2: the forces of a pair
  are equal and opposite; the Coulomb law negates them exactly);
- B4: the smallest gap between the deformed domains of billet and platen
  particles over the run, in cells (0 at t = 0; at least -0.1 required:
  :func:`pfmpm.post.fragments.domain_gap`), and the closest approach of
  their centres in particle spacings (1 at t = 0), which reads the
  compressed particles of reading B as an overlap.

Prints them and writes ``billet.json`` and the table of
docs/verification/billet.md (``benchmark_results.json``,
:mod:`benchmarks.common.results`) to ``--out``.

    .venv/bin/python benchmarks/billet/compare.py --out out/billet_A
    .venv/bin/python benchmarks/billet/compare.py --set materials.billet.E=190.0 --set time.end=4.0 --out out/billet_B
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

if str(Path(__file__).resolve().parents[2]) not in sys.path:  # run as a file: the root holds ``benchmarks``
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks.common import results  # noqa: E402
from benchmarks.common.self_contact import interface_slip, relative_difference, run_variants  # noqa: E402
from pfmpm import scenes  # noqa: E402
from pfmpm.scene import Scene  # noqa: E402


def table(report: dict) -> dict:
    """The table of docs/verification/billet.md from ``report`` (:func:`main`'s):
    a row per check, its values at the times of the run, what is required and
    whether it holds."""
    def values(xs, fmt):
        return " / ".join(format(x, fmt) for x in xs)

    def verdict(ok):
        return "pass" if ok else "**fails**"

    b1, b2 = report["B1"], report["B2"]
    b1_ok = all(d <= min(0.05, 0.2 * s) for s, d in zip(b1["single_field"], b1["damage_gradient"]))
    mf = b2["multi_field"]
    dfg_ok = all(abs(d - m) <= 0.1 * abs(m) for d, m in zip(b2["damage_gradient"], mf))
    sf_ok = all(abs(s) <= 0.1 * abs(m) for s, m in zip(b2["single_field"], mf))
    b3_ok = all(v == {"C1": 0, "C2": 0, "C3": 0, "C4": 0} for v in report["B3"].values())
    names = {"single_field": "SF", "multi_field": "MF", "damage_gradient": "DFG"}
    gap = ", ".join(f"{names[n]} {report['B4'][n]:.3g}" for n in names)
    closest = ", ".join(f"{report['B4_closest'][n]:.3g}" for n in names)
    b4_ok = min(report["B4"]["multi_field"], report["B4"]["damage_gradient"]) >= -0.1
    rows = [
        ["B1: e(SF, MF)", values(b1["single_field"], ".3g"), "", ""],
        ["B1: e(DFG, MF)", values(b1["damage_gradient"], ".2g"), "<= 0.2 e(SF, MF) and <= 0.05", verdict(b1_ok)],
        ["B2: slip, MF (mm)", values(mf, ".4g"), "", ""],
        ["B2: slip, DFG", values(b2["damage_gradient"], ".4g"), "within 10 % of MF", verdict(dfg_ok)],
        ["B2: slip, SF", values(b2["single_field"], ".2g"), "<= 10 % of MF", verdict(sf_ok)],
        ["B3: C.1-C.4 violations, MF and DFG",
         str(sum(sum(v.values()) for v in report["B3"].values())), "0 (pair forces exact negatives)",
         verdict(b3_ok)],
        ["B4: smallest gap between billet and platen particle domains, cells (closest centres, spacings)",
         f"{gap} ({closest})", "gap >= -0.1 h", verdict(b4_ok)],
    ]
    return results.table(["check", f"t = {values(report['times'], '.4g')} us", "required", ""], rows)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--out", default="out/billet")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    scene = Scene.from_toml(scenes.path("billet"), args.set)
    end = scene.time.end
    runs = run_variants(scene, [end / 4, end / 2, end])
    names = [b.name for b in scene.bodies]
    billet, platen = names.index("billet"), names.index("platen")
    report = {"times": [], "B1": {"single_field": [], "damage_gradient": []},
              "B2": {v: [] for v in runs}, "B3": {}, "B4": {}, "B4_closest": {}}
    ref = runs["multi_field"]
    for k, (t, _, v_mf) in enumerate(ref["states"]):
        report["times"].append(t)
        mine = ref["body"] == billet
        for name in ("single_field", "damage_gradient"):
            v = runs[name]["states"][k][2]
            report["B1"][name].append(relative_difference(v[mine, 0], v_mf[mine, 0], v_mf[mine, 0]))
        for name, r in runs.items():
            x = r["states"][k][1]
            report["B2"][name].append(interface_slip(r["x0"], x, r["body"], billet, platen, (1.0, 0.6)))
    for name, r in runs.items():
        if r["contact"] is not None:
            report["B3"][name] = {c: r["contact"][c] for c in ("C1", "C2", "C3", "C4")}
        report["B4"][name] = r["gap"]
        report["B4_closest"][name] = r["closest"]
    (out / "billet.json").write_text(json.dumps(report, indent=1))
    results.write(out, "billet", "docs/verification/billet.md", __file__, argv, {"checks": table(report)})
    print("t (us)      " + "  ".join(f"{t:10.4f}" for t in report["times"]))
    for name, e in report["B1"].items():
        print(f"B1 {name:16s}" + "  ".join(f"{x:10.3g}" for x in e))
    for name, s in report["B2"].items():
        print(f"B2 slip {name:16s}" + "  ".join(f"{x:10.3g}" for x in s))
    print("B3", report["B3"])
    print("B4 domain gap (cells)", {k: round(v, 3) for k, v in report["B4"].items()})
    print("B4 closest approach (spacings)", {k: round(v, 3) for k, v in report["B4_closest"].items()})
    return report


if __name__ == "__main__":
    main()
