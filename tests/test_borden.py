"""The Borden plate (Kakouris & Triantafyllou 2019, section 5.1): dynamic crack
growth and branching, and stability on hard cases.

Units: mm, us, N, MPa; energies in J/m (N mm per mm of thickness).
"""

from pathlib import Path

import numpy as np
import pytest

from pfmpm import Scene, Simulation
from pfmpm.observe import CrackObserver
from pfmpm.scene import rayleigh_speed

DEMO = Path(__file__).resolve().parents[1] / "demos" / "borden_plate.toml"
NOTCH_TIP = np.array([50.0, 20.0])


def branched(sim, tip_x):
    """Whether the crack has two branches, above and below y = 20, in the
    column 4-6 mm behind the tip, with intact material on y = 20 between them."""
    x, c = sim.particles.x, sim.particles.c
    col = (x[:, 0] > tip_x - 6.0) & (x[:, 0] < tip_x - 4.0)
    cracked = x[col & (c < 0.2), 1]
    on_line = col & (np.abs(x[:, 1] - 20.0) < 0.5)
    return bool(cracked.size and cracked.min() < 18.0 and cracked.max() > 22.0
                and np.all(c[on_line] > 0.5))


def drive(scene, every=10):
    """Run ``scene``, checking the history field never decreases.

    Returns, every ``every`` steps, the energies with the crack-tip columns and
    a ``branched`` flag, and the final simulation.
    """
    sim = Simulation(scene)
    tips = CrackObserver(sim)
    rows = []
    history = sim.particles.history.copy()
    while sim.step < scene.steps():
        sim.advance(min(every, scene.steps() - sim.step))
        e = sim.energies()
        tips.record(sim, e, False)
        e["branched"] = branched(sim, e["crack_tip_x"])
        rows.append(e)
        now = sim.particles.history
        assert np.all(now >= history), f"history decreased by step {sim.step}"
        history = now.copy()
    return {k: np.array([r[k] for r in rows]) for k in rows[0]}, sim


def balance(e):
    """Energy balance error |K + E + F - W - (its value at t = 0)| relative to W."""
    drift = np.abs(e["total"] - e["total"][0])
    return drift, e["external_work"]


def test_borden_plate_default_resolution():
    # The demo's h = 0.25 mm and l0 = 0.5 mm; 2 x 2 particles per cell
    # (the demo has 3 x 3) and 56 us to keep the suite short: the tip leaves
    # y = 20 at about 37 us, and the two arms are apart 4-6 mm behind the tip
    # (branched) from 53.6 us (measured, 2026-12-07).
    scene = Scene.from_toml(DEMO, ["bodies.plate.particles_per_cell=2", "output.particles=false",
                                   "time.end=56"])
    e, _ = drive(scene)
    t, tip_x, tip_y, speed = e["t"], e["crack_tip_x"], e["crack_tip_y"], e["crack_tip_speed"]

    # The crack starts at the notch tip between 5 and 20 us: the tip first
    # moves l0 beyond where the initial crack's phase field reaches.
    start = t[np.argmax(tip_x > tip_x[0] + 0.5)]
    assert 5.0 < start < 20.0, f"crack initiation at {start} us"

    # It runs along y = 20 (while the tip is within 10 mm of the notch), then
    # branches into two cracks, above and below y = 20, before the right edge.
    first = np.argmax(e["branched"]) if e["branched"].any() else len(t) - 1
    print(f"initiation {start:.1f} us; branches seen at t = {t[first]:.1f} us, x = {tip_x[first]:.1f} mm;"
          f" max speed {speed.max():.3f} mm/us")
    assert np.all(np.abs(tip_y[tip_x < 60.0] - 20.0) < 1.0)
    assert e["branched"].any(), "no branching"
    assert tip_x[first] < 95.0, f"branches seen only at x = {tip_x[first]:.1f}"

    # The tip never runs faster than the Rayleigh wave.
    m = scene.materials[0]
    assert speed.max() < rayleigh_speed(m.E, m.nu, m.density)

    # Energy balance: kinetic + elastic + fracture - work stays within 2 % of
    # the work done (once the load has done work worth comparing against).
    drift, work = balance(e)
    loaded = t >= 2.0
    assert np.all(drift[loaded] <= 0.02 * work[loaded]), f"balance {np.max(drift[loaded] / work[loaded]):.3g}"


HARD = {
    "branching-2.3MPa": ["loads.0.traction=[0,2.3]", "loads.1.traction=[0,-2.3]", "time.end=100"],
    "cfl-0.98": ["time.cfl=0.98"],
}


@pytest.mark.parametrize("case", HARD, ids=list(HARD))
def test_hard_cases_stay_bounded(case):
    # Coarse (h = 0.5, l0 = 1) to keep the suite short: the point is
    # stability, not resolution.
    coarse = ["grid.h=0.5", "materials.concrete.fracture.l0=1.0",
              "bodies.plate.particles_per_cell=2", "output.particles=false"]
    scene = Scene.from_toml(DEMO, coarse + HARD[case])
    e, sim = drive(scene, every=50)
    assert sim.step == scene.steps()
    assert all(np.all(np.isfinite(v)) for v in e.values())
    drift, work = balance(e)
    # No energy appears beyond the work put in.
    assert np.all(e["total"] - e["total"][0] <= 0.02 * work + 1e-12)
