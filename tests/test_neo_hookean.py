"""Finite strain in MPM runs (Homel & Herbold 2017, eqs. 8 and 22): a bar
stretched to twice its length against the closed-form uniaxial stress, and
the energy of a large-amplitude vibration. The single-point closed forms and
objectivity are checked in cpp/tests/test_neo_hookean.cpp."""

import math

import numpy as np
import pytest

from pfmpm import Scene, Simulation
from pfmpm.scene import Body, GridSpec, NeoHookeanSpec, Rectangle, Time, WallSpec

E, NU, RHO = 100.0, 0.3, 1.0
MU, LAME = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))


def uniaxial_lateral_stretch(l1: float) -> float:
    """l2 with sigma_yy = 0 in plane strain: mu (l2^2 - 1) + lambda ln(l1 l2) = 0 (Newton)."""
    l2 = 1.0
    for _ in range(60):
        l2 -= (MU * (l2 * l2 - 1) + LAME * math.log(l1 * l2)) / (2 * MU * l2 + LAME / l2)
    return l2


def grips_scene(integration="euler", L=16.0, H=2.0, ppc=4, stretch=2.0):
    """A bar L x H between two grips 2 long, each 1000 times as stiff and as
    dense (the same wave speed), with room to stretch the bar to `stretch`."""
    grip, margin = 2.0, 3.0
    x0 = margin + grip + (stretch - 1) * L / 2
    span = math.ceil(L * stretch + 2 * grip + 2 * margin + 2.0)
    y0 = 4.0
    materials = (NeoHookeanSpec(name="rubber", E=E, nu=NU, density=RHO, integration=integration),
                 NeoHookeanSpec(name="grip", E=1000 * E, nu=NU, density=1000 * RHO))
    bodies = (Body(name="bar", material="rubber", shape=Rectangle((x0, y0), (x0 + L, y0 + H)),
                   particles_per_cell=ppc),
              Body(name="left", material="grip", shape=Rectangle((x0 - grip, y0), (x0, y0 + H)),
                   particles_per_cell=ppc),
              Body(name="right", material="grip", shape=Rectangle((x0 + L, y0), (x0 + L + grip, y0 + H)),
                   particles_per_cell=ppc))
    return Scene(name="grips", grid=GridSpec(size=(float(span), H + 8.0), h=1.0),
                 time=Time(end=1.0, cfl=0.4), materials=materials, bodies=bodies)


@pytest.mark.parametrize("integration", ["euler", "exponential"])
def test_bar_stretched_to_twice_its_length_follows_the_uniaxial_closed_form(integration):
    # The grips are moving walls: their particles' velocity is set every step
    # to -v and +v, v rising and falling smoothly (1 - cos) over T, which is
    # 150 transit times of the bar's P wave, so that the stretch is nearly
    # quasi-static. Four particles per cell keep the bar a continuum at
    # twice its length. The middle 30 % is in uniaxial stress (sigma_yy = 0).
    L, stretch = 16.0, 2.0
    sim = Simulation(grips_scene(integration, L=L, stretch=stretch))
    P = sim.particles
    left, right, bar = P.body == 1, P.body == 2, P.body == 0
    c = math.sqrt((LAME + 2 * MU) / RHO)
    v_max = 0.004 * c
    T = (stretch - 1) * L / v_max  # each grip moves (stretch - 1) L / 2
    n = math.ceil(T / sim.dt)
    for k in range(n):
        v = v_max * (1 - math.cos(2 * math.pi * (k + 0.5) / n)) / 2
        P.v[left] = (-v, 0.0)
        P.v[right] = (v, 0.0)
        sim.advance(1)
    x = P.x[bar]
    mid = np.abs(x[:, 0] - x[:, 0].mean()) < 0.15 * L * stretch
    F, s = P.F[bar][mid], P.stress[bar][mid]
    l1 = F[:, 0].mean()
    assert l1 == pytest.approx(stretch, rel=0.01)
    l2 = uniaxial_lateral_stretch(l1)
    sxx = MU * (l1 * l1 - l2 * l2) / (l1 * l2)
    assert F[:, 3].mean() == pytest.approx(l2, rel=0.01)
    assert s[:, 0].mean() == pytest.approx(sxx, rel=0.01)
    assert abs(s[:, 1].mean()) < 0.01 * sxx
    # Each particle, not only the mean: within 2 % of the closed form.
    assert np.max(np.abs(s[:, 0] / sxx - 1)) < 0.02
    # The finite-strain stress, far from linear elasticity's E' (l1 - 1).
    assert sxx < 0.9 * E / (1 - NU * NU) * (l1 - 1)


def vibrating_bar(amplitude: float, periods: float = 10.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A bar 25 long fixed at x = 0 (a grid wall) released in its first
    fixed-free mode with velocity amplitude `amplitude`; times, momentum_x,
    total energy per step."""
    L, nu = 25.0, 0.0  # nu = 0: the bar speed is sqrt(E / rho) = 10, T = 4 L / c = 10
    scene = Scene(name="bar", grid=GridSpec(size=(30.0, 6.0), h=1.0),
                  time=Time(end=periods * 10.0, cfl=0.5),
                  materials=(NeoHookeanSpec(name="soft", E=E, nu=nu, density=RHO),),
                  bodies=(Body(name="bar", material="soft", shape=Rectangle((0.0, 2.0), (L, 4.0)),
                               particles_per_cell=3),),
                  walls=(WallSpec(side="left", type="fixed"),))
    sim = Simulation(scene)
    sim.particles.v[:, 0] = amplitude * np.sin(np.pi * sim.particles.x[:, 0] / (2 * L))
    e = sim.energies()
    t, px, total = [0.0], [e["momentum_x"]], [e["total"]]
    while sim.step < scene.steps():
        sim.advance(1)
        e = sim.energies()
        t.append(e["t"])
        px.append(e["momentum_x"])
        total.append(e["total"])
    return np.array(t), np.array(px), np.array(total)


def test_large_amplitude_vibration_keeps_its_energy_over_ten_periods():
    # Strain amplitude A / c = 5 %, where the neo-Hookean stress is 2.5 %
    # off the linear one: compare the period-averaged total energy of the
    # first and the tenth period (the explicit scheme's energy oscillates by
    # O(dt) within a period), and the end against the start.
    t, px, total = vibrating_bar(0.5)
    T = 10.0
    first, last = total[t < T].mean(), total[t > 9 * T].mean()
    assert abs(last - first) / first < 0.01
    assert abs(total[-1] - total[0]) / total[0] < 0.01
    # It did vibrate ten times: the momentum changed sign about 20 times.
    crossings = np.count_nonzero(np.sign(px[:-1]) * np.sign(px[1:]) < 0)
    assert 19 <= crossings <= 21
