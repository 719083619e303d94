"""Wedge, disk and block (Homel & Herbold 2017, section 3.1, Fig. 9): checks W1-W4.

Runs the wedge-disk-block scene three ways (:func:`benchmarks.common.self_contact.variants`):
the single field (no-slip), the three bodies as contact groups (the
multi-field reference, mu_f = 0.1) and one group whose surfaces were flagged
at t = 0 (damage-gradient self-contact, the scene as it is), and measures:

- W1: the disk's rigid rotation (least-squares fit of its particle motion)
  at the end of each run, and |theta_DFG - theta_MF| against
  |theta_SF - theta_MF| and |theta_MF|;
- W2: the L2 difference of the particle positions from the multi-field
  run's, over the L2 norm of the multi-field displacements;
- W3: the smallest gap between the deformed domains of particles of
  different bodies over the run, in cells (0 at contact; at least -0.1
  required: :func:`pfmpm.post.fragments.domain_gap`), and the closest
  approach of their centres in particle spacings (1 at contact);
- W4: the x momentum against m_wedge a_x t while no wall acts in x (until the
  disk reaches the block), relative;
- the contact checks C.1-C.4.

Prints them and writes ``wedge_disk_block.json`` and the table of
docs/verification/wedge-disk-block.md (``benchmark_results.json``,
:mod:`benchmarks.common.results`) to ``--out``.

    .venv/bin/python benchmarks/wedge_disk_block/compare.py --out out/wedge
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

if str(Path(__file__).resolve().parents[2]) not in sys.path:  # run as a file: the root holds ``benchmarks``
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks.common import results  # noqa: E402
from benchmarks.common.self_contact import relative_difference, rigid_rotation, run_variants  # noqa: E402
from pfmpm import scenes  # noqa: E402
from pfmpm.scene import Scene  # noqa: E402

ORDER = ("single_field", "multi_field", "damage_gradient")
"""The runs in the order of the table's cells: SF / MF / DFG."""


def table(report: dict) -> dict:
    """The table of docs/verification/wedge-disk-block.md from ``report``
    (:func:`main`'s): a row per check, what it measured, what is required and
    whether it holds."""
    def each(key, fmt, names=ORDER):
        return " / ".join(format(report[key][n], fmt) for n in names)

    def verdict(ok):
        return "pass" if ok else "**fails**"

    w1, w2 = report["W1"], report["W2"]
    both = ("multi_field", "damage_gradient")
    rows = [
        ["W1: disk rotation (rad), SF / MF / DFG", each("W1", ".3f"), "", ""],
        ["W1: |theta_DFG - theta_MF|",
         f"{w1['dfg_over_sf']:.2g} of |theta_SF - theta_MF|; {w1['dfg_over_mf']:.2g} of |theta_MF|",
         "<= 0.15; <= 0.10", verdict(w1["dfg_over_sf"] <= 0.15 and w1["dfg_over_mf"] <= 0.10)],
        ["W2: position difference from MF, SF / DFG",
         f"{w2['single_field']:.3g} / {w2['damage_gradient']:.2g} "
         f"({w2['damage_gradient'] / w2['single_field']:.2g} of SF's)", "DFG <= 0.2 SF",
         verdict(w2["damage_gradient"] <= 0.2 * w2["single_field"])],
        ["W3: smallest gap between particle domains of different bodies, cells, SF / MF / DFG "
         "(closest centres, spacings)", f"{each('W3', '.2g')} ({each('W3_closest', '.3g')})",
         ">= -0.1 in MF and DFG", verdict(min(report["W3"][n] for n in both) >= -0.1)],
        ["W4: x momentum against m_wedge a_x t before the disk meets the block", each("W4", ".1e"),
         "< 1e-9", verdict(max(report["W4"].values()) <= 1e-9)],
        ["C.1-C.4 violations, MF and DFG", str(sum(sum(v.values()) for v in report["contact"].values())),
         "0", verdict(all(v == {"C1": 0, "C2": 0, "C3": 0, "C4": 0} for v in report["contact"].values()))],
    ]
    return results.table(["check", "measured", "required", ""], rows)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--out", default="out/wedge")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    scene = Scene.from_toml(scenes.path("wedge_disk_block"), args.set)
    runs = run_variants(scene, [scene.time.end], samples=40)
    names = [b.name for b in scene.bodies]
    wedge, disk = names.index("wedge"), names.index("disk")
    load = next(l for l in scene.loads if getattr(l, "body", None) == "wedge")
    report = {"W1": {}, "W2": {}, "W3": {}, "W3_closest": {}, "W4": {}, "contact": {}}
    for name, r in runs.items():
        t, x, _ = r["states"][-1]
        mine = r["body"] == disk
        report["W1"][name] = rigid_rotation(r["x0"][mine], x[mine])
        report["W3"][name] = r["gap"]
        report["W3_closest"][name] = r["closest"]
        # x momentum against the load's impulse before the block is pushed
        # (the first half of the run).
        m_wedge = float(r["mass"][r["body"] == wedge].sum())
        early = [(s, px) for s, px, _ in r["momentum"] if s <= 0.5 * scene.time.end]
        report["W4"][name] = max(abs(px - m_wedge * load.acceleration[0] * s) / (m_wedge * load.acceleration[0] * s)
                                 for s, px in early)
        if r["contact"] is not None:
            report["contact"][name] = {c: r["contact"][c] for c in ("C1", "C2", "C3", "C4")}
    x_mf = runs["multi_field"]["states"][-1][1]
    moved = x_mf - runs["multi_field"]["x0"]
    for name in ("single_field", "damage_gradient"):
        report["W2"][name] = relative_difference(runs[name]["states"][-1][1], x_mf, moved)
    theta = report["W1"]
    report["W1"]["dfg_over_sf"] = (abs(theta["damage_gradient"] - theta["multi_field"])
                                   / abs(theta["single_field"] - theta["multi_field"]))
    report["W1"]["dfg_over_mf"] = (abs(theta["damage_gradient"] - theta["multi_field"])
                                   / abs(theta["multi_field"]))
    (out / "wedge_disk_block.json").write_text(json.dumps(report, indent=1))
    results.write(out, "wedge_disk_block", "docs/verification/wedge-disk-block.md", __file__, argv,
                  {"checks": table(report)})
    for key, value in report.items():
        print(key, json.dumps(value))
    return report


if __name__ == "__main__":
    main()
