"""Fracture energy of the disk-beam's running crack, counted as the paper counts it.

Kakouris & Triantafyllou (2019), section 5.3, read the beam's fracture energy
when its flexural crack starts to run and again when it has run through the
depth, and compare the difference with A_f G_c (case i: 311.82 - 94.29 =
217.53 mJ against 212.13 mJ). This script runs the disk-beam scene (with
``--set`` overrides as for ``pfmpm run``) and every ``--every`` steps records
how far the crack has risen from the bottom face along the impact line
(:func:`benchmarks.disk_beam.measure.crack_rise`) and the beam's fracture energy. It prints
the samples and then :func:`benchmarks.disk_beam.measure.running_crack` of them:

- start: the last sample before the crack appears at the bottom face;
- end: the first sample at which the crack has reached its final height;
- the energy between them against A_f G_c (the paper's measure);
- the energy per unit rise while the crack runs from 20 to 80 % of the
  depth (a least-squares slope) against G_c times the thickness;
- at the last sample, the part of the beam's fracture energy held by the
  particles within 5 l0 of the impact line (an AT2 crack keeps 99 % of its
  energy there), against G_c times the crack's area.

Writes ``running_crack.csv`` (t, rise, beam fracture energy) to ``--out``.

``--line X`` follows a crack rising along x = X instead of the impact line
(an AT1 beam cracks twice, under the edges of the contact, and not under its
centre), and then counts only the fracture energy of the half of the beam on
that side of the impact line: by symmetry, that crack's share.

    .venv/bin/python benchmarks/disk_beam/running_crack.py --out out/disk_beam_energy
    .venv/bin/python benchmarks/disk_beam/running_crack.py --set grid.h=0.125 --out out/dbe_fine
    .venv/bin/python benchmarks/disk_beam/running_crack.py --set materials.beam.fracture.model=AT1 \
        --set materials.disk.fracture.model=AT1 --line 19.5 --out out/dbe_at1
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import numpy as np

if str(Path(__file__).resolve().parents[2]) not in sys.path:  # run as a file: the root holds ``benchmarks``
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks.disk_beam.measure import crack_rise, running_crack  # noqa: E402
from pfmpm import scenes  # noqa: E402
from pfmpm.scene import Scene  # noqa: E402
from pfmpm.simulation import Simulation  # noqa: E402


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--every", type=int, default=20, help="steps between samples")
    parser.add_argument("--out", default="out/disk_beam_energy")
    parser.add_argument("--line", type=float, default=None,
                        help="x (mm) of the vertical line the crack rises along (default: the impact"
                             " line); counts the beam's half on that side")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    scene = Scene.from_toml(scenes.path("disk_beam"), args.set)
    index = [b.name for b in scene.bodies].index("beam")
    impact_x = scene.body("disk").shape.center[0]  # the impact line
    line_x = impact_x if args.line is None else args.line
    sim = Simulation(scene)

    def beam_energy() -> float:
        """The beam's fracture energy, or with --line that of its half on the line's side."""
        if args.line is None:
            return sim.energies()["fracture_beam"]
        per_particle = sim.particles.fracture_energy
        side = np.sign(line_x - impact_x) * (sim.particles.x[:, 0] - impact_x) > 0
        return float(per_particle[(sim.particles.body == index) & side].sum())

    rows = []
    total = scene.steps()
    while True:
        p = sim.particles
        rows.append({"t": sim.time, "rise": crack_rise(scene, p.x, p.body, p.c, "beam", line_x),
                     "fracture_beam": beam_energy()})
        print(f"t = {rows[-1]['t']:6.2f} us  crack rise {rows[-1]['rise']:5.2f} mm  "
              f"beam fracture energy {rows[-1]['fracture_beam']:7.2f} mJ", flush=True)
        if sim.step >= total:
            break
        sim.advance(min(args.every, total - sim.step))
    with open(out / "running_crack.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)

    t, rise, energy = (np.array([r[k] for r in rows]) for k in ("t", "rise", "fracture_beam"))
    r = running_crack(scene, "beam", t, rise, energy)
    if not r:
        print("the crack did not reach the bottom face")
        return
    per_length = scene.fracture_of(scene.bodies[index]).Gc * scene.thickness  # mJ per mm of rise
    print(f"start {r['t_start']:.2f} us ({r['energy_start']:.2f} mJ), end {r['t_end']:.2f} us "
          f"({r['energy_end']:.2f} mJ, crack {r['rise_end']:.2f} of {r['depth']:g} mm)")
    print(f"running crack: {r['running']:.2f} mJ = {r['per_rise']:.3f} x G_c t rise "
          f"({per_length * r['rise_end']:.2f} mJ); {r['per_area']:.3f} x A_f G_c"
          f" ({per_length * r['depth']:.2f} mJ)")
    if np.isfinite(r["slope"]):
        print(f"while running (20-80 % of the depth): {r['slope'] * per_length:.2f} mJ/mm"
              f" = {r['slope']:.3f} x G_c t")
    l0 = scene.fracture_of(scene.bodies[index]).l0
    p = sim.particles
    band = (p.body == index) & (np.abs(p.x[:, 0] - line_x) < 5 * l0)
    held = float(p.fracture_energy[band].sum())
    print(f"at {t[-1]:.2f} us: {held:.2f} of {energy[-1]:.2f} mJ within 5 l0 of the line, "
          f"{held / (per_length * rise.max()):.3f} x G_c t rise")


if __name__ == "__main__":
    main()
