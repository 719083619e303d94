"""The measured numbers of the damage-gradient checks in docs/verification/damage-gradient.md.

Homel & Herbold (2017), checks of ``../shared/benchmarks-homel-herbold.md``:

- ``units``: U1 (uniform damage, zero gradient), U2 (a damaged row's
  particle gradients against its normal), U3 (a semicircular band's nodal
  gradients against its normal) and U4 (the surface flags of a rectangle);
- ``bar``: the impulse across the middle of a bar pulled apart, intact, with
  a failed band in one field, and split by the damage gradient;
- ``momentum``: two free disks meeting obliquely, in one group with surface
  flags and as two groups: the largest momentum change over sum M_p |v_p|.

``bar`` and ``momentum`` run with quadratic B-splines, or with ``--shape cpdi``
with CPDI1 on the degree-1 grid (the grids' ``SHAPES``).

Prints the numbers as JSON; ``tests/test_damage_gradient.py`` asserts them.

    OMP_NUM_THREADS=1 PYTHONPATH=src .venv/bin/python tools/dfg_checks.py units bar momentum
    OMP_NUM_THREADS=1 PYTHONPATH=src .venv/bin/python tools/dfg_checks.py --shape cpdi bar momentum
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from pfmpm import _core
from pfmpm.scene import Body, Contact, Disk, GridSpec, LinearElasticSpec, Rectangle, Scene, Time
from pfmpm.simulation import Simulation

MATERIAL = LinearElasticSpec("m", 100.0, 0.3, 1.0)
SHAPES = {"bspline": {"degree": 2}, "cpdi": {"degree": 1, "shape": "cpdi"}}
"""The grid keys of each shape: quadratic B-splines, or CPDI1 on the degree-1 grid."""


def lattice(x0: float, x1: float, y0: float, y1: float, spacing: float) -> np.ndarray:
    """Points at the centres of a square lattice of ``spacing`` filling [x0, x1] x [y0, y1]."""
    xs = np.arange(x0 + spacing / 2, x1, spacing)
    ys = np.arange(y0 + spacing / 2, y1, spacing)
    return np.array([(x, y) for x in xs for y in ys])


def uniform_damage() -> dict:
    """U1: a disk of radius 1.7 (spacing 0.125, h = 0.25) with D = 0, 0.37, 1."""
    radius = math.sqrt(2.0) * 0.25
    grid = _core.Grid(2, [24, 24], 0.25, [0.0, 0.0])
    x = lattice(0.0, 6.0, 0.0, 6.0, 0.125)
    x = x[np.hypot(x[:, 0] - 3.0, x[:, 1] - 3.0) <= 1.7]
    worst = 0.0
    for d in (0.0, 0.37, 1.0):
        _, D, G = _core.kernel_damage_field(grid, x, np.full(len(x), d), radius)
        worst = max(worst, float(np.hypot(*G.T).max() * radius), float(np.abs(D - d).max()))
    return {"particles": len(x), "max_gradient_times_radius_or_error": worst}


def damaged_row() -> dict:
    """U2: one row of D = 1 at y = 2.0625 in [1, 7] x [1, 3] (2 per cell, h = 0.25):
    the particles within r_p of it and r_p from the block's ends."""
    radius = math.sqrt(2.0) * 0.25
    grid = _core.Grid(2, [32, 16], 0.25, [0.0, 0.0])
    x = lattice(1.0, 7.0, 1.0, 3.0, 0.125)
    dy = x[:, 1] - 2.0625
    band = np.abs(dy) < 0.01
    _, _, G = _core.kernel_damage_field(grid, x, band.astype(float), radius)
    near = ~band & (np.abs(dy) < radius) & (x[:, 0] > 1.0 + radius) & (x[:, 0] < 7.0 - radius)
    angle = np.degrees(np.arctan2(np.abs(G[near, 0]), np.abs(G[near, 1])))
    return {"particles": int(near.sum()), "all_point_at_it": bool(np.all(G[near, 1] * dy[near] < 0.0)),
            "max_angle_deg": float(angle.max())}


def curved_band() -> dict:
    """U3: a semicircular band of radius 10 h (3 per cell): the nodal gradient
    (Algorithm 1) within a cell of the arc and 2 cells from its tips.

    Algorithm 1 runs only at the nodes where the fields may separate, whose
    mean damage exceeds D-bar_min (docs/contact.md, "Exact shortcut"); with
    D-bar_min = 0.1 every node within a cell of this one-cell band is one
    (with the default 0.25, 50 of the 56 are)."""
    h, radius, centre = 0.25, 2.5, np.array([4.0, 2.0])
    scene = Scene(grid=GridSpec(size=(8.0, 6.0), h=h, degree=2), time=Time(end=1.0), materials=(MATERIAL,),
                  bodies=(Body("block", "m", Rectangle((0.5, 0.5), (7.5, 5.5)), particles_per_cell=3),),
                  contact=Contact(partition="damage_gradient", separability=0.1))
    sim = Simulation(scene)
    p = sim.particles
    r = np.hypot(*(p.x - centre).T)
    p.surface[(np.abs(r - radius) < 0.5 * h) & (p.x[:, 1] > centre[1])] = 1
    sim.solver.prepare()
    rows = sim.solver.damage_partition()["nodal_gradient"]
    ny = sim.grid.nodes[1]
    # Node (i, j) of the quadratic open knot vector sits at ((i, j) - 0.5) h.
    d = np.column_stack([rows[:, 0] // ny, rows[:, 0] % ny]) * h - 0.5 * h - centre
    dist, polar = np.hypot(*d.T), np.arctan2(d[:, 1], d[:, 0])
    near = (np.abs(dist - radius) < h) & (polar > 2 * h / radius) & (polar < math.pi - 2 * h / radius)
    G = rows[near, 2:]
    cosine = np.abs(np.sum(G * d[near], axis=1)) / (np.hypot(*G.T) * dist[near])
    angle = np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))
    return {"nodes": int(near.sum()), "max_angle_deg": float(angle.max()),
            "mean_angle_deg": float(angle.mean())}


def rectangle_flags() -> dict:
    """U4: the kernel-sum surface flags (S < 0.99 S_bulk) of the rectangle
    [1, 5] x [1, 4], 2 per cell, h = 0.25."""
    scene = Scene(grid=GridSpec(size=(6.0, 5.0), h=0.25, degree=2), time=Time(end=1.0), materials=(MATERIAL,),
                  bodies=(Body("r", "m", Rectangle((1.0, 1.0), (5.0, 4.0)), particles_per_cell=2),),
                  contact=Contact(partition="damage_gradient"))
    sim = Simulation(scene)
    x = sim.particles.x
    ratio = np.asarray(sim.solver.detect_surfaces([0.125], 0.99))
    edge = np.minimum.reduce([x[:, 0] - 1.0, 5.0 - x[:, 0], x[:, 1] - 1.0, 4.0 - x[:, 1]])
    corner = int(np.argmin(np.hypot(x[:, 0] - 1.0625, x[:, 1] - 1.0625)))
    return {"two_outer_rows_exactly": bool(np.array_equal(sim.particles.surface == 1, edge < 0.25)),
            "corner_ratio": float(ratio[corner]),
            "third_row_min_ratio": float(ratio[(edge > 0.25) & (edge < 0.375)].min())}


def units() -> dict:
    return {"U1": uniform_damage(), "U2": damaged_row(), "U3": curved_band(), "U4": rectangle_flags()}


def bar_scene(partition: str | None, band: bool = True, h: float = 0.25,
              shape: str = "bspline") -> Scene:
    """A 10 x 2 bar whose halves move apart at 0.05; with ``band``, a band one cell
    wide across its middle of a material 1e8 times softer (failed), flagged as fully
    damaged under the damage gradient."""
    materials = (MATERIAL, LinearElasticSpec("failed", 1e-8 * MATERIAL.E, 0.3, 1.0))
    half = h / 2 if band else 0.0
    bodies = [Body("left", "m", Rectangle((1.0, 1.0), (6.0 - half, 3.0)), velocity=(-0.05, 0.0)),
              Body("right", "m", Rectangle((6.0 + half, 1.0), (11.0, 3.0)), velocity=(0.05, 0.0))]
    if band:
        bodies.append(Body("band", "failed", Rectangle((6.0 - half, 1.0), (6.0 + half, 3.0))))
    contact = None
    if partition == "damage_gradient":
        flags = (Rectangle((6.0 - half, 0.0), (6.0 + half, 4.0)),) if band else ()
        contact = Contact(partition="damage_gradient", groups=(tuple(b.name for b in bodies),),
                          surfaces=flags)
    return Scene(grid=GridSpec(size=(12.0, 4.0), h=h, **SHAPES[shape]), time=Time(end=4.0, cfl=0.5),
                 materials=materials, bodies=tuple(bodies), plane="strain", contact=contact)


def impulse_across(scene: Scene) -> tuple[float, Simulation]:
    """The impulse across the bar's middle over the run: the change of the x momentum
    of the particles right of it."""
    sim = Simulation(scene)
    p = sim.particles
    right = p.x[:, 0] > 6.0
    before = float(np.sum(p.mass[right] * p.v[right, 0]))
    sim.advance(scene.steps())
    return float(np.sum(p.mass[right] * p.v[right, 0])) - before, sim


def bar(shape: str = "bspline") -> dict:
    intact, _ = impulse_across(bar_scene(None, band=False, shape=shape))
    smeared, _ = impulse_across(bar_scene(None, shape=shape))
    parted, sim = impulse_across(bar_scene("damage_gradient", shape=shape))
    e, stats = sim.energies(), sim.solver.contact_stats()
    return {"intact": intact, "single_field": smeared, "damage_gradient": parted,
            "momentum": [e["momentum_x"], e["momentum_y"]],
            "separable_node_steps": stats["separable_total"], "active_pairs": stats["active"]}


def momentum(shape: str = "bspline") -> dict:
    """Two free disks (R = 1, h = 0.25) meeting obliquely at 0.5, mu_f = 0.3, for 3
    time units: the largest |p - p_0| over sum M_p |v_p| after every 1/30 of the run."""
    bodies = (Body("a", "m", Disk((2.0, 2.0), 1.0), velocity=(0.5, 0.0)),
              Body("b", "m", Disk((4.1, 2.6), 1.0)))
    runs = {"one_group_flagged": Contact(partition="damage_gradient", friction=0.3, groups=(("a", "b"),),
                                         surface_detection="kernel_sum"),
            "two_groups": Contact(partition="damage_gradient", friction=0.3)}
    out = {}
    for name, contact in runs.items():
        scene = Scene(grid=GridSpec(size=(8.0, 6.0), h=0.25, **SHAPES[shape]), time=Time(end=3.0, cfl=0.5),
                      materials=(MATERIAL,), bodies=bodies, plane="strain", contact=contact)
        sim = Simulation(scene)
        p = sim.particles
        scale = float(np.sum(p.mass * np.hypot(*p.v.T)))
        e = sim.energies()
        p0 = np.array([e["momentum_x"], e["momentum_y"]])
        worst, steps = 0.0, scene.steps()
        for _ in range(30):
            sim.advance(steps // 30)
            e = sim.energies()
            worst = max(worst, float(np.hypot(*(np.array([e["momentum_x"], e["momentum_y"]]) - p0))))
        s = sim.solver.contact_stats()
        out[name] = {"steps": steps // 30 * 30, "relative_change": worst / scale, "active_pairs": s["active"],
                     "separable_node_steps": s["separable_total"], "friction_work": s["friction_work"],
                     "violations": [s[c] for c in ("C1", "C2", "C3", "C4")]}
    return out


CHECKS = {"units": units, "bar": bar, "momentum": momentum}


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("checks", nargs="+", choices=sorted(CHECKS))
    parser.add_argument("--shape", choices=sorted(SHAPES), default="bspline",
                        help="shape functions of bar and momentum")
    args = parser.parse_args(argv)
    report = {name: CHECKS[name](**({} if name == "units" else {"shape": args.shape}))
              for name in args.checks}
    print(json.dumps(report, indent=1))
    return report


if __name__ == "__main__":
    main()
