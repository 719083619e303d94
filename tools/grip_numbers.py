"""The grip rows of docs/verification/prescribed.md: the bar of
tests/test_prescribed.py pushed at V by a box of nodes and by its own left
face, in both methods: the reaction after the ramp over rho c V A, the mean
stress over 6 < x < 14 at the end over -rho c V, and the largest drift of the
energy balance over the grip's work.

    OMP_NUM_THREADS=1 .venv/bin/python tools/grip_numbers.py
"""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_prescribed import C, METHODS, RHO, V, face_scene, grip_scene, run  # noqa: E402

from pfmpm.post.forces import mean_forces  # noqa: E402

for name, scene in (("box", grip_scene()), ("face", face_scene(face="left"))):
    for method, cls in METHODS.items():
        sim = cls(scene)
        e = run(sim)
        f = mean_forces(scene, e)
        reaction = np.mean(f["region_grip_x"][f["t"] > 0.7]) / (RHO * C * V * 2.0)
        if method == "mpm":
            x, sigma = sim.particles.x[:, 0], sim.particles.stress[:, 0]
        else:
            x, sigma = sim._x[sim._dofs].mean(axis=1)[:, 0], sim.stresses()[:, 0]
        middle = (x > 6) & (x < 14)
        drift = np.max(np.abs(e["total"] - e["total"][0])) / e["work_grip"][-1]
        print(f"{name:5s} {method}: reaction / (rho c V A) = {reaction:.4f}, "
              f"stress / (-rho c V) = {np.mean(sigma[middle]) / (-RHO * C * V):.4f}, drift / work = {drift:.2%}")
