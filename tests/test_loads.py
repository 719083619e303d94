"""Loads over time and on part of an edge (issue 53): a load's ``amplitude``
(a smooth ramp or a table) and a traction's ``span``, in both methods.

A bar loaded by a ramp slower than its wave period carries the load to its
fixed end without the step's twofold overshoot, and the energy balance
closes with the work of the changing load; a span loads its part of the edge
exactly; bad amplitudes and spans are one-line errors.
"""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pfmpm.output import read_csv
from pfmpm.post.forces import mean_forces
from pfmpm.scene import Ramp, Scene, SceneError, Table, Traction
from pfmpm.scene.toml import plain
from pfmpm.simulation import Simulation

from test_forces import history

ROOT = Path(__file__).resolve().parents[1]
BAR = ROOT / "demos" / "vibrating_bar.toml"
F = 0.1 * 2.0  # the bar's end load: traction x edge length x thickness 1
RAMP = ['loads.0.amplitude={type = "ramp", time = 20.0}', "time.end=40"]


def test_amplitudes_are_the_documented_functions():
    ramp = Ramp(10.0)
    assert [ramp(t) for t in (-1.0, 0.0, 2.5, 5.0, 10.0, 30.0)] == [0.0, 0.0, 0.15625, 0.5, 1.0, 1.0]
    # Zero rate at both ends (central differences over 2e-6 of the ramp).
    assert abs(ramp(1e-5) - ramp(-1e-5)) < 1e-9 and abs(ramp(10.0 + 1e-5) - ramp(10.0 - 1e-5)) < 1e-9
    table = Table((1.0, 2.0, 4.0), (0.0, 3.0, 1.0))
    assert [table(t) for t in (0.0, 1.5, 3.0, 9.0)] == [0.0, 1.5, 2.0, 1.0]


def check_ramped_bar(e, scene: Scene) -> None:
    """Against the same bar under a step: the fixed end's reaction is the load
    once the ramp is over (its mean over t > 25, to 0.1 %) and never
    overshoots to the step's 2 F (at most 1.1 F); the energy balance closes
    to 0.5 % of the work."""
    forces = mean_forces(scene, e)
    reaction, t = forces["wall_left_x"], forces["t"]
    assert np.mean(reaction[t > 25.0]) == pytest.approx(-F, rel=1e-3)
    assert np.max(np.abs(reaction)) < 1.1 * F
    drift = e["total"] - e["total"][0]
    assert np.max(np.abs(drift)) < 5e-3 * np.max(np.abs(e["external_work"]))
    # The momentum is the ramp's impulse (the integral of s^2 (3 - 2 s)) plus
    # the wall's, every row.
    s = np.clip(e["t"] / 20.0, 0.0, 1.0)
    load_impulse = F * np.where(e["t"] < 20.0, 20.0 * (s ** 3 - s ** 4 / 2), 10.0 + (e["t"] - 20.0))
    assert np.max(np.abs(e["momentum_x"] - load_impulse - e["impulse_left_x"])) < 2e-3 * F * e["t"][-1]


def test_a_ramped_load_reaches_its_static_reaction_without_overshoot():
    scene = Scene.from_toml(BAR, RAMP)
    check_ramped_bar(history(Simulation(scene), every=2), scene)


def test_the_fem_ramps_the_load_alike(tmp_path):
    scene = Scene.from_toml(BAR, RAMP)
    out = tmp_path / "fem"
    sets = [a for s in RAMP for a in ("--set", s)]
    r = subprocess.run([sys.executable, "-m", "pfmpm.fem", str(BAR), "--out", str(out), *sets, "--quiet"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    check_ramped_bar(read_csv(out / "energies.csv"), scene)


def test_each_step_takes_the_load_at_its_midpoint():
    scene = Scene.from_toml(BAR, ['loads.0.amplitude={type = "table", times = [0, 10], values = [0, 1]}'])
    sim = Simulation(scene)
    loaded = sim.particles.fext[:, 0] != 0.0
    assert not loaded.any()  # zero at t = 0
    sim.advance(3)
    layer = np.isclose(sim.particles.x[:, 0], sim.particles.x[:, 0].max(), atol=0.2)
    expected = (2.5 * sim.dt / 10.0) * 0.1 / 3.0  # a(t of the third step's midpoint) x traction x spacing
    np.testing.assert_allclose(sim.particles.fext[layer, 0], expected, rtol=1e-12)
    assert np.all(sim.particles.fext[~layer] == 0.0)


def test_a_span_loads_its_part_of_the_edge():
    """Half of the bar's right edge (y from 2 to 3 of 2 to 4): half the force,
    on the particles of that half, in both methods."""
    from pfmpm.fem import FemSimulation

    scene = Scene.from_toml(BAR, ["loads.0.span=[2.0, 3.0]"])
    sim = Simulation(scene)
    fext, x = sim.particles.fext, sim.particles.x
    assert fext[:, 0].sum() == pytest.approx(0.1 * 1.0, rel=1e-14)
    assert np.all(x[fext[:, 0] != 0.0, 1] < 3.0)
    fem = FemSimulation(scene)
    assert fem.external_force[:, 0].sum() == pytest.approx(0.1 * 1.0, rel=1e-14)


def test_amplitudes_and_spans_round_trip_through_toml():
    scene = Scene.from_toml(BAR, ['loads.0.amplitude={type = "table", times = [0, 1.5], values = [0, 2]}',
                                  "loads.0.span=[2.0, 3.5]"])
    assert scene.loads[0] == Traction("bar", "right", (0.1, 0.0), Table((0.0, 1.5), (0.0, 2.0)), (2.0, 3.5))
    assert Scene.from_dict(plain(scene)) == scene


@pytest.mark.parametrize("override, message", [
    ('loads.0.amplitude={type = "ramp", time = 0}', "loads[0].amplitude.time = 0: must be > 0"),
    ('loads.0.amplitude={type = "table", times = [0, 2, 1], values = [0, 1, 0]}',
     "loads[0].amplitude.times[2] = 1.0: must be greater than times[1] = 2.0"),
    ('loads.0.amplitude={type = "table", times = [0, 1], values = [1]}',
     "loads[0].amplitude.values = [1]: must have one value per time (2)"),
    ('loads.0.amplitude={type = "sine", period = 1}', "loads[0].amplitude.type = 'sine': must be one of"),
    ("loads.0.span=[3.0, 2.0]", "loads[0].span = [3.0, 2.0]: must be [a, b] with a < b"),
])
def test_bad_amplitudes_and_spans_are_named(override, message):
    with pytest.raises(SceneError) as error:
        Scene.from_toml(BAR, [override])
    assert str(error.value).startswith(message), str(error.value)


def test_a_span_off_the_edge_is_named():
    from pfmpm.fem import FemSimulation

    scene = Scene.from_toml(BAR, ["loads.0.span=[4.5, 6.0]"])
    with pytest.raises(SceneError, match=r"loads\[0\].span = \[4.5, 6.0\]: holds no particle of the right edge"
                                         r" layer of body 'bar'$"):
        Simulation(scene)
    with pytest.raises(SceneError, match=r"loads\[0\].span = \[4.5, 6.0\]: holds the midpoint of no cell edge"):
        FemSimulation(scene)
