"""Velocity sweep of the disk-beam impact: does a Hertzian cone crack form?

Kakouris & Triantafyllou (2019), section 5.3: 33 runs from 0.02 to 0.18 mm/us in
steps of 0.005, snapshots at t = 16 us; a cone forms above about 0.10 mm/us.

Each run is the disk-beam scene at the disk speed ``v``, to ``--end`` us, at
the resolution given by ``--h`` (l0 = 2 h); its cone index is
:func:`benchmarks.disk_beam.measure.cone_index` at the end.  Writes ``sweep.csv`` (v, beta,
beam fracture energy, cone crack area, wall time) and ``cone_index.png`` to
``--out``.

    .venv/bin/python benchmarks/disk_beam/cone_sweep.py --out out/sweep            # h = 0.5 mm
    .venv/bin/python benchmarks/disk_beam/cone_sweep.py --h 0.25 --out out/sweep   # finer, slower
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np

if str(Path(__file__).resolve().parents[2]) not in sys.path:  # run as a file: the root holds ``benchmarks``
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks.disk_beam.measure import cone_index  # noqa: E402
from pfmpm import plots, scenes  # noqa: E402
from pfmpm.scene import Scene  # noqa: E402
from pfmpm.simulation import Simulation  # noqa: E402


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--h", type=float, default=0.5, help="cell size, mm (l0 = 2 h)")
    parser.add_argument("--end", type=float, default=16.0, help="end time, us")
    parser.add_argument("--vmin", type=float, default=0.02)
    parser.add_argument("--vmax", type=float, default=0.18)
    parser.add_argument("--dv", type=float, default=0.005)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="more overrides of every run's scene")
    parser.add_argument("--out", default="out/disk_beam_sweep")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    l0 = 2 * args.h
    speeds = np.round(np.arange(args.vmin, args.vmax + 0.5 * args.dv, args.dv), 6)
    rows = []
    for v in speeds:
        scene = Scene.from_toml(scenes.path("disk_beam"), [
            f"grid.h={args.h}", f"materials.beam.fracture.l0={l0}", f"materials.disk.fracture.l0={l0}",
            f"time.end={args.end}", f"bodies.disk.velocity=[0.0, {-v}]", *args.set])
        sim = Simulation(scene)
        start = time.perf_counter()
        sim.advance(scene.steps())
        wall = time.perf_counter() - start
        p = sim.particles
        beta, area = cone_index(scene, p.x, p.body, p.c, p.volume, "beam", scene.body("disk").shape.center[0])
        fracture = sim.energies()["fracture_beam"]
        rows.append({"v": v, "beta": beta, "fracture_beam": fracture, "cone_area": area, "wall_s": wall})
        print(f"v = {v:.3f} mm/us: beta = {beta}, off-axis crack {area:.3g} mm^2, "
              f"beam fracture energy {fracture:.4g} mJ ({wall:.0f} s)", flush=True)
    with open(out / "sweep.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)

    plt = plots.plt
    fig, ax = plt.subplots(figsize=(6, 3))
    ax.step([r["v"] for r in rows], [r["beta"] for r in rows], where="mid", marker="o")
    ax.set_xlabel("disk speed (mm/us)")
    ax.set_ylabel("cone index beta")
    ax.set_yticks([0, 1])
    ax.set_title(f"Hertzian cone at t = {args.end:g} us, h = {args.h:g} mm")
    fig.tight_layout()
    fig.savefig(out / "cone_index.png", dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
