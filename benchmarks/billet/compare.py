"""Billet compaction (Homel & Herbold 2017, section 3.1, Fig. 8): checks B1-B4.

Runs the billet scene three ways (:func:`pfmpm.post.self_contact.variants`):
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

Prints them and writes ``billet.json`` to ``--out``.

    .venv/bin/python benchmarks/billet/compare.py --out out/billet_A
    .venv/bin/python benchmarks/billet/compare.py --set materials.billet.E=190.0 --set time.end=4.0 --out out/billet_B
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from pfmpm import scenes
from pfmpm.post.self_contact import interface_slip, relative_difference, run_variants
from pfmpm.scene import Scene


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
