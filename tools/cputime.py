"""Process CPU time of the bench block's steps, which a busy machine inflates
less than wall time (docs/performance.md).

    OMP_NUM_THREADS=1 python -P tools/cputime.py PHYSICS PARTICLES STEPS [PER_CELL [BANDS]]

prints M particle-steps per CPU second, the median of 3 runs of STEPS steps
after 2 warm-up steps, for the block of ``pfmpm bench`` (pfmpm.bench.block_scene,
PER_CELL particles per cell and direction, 3 by default, and BANDS damaged
bands with PHYSICS damage_gradient, 1 by default) set vibrating as the bench
sets it.
"""

import resource
import statistics
import sys

import numpy as np

from pfmpm.bench import block_scene
from pfmpm.simulation import Simulation

physics, n, steps = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
per_cell, bands = (int(a) for a in (sys.argv[4:] + ["3", "1"][len(sys.argv[4:]):])[:2])
sim = Simulation(block_scene(n, 2, per_cell, physics=physics, bands=bands))
x = sim.particles.x
lo, hi = x.min(axis=0), x.max(axis=0)
s = (x - lo) / (hi - lo)
sim.particles.v[:, 0] = 1e-3 * np.sin(np.pi * s[:, 1])
sim.particles.v[:, 1] = 1e-3 * np.sin(np.pi * s[:, 0])
sim.advance(2)


def cpu() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_utime


times = []
for _ in range(3):
    t = cpu()
    sim.advance(steps)
    times.append(cpu() - t)
print(f"{len(sim.particles) * steps / statistics.median(times) / 1e6:.2f}")
