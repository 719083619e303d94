"""The measures of the modified Charpy impact (benchmarks.charpy.measure) on manufactured data."""

import math

import numpy as np
import pytest

from benchmarks.charpy.measure import (contact_end, crack_band, energy_balance, fracture_energy,
                                       momentum_error)
from pfmpm import scenes
from pfmpm.output import ParticleSeries
from pfmpm.scene import Scene


def history():
    """A striker of KE0 = 1000 that loses 400 from t = 20 to 40: 350 to damage,
    10 to friction, 40 to the scheme; the stored energy rings about 0 after 40."""
    t = np.linspace(0.0, 100.0, 1001)
    lost = np.clip((t - 20.0) / 20.0, 0.0, 1.0)
    elastic = 50.0 * np.sin(np.pi * lost) + np.where(t > 40.0, 2.0 * np.sin(3.0 * t) ** 2, 0.0)
    kinetic = 1000.0 - 400.0 * lost - np.where(t > 40.0, 2.0 * np.sin(3.0 * t) ** 2, 0.0)
    kinetic[(t > 5.0) & (t < 6.0)] += 30.0  # a transient of 3 % during contact
    return {"t": t, "kinetic": kinetic, "elastic": elastic,
            "damage_dissipation": 350.0 * lost, "friction_dissipation": 10.0 * lost}


def test_energy_balance_splits_the_loss():
    r = energy_balance(history())
    assert r["KE0"] == 1000.0
    assert r["E_final"] == pytest.approx(600.0, abs=1e-9)
    assert r["dE"] == pytest.approx(400.0, abs=1e-9) and r["loss"] == pytest.approx(0.4)
    assert r["damage"] == pytest.approx(350.0) and r["friction"] == pytest.approx(10.0)
    assert r["numerical"] == pytest.approx(40.0, abs=1e-9)
    assert r["window"] == (70.0, 100.0)
    assert abs(r["drift"]) < 1e-12
    assert r["overshoot"] == pytest.approx(-0.4, abs=1e-9)


def test_energy_balance_window_and_overshoot():
    e = history()
    # The whole run: the transient at t = 5 is the largest E, 3 % above KE0.
    assert energy_balance(e, window=1.0)["overshoot"] == pytest.approx(0.03)
    assert energy_balance(e, after=10.0)["overshoot"] == pytest.approx(0.0, abs=1e-12)
    # A window reaching back into the loss sees a higher mean and a falling E.
    r = energy_balance(e, window=0.7)
    assert r["E_final"] > 600.0 and r["drift"] < 0.0
    # Without the dissipation columns (an elastic run) all of dE is numerical.
    elastic = {k: e[k] for k in ("t", "kinetic", "elastic")}
    assert energy_balance(elastic)["numerical"] == pytest.approx(400.0, abs=1e-9)
    with pytest.raises(ValueError, match="window = 0"):
        energy_balance(e, window=0.0)


def test_momentum_error():
    px = np.full(5, 1.0e5)
    py = np.zeros(5)
    px[3] += 2e-5
    py[4] = -3e-5
    assert momentum_error({"momentum_x": px, "momentum_y": py}) == pytest.approx(3e-10)


@pytest.fixture(scope="module")
def bar():
    scene = Scene.from_toml(scenes.path("charpy"))
    p = scene.particles()
    return scene, p["x"], p["body"]


def test_fracture_energy_of_the_scene(bar):
    scene, _, _ = bar
    # G_f A_f = 22.13 mJ/mm^2 x 8 mm x 2 mm (benchmarks section 5).
    assert fracture_energy(scene) == pytest.approx(354.08)
    # l_ch: the default, 2 h (H&H's cell diagonal, 1.414 mm, gave 1.44 G_f per unit area
    # in a bar: docs/verification/crack-band.md).
    assert scene.material_of(scene.body("target")).damage.length(scene.grid) == 2.0


def test_crack_band_of_a_straight_crack(bar):
    scene, x, body = bar
    target = body == 0
    D = np.zeros(len(x))
    # One cell (two particle rows, y = 27.25 and 27.75) across the 8 mm ligament.
    crack = target & (x[:, 1] > 27.0) & (x[:, 1] < 28.0) & (x[:, 0] < 8.0)
    D[crack] = 1.0
    D[target & (np.abs(x[:, 1] - 28.25) < 0.01)] = 0.9  # damaged, not failed
    r = crack_band(scene, x, D, body)
    assert r["paths"] == 1 and r["failed"] == 32 and r["in_band"] == 1.0
    assert r["from_root"] and r["across"] == 1.0
    assert r["width"] == pytest.approx(1.0) and r["column_width_median"] == pytest.approx(1.0)
    assert r["column_width_max"] == pytest.approx(1.0) and r["area"] == pytest.approx(8.0)
    # A second patch under the striker (4 particles) and the crack only half across.
    D[target & (x[:, 0] < 1.0) & (x[:, 1] > 10.0) & (x[:, 1] < 11.0)] = 1.0
    D[crack & (x[:, 0] < 4.0)] = 0.0
    r = crack_band(scene, x, D, body)
    assert r["paths"] == 2 and r["failed"] == 20 and r["in_band"] == pytest.approx(16 / 20)
    assert r["from_root"] and r["across"] == pytest.approx(0.5)
    assert r["width"] == pytest.approx(0.5) and r["column_width_median"] == pytest.approx(1.0)
    # A band three rows wide at one column, elsewhere two.
    D[:] = 0.0
    D[crack] = 1.0
    D[target & (np.abs(x[:, 1] - 26.75) < 0.01) & (np.abs(x[:, 0] - 3.25) < 0.01)] = 1.0
    r = crack_band(scene, x, D, body)
    assert r["column_width_max"] == pytest.approx(1.5) and r["column_width_median"] == pytest.approx(1.0)
    # A crack that misses the notch root: it starts 3 cells above the slot.
    D[:] = 0.0
    D[target & (x[:, 1] > 31.5) & (x[:, 1] < 32.5)] = 1.0
    assert not crack_band(scene, x, D, body)["from_root"]
    # Nothing failed.
    assert crack_band(scene, x, np.zeros(len(x)), body)["paths"] == 0


def test_contact_end_is_when_the_strikers_momentum_settles(bar, tmp_path):
    """Snapshots of the scene's particles whose striker slows down until t = 3
    and then keeps its momentum (its particles still vibrating about it)."""
    scene, x, body = bar
    striker = body == 1
    wobble = np.where(np.arange(len(x)) % 2 == 0, 1e-3, -1e-3)  # sums to zero over the striker
    assert abs(wobble[striker].sum()) < 1e-12
    series = ParticleSeries(tmp_path / "run")
    for step, speed in enumerate([0.02, 0.015, 0.011, 0.01, 0.01, 0.01]):
        v = np.zeros((len(x), 3))
        v[striker, 0] = speed + (wobble[striker] if step > 3 else 0.0)
        series.write(step, float(step), x, [("velocity", v, ""), ("body", body.astype(float), "")])
    assert contact_end(scene, tmp_path / "run") == 3.0
    # Still slowing at the last snapshot but one: contact has not ended.
    series.write(6, 6.0, x, [("velocity", np.where(striker[:, None], [0.009, 0.0, 0.0], 0.0), ""),
                             ("body", body.astype(float), "")])
    assert contact_end(scene, tmp_path / "run") is None
