"""The crack band of Rankine softening (docs/verification/crack-band.md):
the energy a bar pulled apart dissipates per unit crack area, over G_f, with
the default l_ch (the grid's localisation width) or a given one.

The bar (``prestressed_bar``, which tests/test_damage.py runs too): 20 x 2
between fixed walls, nu = 0, pre-stretched to 0.85 sigma_f, a weak band (0.8 sigma_f) at its
middle, on a node line or (``--offset 0.5``) in the middle of a cell; with
``--dim 3`` a bar 20 x 2 x 2 with free sides. Prints one row per case: the
dissipation over G_f A (A the crack's area, H or H^2), and the particle
columns that failed (D = 1) and that were damaged without failing.

    OMP_NUM_THREADS=1 .venv/bin/python tools/crack_band.py
    OMP_NUM_THREADS=1 .venv/bin/python tools/crack_band.py --h 0.5 --shape bspline --l_ch 0.7071
    OMP_NUM_THREADS=2 .venv/bin/python tools/crack_band.py --dim 3 --shape bspline --h 1 0.5
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from pfmpm import Simulation
from pfmpm.scene import (Body, Box, Contact, GridSpec, NeoHookeanSpec, RankineSpec, Rectangle, Scene,
                         Time, WallSpec)

SHAPES = {"bspline": (2, "bspline"), "cubic": (3, "bspline"), "cpdi": (1, "cpdi")}
"""Stencils by name: (grid degree, shape)."""


def prestressed_bar(h: float, shape: str = "bspline", partition: str | None = None,
                    l_ch: float | None = None, band_cells: float = 2.0, offset: float = 0.0,
                    cfl: float = 0.5, end: float = 4.0, Gf: float = 0.02,
                    parting: str = "softened", dim: int = 2) -> tuple[Simulation, np.ndarray]:
    """The bar, set up: 20 x 2 (in 3D 20 x 2 x 2, free sides) between fixed
    walls, nu = 0, pre-stretched to sigma_xx = 0.85 sigma_f, its band
    ``band_cells`` cells wide (centred ``offset`` cells off the node line at
    its middle) of strength 0.8. Returns the simulation and the band's
    particles."""
    L, H, y0, mu, s0 = 20.0, 2.0, 4.0, 50.0, 0.85
    degree, kind = SHAPES[shape]
    if dim == 2:
        size, body = (L, H + 8.0), Rectangle((0.0, y0), (L, y0 + H))
    else:  # two cells around the bar across: with nu = 0 its sides stay where they are
        size, body = (L, H + 4.0, H + 4.0), Box((0.0, 2.0, 2.0), (L, 2.0 + H, 2.0 + H))
    scene = Scene(name="bar", grid=GridSpec(size=size, h=h, degree=degree, shape=kind),
                  time=Time(end=end, cfl=cfl),
                  materials=(NeoHookeanSpec(name="m", E=100.0, nu=0.0, density=1.0,
                                            damage=RankineSpec(sigma_f=1.0, Gf=Gf, l_ch=l_ch)),),
                  bodies=(Body(name="bar", material="m", shape=body, particles_per_cell=2),),
                  walls=(WallSpec(side="left", type="fixed"), WallSpec(side="right", type="fixed")),
                  contact=Contact(partition=partition, parting=parting) if partition else None)
    sim = Simulation(scene)
    P = sim.particles
    stretch = (s0 + math.sqrt(s0 * s0 + 4 * mu * mu)) / (2 * mu)  # sigma = mu (l^2 - 1) / l
    F = np.eye(dim)
    F[0, 0] = stretch
    P.F[:] = F.ravel()
    P.J[:] = stretch
    P.mass[:] /= stretch  # the lattice is the stretched bar: V = l V_0
    P.stress[:] = 0.0
    P.stress[:, 0] = s0  # xx, the first of the symmetric layout in 2D and 3D
    band = np.abs(P.x[:, 0] - L / 2 - offset * h) < band_cells * h / 2
    P.sigma_f[band] = 0.8
    return sim, band


def bar(h: float, shape: str, partition: str | None, l_ch: float | None, **options) -> dict:
    """Run the bar of :func:`prestressed_bar` to its end and measure its band."""
    sim, _ = prestressed_bar(h, shape, partition, l_ch, **options)
    x0 = sim.particles.x[:, 0].copy()
    sim.advance(sim.scene.steps())
    D = sim.particles.damage
    columns = lambda sel: len(np.unique(np.round(x0[sel], 9)))  # noqa: E731
    Gf, area = sim.scene.materials[0].damage.Gf, 2.0 ** (sim.scene.dim - 1)
    return {"dissipation": sim.energies()["damage_dissipation"] / (Gf * area),
            "failed_columns": columns(D == 1.0), "damaged_columns": columns((D > 1e-3) & (D < 1.0)),
            "l_ch": sim.scene.materials[0].damage.length(sim.scene.grid)}


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--h", type=float, nargs="+", default=[1.0, 0.5, 0.25])
    p.add_argument("--shape", nargs="+", default=list(SHAPES), choices=list(SHAPES))
    p.add_argument("--partition", nargs="+", default=["single", "damage_gradient"],
                   choices=["single", "damage_gradient"])
    p.add_argument("--l_ch", type=float, help="l_ch (default: the grid's localisation width)")
    p.add_argument("--offset", type=float, default=0.0, help="the band's centre off the node line, in cells")
    p.add_argument("--parting", default="softened", choices=["softened", "failed"],
                   help="contact.parting of the damage-gradient runs")
    p.add_argument("--dim", type=int, default=2, choices=[2, 3], help="the bar in 2D or 3D")
    args = p.parse_args(argv)
    print("| stencil | partition | h | l_ch | dissipation / G_f A | failed columns | damaged columns |")
    print("|---|---|---|---|---|---|---|")
    for shape in args.shape:
        for partition in args.partition:
            for h in args.h:
                r = bar(h, shape, None if partition == "single" else partition, args.l_ch,
                        offset=args.offset, parting=args.parting, dim=args.dim)
                print(f"| {shape} | {partition} | {h:g} | {r['l_ch']:.4g} | {r['dissipation']:.3f} | "
                      f"{r['failed_columns']} | {r['damaged_columns']} |", flush=True)


if __name__ == "__main__":
    main()
