"""Where the modified Charpy runs lose (or gain) energy: three diagnostics.

``split``
    Runs the charpy scene (with ``--set`` overrides) and splits each step's
    change of the balance ``total`` into the kinematic part, dK + dF + P
    (the transfers, the grid update and contact; F the friction
    dissipation), and the material part,
    dW + dD - P (the constitutive update: stored energy and damage
    dissipation against the work done on the material). P is the stress
    power, sum_p V sigma : (F^{n+1} (F^n)^-1 - I) with V and sigma the means
    of their values before and after the step (eq. 8 makes dt L exactly
    F^{n+1} (F^n)^-1 - I). Prints the running sums.
``prefailed``
    A band of failed particles (D = 1) at t = 0 along the notch's line, the
    box y in [27, 28], x in [``--start``, 8] (the notch root) of the bar's
    ``[[initial_damage]]``, the strength of every other particle raised so
    that nothing else fails: the largest rise of ``total`` over 20 us, and
    the contact-check counts. From x < 0 the band reaches the face the
    striker presses, where three fields (the bar's two sides and the
    striker) share nodes.
``release``
    A free bar 20 x 2 (E = 100, nu = 0, rho = 1, 2 particles per cell)
    stretched to sigma_xx = 0.5 and released at t = 0, once with a line of
    failed particles at its middle (``[[initial_damage]]``, a band along
    x = 12; the damage-gradient partition: its two
    sides part at once) and once without (released only at its free ends):
    the change of ``total`` by t = 1 (one P-wave transit of a half) and
    t = 4, over the stored energy. ``--set`` applies to its grid
    (``grid.degree=1``, ``grid.shape=cpdi``).

    .venv/bin/python benchmarks/charpy/diagnose.py split
    .venv/bin/python benchmarks/charpy/diagnose.py split --set contact.partition=bodies
    .venv/bin/python benchmarks/charpy/diagnose.py prefailed --start -1
    .venv/bin/python benchmarks/charpy/diagnose.py release --h 0.5
    .venv/bin/python benchmarks/charpy/diagnose.py release --h 0.5 --set grid.degree=1 --set grid.shape=cpdi
"""

from __future__ import annotations

import argparse
import dataclasses
import math

import numpy as np

from pfmpm import scenes
from pfmpm.scene import (Body, Contact, GridSpec, InitialDamage, NeoHookeanSpec, RankineSpec,
                         Rectangle, Scene, Time)
from pfmpm.simulation import Simulation


def stress_power(F0, F1, s0, s1, V0, V1) -> float:
    """sum_p V sigma : (F1 F0^-1 - I), V and sigma the means over the step
    (stress as xx, yy, xy, zz; F as xx, xy, yx, yy)."""
    det = F0[:, 0] * F0[:, 3] - F0[:, 1] * F0[:, 2]
    i00, i01, i10, i11 = F0[:, 3] / det, -F0[:, 1] / det, -F0[:, 2] / det, F0[:, 0] / det
    a00 = F1[:, 0] * i00 + F1[:, 1] * i10 - 1.0
    a01 = F1[:, 0] * i01 + F1[:, 1] * i11
    a10 = F1[:, 2] * i00 + F1[:, 3] * i10
    a11 = F1[:, 2] * i01 + F1[:, 3] * i11 - 1.0
    s, V = 0.5 * (s0 + s1), 0.5 * (V0 + V1)
    return float(np.sum(V * (s[:, 0] * a00 + s[:, 1] * a11 + s[:, 2] * (a01 + a10))))


def split(sim: Simulation, every: int) -> dict:
    """Advance ``sim`` to its end, summing the kinematic and material parts of
    each step's change of ``total``; print the sums every ``every`` steps."""
    P = sim.particles
    sums = {"kinematic": 0.0, "material": 0.0, "total": 0.0}
    e0 = sim.energies()
    while sim.step < sim.scene.steps():
        F, stress, volume = P.F.copy(), P.stress.copy(), P.volume.copy()
        sim.advance(1)
        e1 = sim.energies()
        power = stress_power(F, P.F, stress, P.stress, volume, P.volume)
        sums["kinematic"] += (e1["kinetic"] - e0["kinetic"] + e1.get("friction_dissipation", 0.0)
                              - e0.get("friction_dissipation", 0.0) + power)
        sums["material"] += (e1["elastic"] - e0["elastic"] + e1.get("damage_dissipation", 0.0)
                             - e0.get("damage_dissipation", 0.0) - power)
        sums["total"] += e1["total"] - e0["total"]
        e0 = e1
        if sim.step % every == 0 or sim.step == sim.scene.steps():
            print(f"t = {sim.time:6.2f} us: kinematic {sums['kinematic']:8.2f}, material "
                  f"{sums['material']:7.2f}, total {sums['total']:8.2f} mJ", flush=True)
    return sums


def prefailed_simulation(sets: list[str], start: float) -> Simulation:
    """The charpy scene to 20 us (with ``sets``), its band of failed particles
    from x = ``start`` set (see the module docstring)."""
    scene = Scene.from_toml(scenes.path("charpy"), ["time.end=20", *sets])
    band = InitialDamage(body="target", min=(start, 27.0), max=(8.0, 28.0))
    sim = Simulation(dataclasses.replace(scene, initial_damage=(*scene.initial_damage, band)))
    P = sim.particles
    # Every other particle too strong to fail, by hand: the scene's check of
    # l_ch < 2 E Gf / sigma_f^2 refuses such a strength.
    P.sigma_f[P.damage < 1.0] = 1e9
    return sim


def prefailed(sets: list[str], start: float) -> dict:
    """The pre-failed band run (see the module docstring)."""
    sim = prefailed_simulation(sets, start)
    e0 = sim.energies()["total"]
    rise = -math.inf
    while sim.step < sim.scene.steps():
        sim.advance(10)
        rise = max(rise, sim.energies()["total"] - e0)
    stats = sim.solver.contact_stats()
    return {"rise": rise, "violations": {k: stats[k] for k in ("C1", "C2", "C3", "C4")}}


def release(h: float, crack: bool, sets: tuple[str, ...] = ()) -> dict:
    """The released bar (see the module docstring): d total / W0 at t = 1 and 4."""
    E, s0, L = 100.0, 0.5, 20.0
    scene = Scene(name="release", grid=GridSpec(size=(L + 4.0, 10.0), h=h), time=Time(end=4.0, cfl=0.4),
                  materials=(NeoHookeanSpec(name="m", E=E, nu=0.0, density=1.0,
                                            damage=RankineSpec(sigma_f=1.0, Gf=0.02, l_ch=2 * h)),),
                  bodies=(Body(name="bar", material="m", shape=Rectangle((2.0, 4.0), (2.0 + L, 6.0)),
                               particles_per_cell=2),),
                  contact=Contact(partition="damage_gradient"),
                  initial_damage=(InitialDamage(points=((2.0 + L / 2, 0.0), (2.0 + L / 2, 10.0)),
                                                half_width=0.3 * h),) if crack else ())
    scene = Scene.from_dict(scene.to_dict(), list(sets))
    sim = Simulation(scene)
    P = sim.particles
    mu = E / 2.0
    stretch = (s0 + math.sqrt(s0 * s0 + 4.0 * mu * mu)) / (2.0 * mu)  # sigma = mu (l^2 - 1) / l
    P.F[:] = (stretch, 0.0, 0.0, 1.0)
    P.J[:] = stretch
    P.mass[:] /= stretch  # the lattice is the stretched bar
    P.sigma_f[:] = 1e9
    e0 = sim.energies()["total"]
    out = {}
    for t in (1.0, 4.0):
        sim.advance(int(round(t / scene.dt())) - sim.step)
        out[f"t{t:g}"] = sim.energies()["total"] / e0 - 1.0
    return out


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("diagnostic", choices=("split", "prefailed", "release"))
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="overrides of the charpy scene (split, prefailed), of the bar's grid (release)")
    parser.add_argument("--start", type=float, default=-1.0, help="prefailed: the band's start x (mm)")
    parser.add_argument("--h", type=float, default=0.5, help="release: the cell size")
    parser.add_argument("--every", type=int, default=200, help="split: print every this many steps")
    args = parser.parse_args(argv)
    if args.diagnostic == "split":
        return split(Simulation(Scene.from_toml(scenes.path("charpy"), args.set)), args.every)
    if args.diagnostic == "prefailed":
        r = prefailed(args.set, args.start)
        print(f"band from x = {args.start:g}: largest rise of total {r['rise']:.2f} mJ, {r['violations']}")
        return r
    r = {"crack": release(args.h, True, args.set), "ends": release(args.h, False, args.set)}
    for name, v in r.items():
        print(f"released at {'a failed line' if name == 'crack' else 'its free ends only'}, h = {args.h:g}: "
              + ", ".join(f"d total / W0 = {x:+.4f} at {k[1:]}" for k, x in v.items()))
    return r


if __name__ == "__main__":
    main()
