"""Fracture energy of the disk-beam's running crack, counted as the paper counts it.

Kakouris & Triantafyllou (2019), section 5.3, read the beam's fracture energy
when its flexural crack starts to run and again when it has run through the
depth, and compare the difference with A_f G_c (case i: 311.82 - 94.29 =
217.53 mJ against 212.13 mJ). This script runs ``demos/disk_beam.toml`` (with
``--set`` overrides as for ``pfmpm run``) and every ``--every`` steps records
how far the crack has risen from the bottom face along the impact line (beam
particles with c < 0.2 within 2 l0 of it, in bins one cell high, counted from
the bottom while every bin is cracked) and the beam's fracture energy. It
prints the samples and then:

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

    .venv/bin/python -P demos/disk_beam_energy.py --out out/disk_beam_energy
    .venv/bin/python -P demos/disk_beam_energy.py --set grid.h=0.125 --out out/dbe_fine
    .venv/bin/python -P demos/disk_beam_energy.py --set materials.beam.fracture.model=AT1 \
        --set materials.disk.fracture.model=AT1 --line 19.5 --out out/dbe_at1
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

from pfmpm.scene import Scene
from pfmpm.simulation import Simulation

SCENE = Path(__file__).with_name("disk_beam.toml")
THRESHOLD = 0.2


def crack_rise(sim: Simulation, index: int, line_x: float) -> float:
    """Height (mm) to which the crack of body ``index`` (the beam) has risen
    from its bottom face along the vertical line ``x = line_x``."""
    scene = sim.scene
    beam = scene.bodies[index]
    (_, y0), (_, y1) = beam.shape.min, beam.shape.max
    l0, h = scene.fracture_of(beam).l0, scene.grid.h
    p = sim.particles
    near = (p.body == index) & (np.abs(p.x[:, 0] - line_x) < 2.0 * l0)
    y, c = p.x[near, 1], p.c[near]
    bins = np.floor((y - y0) / h).astype(int)
    cracked = np.zeros(int(round((y1 - y0) / h)) + 1, dtype=bool)
    inside = (bins >= 0) & (bins < len(cracked))
    cracked[bins[inside & (c < THRESHOLD)]] = True
    return float(np.argmin(cracked) if not cracked.all() else len(cracked)) * h


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--every", type=int, default=20, help="steps between samples")
    parser.add_argument("--out", default="out/disk_beam_energy")
    parser.add_argument("--line", type=float, default=None,
                        help="x (mm) of the vertical line the crack rises along (default: the impact"
                             " line); counts the beam's half on that side")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    scene = Scene.from_toml(SCENE, args.set)
    index = next(i for i, b in enumerate(scene.bodies) if b.name == "beam")
    beam = scene.bodies[index]
    impact_x = next(b for b in scene.bodies if b.name == "disk").shape.center[0]
    line_x = impact_x if args.line is None else args.line
    (_, y0), (_, y1) = beam.shape.min, beam.shape.max
    depth, fracture = y1 - y0, scene.fracture_of(beam)
    per_area = fracture.Gc * scene.thickness  # mJ per mm of crack rise
    sim = Simulation(scene)
    # Each crackable body's field keeps its own per-particle fracture energy.
    field = sum(scene.fracture_of(b) is not None for b in scene.bodies[:index])

    def beam_energy() -> float:
        """The beam's fracture energy, or with --line that of its half on the line's side."""
        if args.line is None:
            return sim.energies()["fracture_beam"]
        per_particle = sim.solver.state()["fields"]["phase_fields"][field]["fracture_energy"]
        side = np.sign(line_x - impact_x) * (sim.particles.x[:, 0] - impact_x) > 0
        return float(per_particle[(sim.particles.body == index) & side].sum())

    rows = []
    total = scene.steps()
    while True:
        rows.append({"t": sim.time, "rise": crack_rise(sim, index, line_x),
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

    t = np.array([r["t"] for r in rows])
    rise = np.array([r["rise"] for r in rows])
    energy = np.array([r["fracture_beam"] for r in rows])
    if rise.max() == 0.0:
        print("the crack did not reach the bottom face")
        return
    start = max(int(np.argmax(rise > 0.0)) - 1, 0)  # the first sample if the crack is there from the start
    end = int(np.argmax(rise >= rise.max()))
    expected = per_area * rise[end]
    print(f"start {t[start]:.2f} us ({energy[start]:.2f} mJ), end {t[end]:.2f} us "
          f"({energy[end]:.2f} mJ, crack {rise[end]:.2f} of {depth:g} mm)")
    print(f"running crack: {energy[end] - energy[start]:.2f} mJ = "
          f"{(energy[end] - energy[start]) / expected:.3f} x G_c t rise ({expected:.2f} mJ); "
          f"{(energy[end] - energy[start]) / (per_area * depth):.3f} x A_f G_c ({per_area * depth:.2f} mJ)")
    running = (rise >= 0.2 * depth) & (rise <= 0.8 * depth) & (np.arange(len(t)) <= end)
    if np.count_nonzero(running) >= 3:
        slope = np.polyfit(rise[running], energy[running], 1)[0]
        print(f"while running (20-80 % of the depth): {slope:.2f} mJ/mm = {slope / per_area:.3f} x G_c t")
    per_particle = sim.solver.state()["fields"]["phase_fields"][field]["fracture_energy"]
    band = (sim.particles.body == index) & (np.abs(sim.particles.x[:, 0] - line_x) < 5 * fracture.l0)
    held = float(per_particle[band].sum())
    print(f"at {t[-1]:.2f} us: {held:.2f} of {energy[-1]:.2f} mJ within 5 l0 of the line, "
          f"{held / (per_area * rise.max()):.3f} x G_c t rise")


if __name__ == "__main__":
    main()
