"""Drucker-Prager plasticity through the whole MPM: an oedometer test, a
block confined by slip walls on three sides and pushed down by its own top
face (a prescribed region). Every particle is in uniaxial strain, for which
the perfectly plastic cone has a closed form: with friction angle 0 (von
Mises, k = c) the block yields at |eps| = sqrt(3) c / (2 mu), after which
sigma_yy and sigma_xx both grow with the bulk modulus K, and the plastic
work per unit volume and unit strain past yield is (2 / sqrt(3)) c."""

import numpy as np
import pytest

from pfmpm.scene import Scene
from pfmpm.simulation import Simulation

E, NU, C = 100.0, 0.3, 0.2
MU = E / (2 * (1 + NU))
LAM = E * NU / ((1 + NU) * (1 - 2 * NU))
K = LAM + 2 * MU / 3
EPS_Y = np.sqrt(3) * C / (2 * MU)


def oedometer(U: float = 0.08, T: float = 30.0) -> Scene:
    """A 4 x 4 block on a 4 x 6 grid, slip walls left, right and below, its
    top face moved down by U over a smooth ramp of T (20 P-wave transits)."""
    return Scene.from_dict({
        "grid": {"size": [4.0, 6.0], "h": 0.5},
        "time": {"end": T},
        "materials": [{"name": "soil", "model": "drucker_prager", "E": E, "nu": NU, "density": 1.0,
                       "cohesion": C}],
        "bodies": [{"name": "block", "material": "soil", "particles_per_cell": 3,
                    "shape": {"type": "rectangle", "min": [0.0, 0.0], "max": [4.0, 4.0]}}],
        "walls": [{"side": side, "type": "slip"} for side in ("left", "right", "bottom")],
        "prescribed": [{"name": "piston", "body": "block", "face": "top", "components": "y",
                        "displacement": [0.0, -U], "amplitude": {"type": "ramp", "time": T}}],
        "output": {"particles": False},
    })


def test_an_oedometer_follows_the_closed_form_of_the_cone():
    sim = Simulation(oedometer())
    sim.advance(sim.scene.steps())
    p = sim.particles
    strain, stress = p.strain, p.stress
    # Uniaxial strain: no lateral strain. The top face's particles, held by
    # the piston, move rigidly; the rest is compressed past yield.
    assert np.max(np.abs(strain[:, 0])) < 1e-12
    eps = strain[:, 1]
    plastic = eps < -EPS_Y
    assert plastic.sum() > 0.8 * len(eps)
    # Per particle: elastic, sigma_yy = (lambda + 2 mu) eps and sigma_xx =
    # lambda eps; past yield, sigma = sigma(eps_y) + K (eps + eps_y) in both
    # directions; to 2e-4 relative (the ramp, 20 wave transits, is not
    # quite static: a particle that unloads a little leaves the monotonic path).
    past = np.minimum(eps + EPS_Y, 0.0)
    at = np.maximum(eps, -EPS_Y)  # the strain up to yield
    assert stress[:, 1] == pytest.approx((LAM + 2 * MU) * at + K * past, rel=2e-4, abs=1e-12)
    assert stress[:, 0] == pytest.approx(LAM * at + K * past, rel=2e-4, abs=1e-12)
    # The plastic work, summed by the core, against the closed form per
    # particle: (2 / sqrt(3)) c per unit volume and unit strain past yield,
    # on the current volume V = V_end exp(|eps| - s) at strain s (the volume
    # G2P keeps shrinks with the strain), integrated: V_end (exp(|eps| - eps_y) - 1).
    work = np.sum(p.volume * 2 / np.sqrt(3) * C * np.expm1(-past))
    assert sim.energies()["plastic_dissipation"] == pytest.approx(work, rel=2e-4)
