"""The scheme's own energy loss on the sphere-on-disk scene: the disk alone
(no sphere, no contact, no damage: sigma_f = 1e7 MPa), set ringing by a
smooth velocity field, v_z = 0.05 cos(pi x / 24) cos(pi y / 24) and v_x =
0.02 sin(pi z / 6) mm/us, printing 1 - (kinetic + elastic) / (their value at
t = 0) every ``--every`` steps. It separates what the explicit step loses on
this disk at a resolution from what contact and failure lose
(docs/verification/sphere-disk.md, "Where the energy goes").

    OMP_NUM_THREADS=2 .venv/bin/python benchmarks/sphere_disk/free_disk.py --set grid.h=1.0 --every 60 --rows 2
    OMP_NUM_THREADS=2 .venv/bin/python benchmarks/sphere_disk/free_disk.py --set grid.h=0.5 --every 120 --rows 2
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from pfmpm import Scene, Simulation, scenes


def main(argv: list[str] | None = None) -> list[tuple[float, float]]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--set", action="append", default=[])
    parser.add_argument("--every", type=int, default=60)
    parser.add_argument("--rows", type=int, default=2)
    args = parser.parse_args(argv)
    scene = Scene.from_toml(scenes.path("sphere_disk"), ["materials.alumina.damage.sigma_f=1e7"] + args.set)
    scene = dataclasses.replace(scene, bodies=scene.bodies[:1], contact=None)
    sim = Simulation(scene)
    x, v = sim.particles.x, sim.particles.v
    v[:, 2] = 0.05 * np.cos(np.pi * x[:, 0] / 24.0) * np.cos(np.pi * x[:, 1] / 24.0)
    v[:, 0] = 0.02 * np.sin(np.pi * x[:, 2] / 6.0)
    e0 = sim.energies()["total"]
    rows = []
    for _ in range(args.rows):
        sim.advance(args.every)
        e = sim.energies()
        rows.append((e["t"], 1.0 - e["total"] / e0))
        print(f"t = {e['t']:.2f} us: lost {rows[-1][1]:.4f} of the energy")
    return rows


if __name__ == "__main__":
    main()
