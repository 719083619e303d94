"""Wall milliseconds per step of a scene after 5 warm-up steps (docs/performance.md).

    python tools/steptime.py SCENE STEPS [KEY=VALUE ...]

KEY=VALUE are scene overrides, as ``pfmpm run --set`` takes them.
"""

import sys
import time

from pfmpm import Scene, Simulation

scene = Scene.from_toml(sys.argv[1], sys.argv[3:] + ["output.particles=false"])
sim = Simulation(scene)
sim.advance(5)
steps = int(sys.argv[2])
start = time.perf_counter()
sim.advance(steps)
print(f"{1000 * (time.perf_counter() - start) / steps:.1f}")
