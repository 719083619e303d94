"""Process CPU time of the bench block's steps, which a busy machine inflates
less than wall time (docs/performance/index.md).

    OMP_NUM_THREADS=1 python -P tools/cputime.py PHYSICS PARTICLES STEPS [PER_CELL [BANDS]] [--order rows]

prints M particle-steps per CPU second, the median of 3 runs of STEPS steps
after 2 warm-up steps, for the block of ``pfmpm bench`` (pfmpm.bench.block_scene,
PER_CELL particles per cell and direction, 3 by default, and BANDS damaged
bands with PHYSICS damage_gradient, 1 by default) set vibrating as the bench
sets it. ``--order rows`` first permutes every particle column into the order the
seeding had before it numbered the cells column by column: row by row (y
outer), a cell's particles in their seeded order, so that successive cells
of a transfer's column lie a grid row apart in memory. It measures what the
seeding order is worth (docs/performance/particle-count.md); not with
``damage_gradient``, whose neighbour lists are built before it.
"""

import argparse
import resource
import statistics

import numpy as np

from pfmpm.bench import block_scene
from pfmpm.simulation import Simulation

parser = argparse.ArgumentParser()
parser.add_argument("physics")
parser.add_argument("particles", type=int)
parser.add_argument("steps", type=int)
parser.add_argument("per_cell", type=int, nargs="?", default=3)
parser.add_argument("bands", type=int, nargs="?", default=1)
parser.add_argument("--order", choices=("seeding", "rows"), default="seeding")
args = parser.parse_args()
if args.order == "rows" and args.physics == "damage_gradient":
    parser.error("--order rows: not with damage_gradient, whose neighbour lists hold particle indices")
sim = Simulation(block_scene(args.particles, 2, args.per_cell, physics=args.physics, bands=args.bands))
P = sim.particles
if args.order == "rows":
    g = sim.scene.grid
    cx, cy = (np.floor((P.x[:, k] - g.origin[k]) / g.h).astype(np.int64) for k in (0, 1))
    perm = np.lexsort((np.arange(len(P)), cx, cy))
    for column in P.columns():
        values = getattr(P, column["name"])
        values[...] = values[perm]
x = P.x
lo, hi = x.min(axis=0), x.max(axis=0)
s = (x - lo) / (hi - lo)
P.v[:, 0] = 1e-3 * np.sin(np.pi * s[:, 1])
P.v[:, 1] = 1e-3 * np.sin(np.pi * s[:, 0])
sim.advance(2)


def cpu() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_utime


times = []
for _ in range(3):
    t = cpu()
    sim.advance(args.steps)
    times.append(cpu() - t)
print(f"{len(P) * args.steps / statistics.median(times) / 1e6:.2f}")
