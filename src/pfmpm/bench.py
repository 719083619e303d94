"""Throughput of the core step: on a synthetic block of particles
(:func:`bench`), and on the scenes users run (:func:`scenes_bench`)."""

from __future__ import annotations

import json
import math
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from . import _core
from .scene import (Anisotropy, Body, Box, Contact, Crack, FractureSpec, GridSpec, LinearElasticSpec, Output,
                    NeoHookeanSpec, PhaseFieldSpec, Rectangle, Scene, Time, TransferSpec)
from .simulation import Simulation

PHYSICS = ("elastic", "phasefield", "anisotropic", "contact", "damage_gradient")
MODELS = ("linear_elastic", "neo_hookean")
"""Material models the bench can run (``"neo_hookean"`` with ``elastic`` or ``contact`` only)."""


def block_scene(particles: int, degree: int = 2, per_cell: int = 3, physics: str = "elastic",
                model: str = "linear_elastic", bands: int = 1, shape: str = "bspline",
                transfer: str = "flip", dim: int = 2) -> Scene:
    """A square block of about ``particles`` points, ``per_cell`` per cell and
    direction, with a margin of empty cells; with ``dim=3`` a cube of them.

    ``physics="phasefield"`` makes the block crackable (l0 = 2 h, spectral
    split) with an initial crack from its left edge to its centre, and a
    toughness low enough that the bench's vibration raises the history field
    everywhere: the phase-field system changes at every node and step.
    ``physics="anisotropic"`` adds the fourth-order term with the Borden
    plate's cubic gamma (g1111 = 1, g1212 = 74) at 30 degrees.
    ``physics="contact"`` cuts the elastic block into two bodies along its
    vertical midline, each its own discrete field with frictional contact
    (mu = 0.3): the same particles as ``"elastic"``, with a line of contact
    nodes through the middle.
    ``physics="damage_gradient"`` is the elastic block with the
    damage-gradient partition (Homel & Herbold 2017) and a fully damaged
    band one cell wide along each midline (surface-flagged particles): every
    step computes the kernel damage field near the bands, Algorithms 1 and 2,
    and contact across them, where the block is cut in four. ``bands`` such
    bands per direction, evenly spaced, cut it into (bands + 1)^2 fragments:
    the share of particles near full damage grows with it.
    ``model="neo_hookean"`` makes the material neo-Hookean (H&H eq. 8 in one
    step, no damage) with the same E, nu and density; it has no phase field.
    ``shape="cpdi"`` (with ``degree=1``) maps with CPDI1 over the particle
    domains instead of B-splines at the centres. ``transfer="apic"`` moves
    momentum with APIC (``[transfer] scheme``). A cube (``dim=3``) is elastic
    (either model) on B-splines or CPDI, with ``physics="contact"`` cut in two along
    the plane x = its middle, each half its own field with frictional
    contact, and with ``physics="damage_gradient"`` (linear elastic) cut by
    failed planes one cell thick, ``bands`` per direction, into (bands + 1)^3
    fragments, and with ``physics="phasefield"`` cut by a crack patch from
    one face to its middle (the second-order phase field, AT2).
    """
    if bands < 1:
        raise ValueError(f"bands = {bands}: must be >= 1")
    if model not in MODELS:
        raise ValueError(f"model = {model!r}: must be one of {', '.join(MODELS)}")
    if model == "neo_hookean" and physics not in ("elastic", "contact"):
        raise ValueError(f"model = 'neo_hookean': physics must be elastic or contact, not {physics!r}")
    if dim not in (2, 3):
        raise ValueError(f"dim = {dim}: must be 2 or 3")
    if dim == 3:
        if physics not in ("elastic", "contact", "damage_gradient", "phasefield"):
            raise ValueError(f"dim = 3: physics must be elastic, contact, damage_gradient or phasefield (not"
                             f" {physics!r}): the fourth-order anisotropic phase field is two-dimensional")
        cells = max(4, math.ceil((particles / per_cell**3) ** (1 / 3) - 1e-9))
        lo, hi = 4.0, 4.0 + cells
        material = (NeoHookeanSpec(name="m", E=1.0, nu=0.3, density=1.0) if model == "neo_hookean"
                    else LinearElasticSpec(name="m", E=1.0, nu=0.3, density=1.0))
        if physics == "contact":  # two bodies, cut along the plane x = mid
            mid = lo + cells // 2
            boxes = {"left": Box(min=(lo,) * 3, max=(mid, hi, hi)), "right": Box(min=(mid, lo, lo), max=(hi,) * 3)}
        else:
            boxes = {"block": Box(min=(lo,) * 3, max=(hi,) * 3)}
        contact = Contact(friction=0.3) if physics == "contact" else None
        if physics == "damage_gradient":  # failed planes one cell thick normal to each direction
            at = [lo + cells * k // (bands + 1) for k in range(1, bands + 1)]
            cuts = tuple(Box(min=tuple(c - 0.5 if e == d else lo for e in range(3)),
                             max=tuple(c + 0.5 if e == d else hi for e in range(3)))
                         for c in at for d in range(3))
            contact = Contact(friction=0.3, partition="damage_gradient", surfaces=cuts)
        cracks, output = (), Output()
        if physics == "phasefield":  # a crack patch from the face x = lo to the middle, through z
            material = LinearElasticSpec(name="m", E=1.0, nu=0.3, density=1.0, fracture=FractureSpec(Gc=1e-5, l0=2.0))
            mid = lo + cells / 2
            cracks = (Crack(points=((lo, mid, lo), (mid, mid, lo), (mid, mid, hi), (lo, mid, hi))),)
            output = Output(crack_direction=(1.0, 0.0, 0.0))
        return Scene(name="bench-cube", grid=GridSpec(size=(cells + 8.0,) * 3, h=1.0, degree=degree, shape=shape),
                     time=Time(end=1.0), materials=(material,), cracks=cracks, output=output,
                     bodies=tuple(Body(name=name, material="m", shape=box, particles_per_cell=per_cell)
                                  for name, box in boxes.items()),
                     contact=contact, transfer=TransferSpec(transfer))
    cells = max(4, math.ceil(math.sqrt(particles / per_cell**2)))
    margin = 4
    side = cells + 2 * margin
    fracture, cracks = None, ()
    if physics in ("phasefield", "anisotropic"):
        cubic = Anisotropy("cubic", g1111=1.0, g1212=74.0) if physics == "anisotropic" else None
        fracture = FractureSpec(Gc=1e-5, l0=2.0, anisotropy=cubic)
        mid = margin + cells / 2
        cracks = (Crack(points=((float(margin), mid), (mid, mid))),)
    lo, hi = float(margin), float(margin + cells)
    contact = None
    if physics == "contact":
        mid = float(margin + cells // 2)
        shapes = {"left": Rectangle(min=(lo, lo), max=(mid, hi)), "right": Rectangle(min=(mid, lo), max=(hi, hi))}
        contact = Contact(friction=0.3)
    else:
        shapes = {"block": Rectangle(min=(lo, lo), max=(hi, hi))}
    if physics == "damage_gradient":
        at = [float(margin + cells * k // (bands + 1)) for k in range(1, bands + 1)]
        cuts = tuple(shape for c in at for shape in (Rectangle(min=(lo, c - 0.5), max=(hi, c + 0.5)),
                                                    Rectangle(min=(c - 0.5, lo), max=(c + 0.5, hi))))
        contact = Contact(friction=0.3, partition="damage_gradient", surfaces=cuts)
    return Scene(
        name="bench-block",
        grid=GridSpec(size=(float(side), float(side)), h=1.0, degree=degree, shape=shape),
        time=Time(end=1.0),
        cracks=cracks,
        materials=(NeoHookeanSpec(name="m", E=1.0, nu=0.3, density=1.0) if model == "neo_hookean"
                   else LinearElasticSpec(name="m", E=1.0, nu=0.3, density=1.0, fracture=fracture),),
        bodies=tuple(Body(name=name, material="m", shape=shape, particles_per_cell=per_cell,
                          orientation=30.0)
                     for name, shape in shapes.items()),
        # The first, cold fourth-order solve needs more than the default limit.
        phase_field=PhaseFieldSpec(max_iterations=100_000),
        contact=contact,
        transfer=TransferSpec(transfer),
    )


def bench(physics: str = "elastic", particles: int = 1_000_000, steps: int = 20, repeats: int = 3,
          degree: int = 2, model: str = "linear_elastic", per_cell: int | None = None, bands: int = 1,
          shape: str = "bspline", transfer: str = "flip", dim: int = 2) -> dict:
    """Time ``steps`` core steps ``repeats`` times and report the median
    (``per_cell`` particles per cell and direction, by default 3 in 2D and 2
    in 3D; ``bands`` damaged bands per direction with
    ``physics="damage_gradient"``; ``shape`` the shape functions,
    ``transfer`` the particle-grid transfer and ``dim`` the dimension,
    :func:`block_scene`).

    The block vibrates in a smooth mode (velocity amplitude 1e-3 of the wave
    speed), so strains and stresses are nonzero and nothing leaves the grid.
    Besides the speed it reports the peak memory per particle, as
    :func:`scene_bench` does (the process's peak resident size less its size
    before the block was built, over the particle count: so in a process of
    its own, as ``pfmpm bench`` runs it).
    """
    if physics not in PHYSICS:
        raise ValueError(f"physics = {physics!r}: must be one of {', '.join(PHYSICS)}")
    if per_cell is None:
        per_cell = 3 if dim == 2 else 2
    resident = rss_bytes()
    sim = Simulation(block_scene(particles, degree, per_cell, physics=physics, model=model, bands=bands,
                                 shape=shape, transfer=transfer, dim=dim))
    x = sim.particles.x
    lo, hi = x.min(axis=0), x.max(axis=0)
    s = (x - lo) / (hi - lo)
    for d in range(dim):  # v_x of y, v_y of x (2D); v_x of y, v_y of z, v_z of x (3D)
        sim.particles.v[:, d] = 1e-3 * np.sin(np.pi * s[:, (d + 1) % dim])
    sim.solver.adaptive_threads = False  # the kernels on the threads asked for
    sim.advance(2)  # warm-up: allocations, first sort
    before = _damage_seconds(sim)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        sim.advance(steps)
        times.append(time.perf_counter() - start)
    seconds = statistics.median(times)
    n = len(sim.particles)
    stats = sim.solver.phase_field_stats()
    peak = peak_rss_bytes()
    return {
        "physics": physics,
        "model": model,
        "dim": dim,
        "degree": degree,
        "per_cell": per_cell,
        "shape": shape,
        "transfer": transfer,
        "particles": n,
        "steps": steps,
        "repeats": repeats,
        "threads": _core.num_threads(),
        "seconds": seconds,
        "particle_steps_per_s": n * steps / seconds,
        "peak_bytes_per_particle": (peak - resident) / n,
        "phase_field_iterations_per_step": stats["iterations"] / max(stats["solves"], 1),
        "contact_nodes": (sim.solver.contact_stats() or {"nodes": 0})["nodes"],
        **({"bands": bands} if physics == "damage_gradient" else {}),
        **_damage_share(sim, before, sum(times)),
    }


def _damage_seconds(sim: Simulation) -> dict:
    """Seconds so far in each block of the damage-gradient partition (empty without it)."""
    part = sim.solver.damage_partition()
    return dict(part["seconds"]) if part else {}


def _damage_share(sim: Simulation, before: dict, total: float) -> dict:
    """With the damage-gradient partition: the share of the timed steps spent in
    each of its blocks (particle damage, neighbour list, kernel gradient,
    Algorithms 1-2 and slots) and the neighbour-list builds so far."""
    if not before:
        return {}
    after = _damage_seconds(sim)
    return {"damage_share": {k: (after[k] - before[k]) / total for k in after},
            "neighbour_builds": sim.solver.damage_partition()["neighbour_builds"]}


def rss_bytes() -> int:
    """Resident set size of this process now."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024
    return 0


def peak_rss_bytes() -> int:
    """The largest resident set size of this process so far (``ru_maxrss``)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def scene_bench(path: Path | str, steps: int = 20, overrides: list[str] | tuple[str, ...] = ()) -> dict:
    """Time ``steps`` steps of a scene file after the warm-up steps
    (``_core.thread_warmup_steps``), in this process.

    Returns particle-steps per second, CG iterations per phase-field solve,
    how many of the timed steps the thread governor ran on fewer threads than
    the user's count, and the peak memory per particle: the process's peak resident size
    (``ru_maxrss``) less its size before the scene was built, over the
    particle count, so it holds the core's arrays, the solver's grid and
    phase-field storage and the Python copies the set-up makes. Run one scene
    per process (:func:`scenes_bench`) for a peak of its own.
    """
    from .scene import Scene

    before = rss_bytes()
    scene = Scene.from_toml(path, list(overrides) + ["output.particles=false"])
    sim = Simulation(scene)
    # Warm-up: allocations, the first sort, the cold phase-field solve and the
    # first probe of the thread count (the solver's ThreadGovernor), so that
    # the timed steps run as a long run's do.
    sim.advance(_core.thread_warmup_steps)
    solves, iterations = (sim.solver.phase_field_stats()[k] for k in ("solves", "iterations"))
    reduced = sim.solver.reduced_thread_steps
    start = time.perf_counter()
    sim.advance(steps)
    seconds = time.perf_counter() - start
    stats = sim.solver.phase_field_stats()
    peak = peak_rss_bytes()
    n = len(sim.particles)
    solved = stats["solves"] - solves
    return {
        "scene": scene.name,
        "particles": n,
        "steps": steps,
        "threads": _core.num_threads(),
        "reduced_thread_steps": sim.solver.reduced_thread_steps - reduced,  # of the timed steps
        "seconds": seconds,
        "particle_steps_per_s": n * steps / seconds,
        "cg_iterations_per_solve": (stats["iterations"] - iterations) / solved if solved else 0.0,
        "peak_bytes_per_particle": (peak - before) / n,
    }


def scenes_bench(paths: list[Path | str], steps: int = 20,
                 overrides: list[str] | tuple[str, ...] = ()) -> list[dict]:
    """:func:`scene_bench` of each scene in a process of its own, in order."""
    rows = []
    for path in paths:
        args = [sys.executable, "-m", "pfmpm.bench", str(path), "--steps", str(steps)]
        for o in overrides:
            args += ["--set", o]
        r = subprocess.run(args, capture_output=True, text=True)
        if r.returncode != 0:
            raise RuntimeError(f"{path}: {r.stderr.strip().splitlines()[-1] if r.stderr.strip() else r.returncode}")
        rows.append(json.loads(r.stdout))
    return rows


def markdown_table(rows: list[dict]) -> str:
    """The rows of :func:`scenes_bench` as a Markdown table."""
    lines = ["| scene | particles | threads | M particle-steps/s | CG iterations per solve |"
             " peak bytes per particle |", "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['scene']} | {r['particles']} | {r['threads']} | "
                     f"{r['particle_steps_per_s'] / 1e6:.2f} | {r['cg_iterations_per_solve']:.1f} | "
                     f"{r['peak_bytes_per_particle']:.0f} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    import argparse

    parser = argparse.ArgumentParser(description="scene_bench of one scene, as one JSON object")
    parser.add_argument("scene")
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--set", action="append", default=[], dest="overrides")
    a = parser.parse_args()
    print(json.dumps(scene_bench(a.scene, a.steps, a.overrides)))
