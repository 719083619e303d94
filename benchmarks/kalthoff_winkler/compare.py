"""Kalthoff-Winkler (Homel & Herbold 2017, section 3.2, Fig. 11): checks K1-K5.

Runs the Kalthoff-Winkler scene with damage-gradient partitioning (DFG, the
scene as it is), as the single field (SF: the target one field, the impactor
still its own, :func:`pfmpm.post.self_contact.body_fields`) and, for K5, DFG
with G_f = 22.3 N/mm (Table II's print), sampling the crack from the notch
tip every 0.5 us (:func:`pfmpm.post.kalthoff_winkler.run_crack`), and
measures (:func:`pfmpm.post.kalthoff_winkler.report`):

- K1: the crack angle, from the failed particles 5-30 mm from the notch tip
  above the notch's line when the tip has passed 30 mm: their bearing from
  the tip and their least-squares line (paper: DFG 59.1, SF 60.8 degrees;
  XFEM 60, experiment about 70);
- K2: the tip's speed over 40-50 us (paper: DFG 2.0, SF 1.7 km/s; the
  Rayleigh speed is 2.80 km/s);
- K3: where damage first becomes full (within 2 h of the notch tip), and
  until when one arm of the crack's band crosses circles of 10, 20 and 30 mm
  about the tip (one crack, no branching, until at least 60 us);
- K4: the x momentum, conserved to round-off (the symmetry plane acts in y);
- K5: the angle's change with G_f = 22.3.

Prints them, writes ``kalthoff_winkler.json`` and ``crack_paths.png`` (the
failed particles of each run coloured by the time they failed, and the
tip's distance against time) to ``--out``.

    .venv/bin/python benchmarks/kalthoff_winkler/compare.py --out out/kalthoff_winkler
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from pfmpm import scenes
from pfmpm.post.fragments import failed
from pfmpm.post.kalthoff_winkler import report, run_crack
from pfmpm.post.self_contact import body_fields
from pfmpm.scene import Scene

RAYLEIGH = 2.803
"""Rayleigh speed of Table II's steel, mm/us (shared/benchmarks-homel-herbold.md section 0.1)."""


def variants(scene: Scene, sensitivity: bool) -> dict[str, Scene]:
    """The runs: DFG, SF and (with ``sensitivity``) DFG with G_f = 22.3 N/mm."""
    runs = {"damage_gradient": scene, "single_field": body_fields(scene)}
    if sensitivity:
        runs["damage_gradient_Gf_22.3"] = Scene.from_dict(scene.to_dict(),
                                                          ["materials.target.damage.Gf=22.3"])
    return runs


def plot(runs: dict, out: Path) -> None:
    """crack_paths.png: per run the failed target particles coloured by when they
    failed; and the tip's distance from the notch tip against time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(runs) + 1, figsize=(4.2 * (len(runs) + 1), 4.2))
    for ax, (name, r) in zip(axes, runs.items()):
        target = r["body"] == 0
        x = r["x"][target]
        ax.scatter(x[:, 0], x[:, 1], s=0.2, c="0.85", rasterized=True)
        broken = failed(r["damage"][target])
        art = ax.scatter(x[broken, 0], x[broken, 1], s=1.5, c=r["failed_at"][target][broken],
                         cmap="viridis", vmin=0.0, vmax=r["rows"][-1]["t"])
        ax.plot(*r["tip"], "r+", ms=8)
        ax.set_xlim(0, 102)
        ax.set_ylim(0, 102)
        ax.set_aspect("equal")
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("y [mm]")
        ax.set_title(f"{name}: angle {r['report']['angle']:.1f} deg", fontsize=9)
    fig.colorbar(art, ax=axes[len(runs) - 1], label="failed at t [us]")
    ax = axes[-1]
    for name, r in runs.items():
        t = [row["t"] for row in r["rows"]]
        ax.plot(t, [row["tip"] for row in r["rows"]], label=f"{name}: {r['report']['speed']:.2f} km/s")
    ax.axvspan(40.0, 50.0, color="0.9")
    ax.set_xlabel("t [us]")
    ax.set_ylabel("tip distance from the notch tip [mm]")
    ax.legend(fontsize=7, title="speed over 40-50 us", title_fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "crack_paths.png", dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--out", default="out/kalthoff_winkler")
    parser.add_argument("--no-sensitivity", action="store_true", help="skip the G_f = 22.3 run (K5)")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    scene = Scene.from_toml(scenes.path("kalthoff_winkler"), args.set)
    runs = {}
    for name, s in variants(scene, not args.no_sensitivity).items():
        r = run_crack(s)
        r["report"] = report(r, s.grid.h)
        r["report"]["contact"] = {k: r["contact"][k] for k in ("violations", "separable_nodes_last_step")
                                  if k in r["contact"]}
        runs[name] = r
    summary = {name: r["report"] for name, r in runs.items()}
    summary["speed_below_rayleigh"] = {name: bool(r["report"]["speed"] < RAYLEIGH)
                                       for name, r in runs.items()}
    if "damage_gradient_Gf_22.3" in runs:
        summary["K5_angle_change"] = abs(runs["damage_gradient_Gf_22.3"]["report"]["angle"]
                                         - runs["damage_gradient"]["report"]["angle"])
    (out / "kalthoff_winkler.json").write_text(json.dumps(summary, indent=1, default=float))
    plot(runs, out)
    for name, value in summary.items():
        print(name, json.dumps(value, default=float))
    return summary


if __name__ == "__main__":
    main()
