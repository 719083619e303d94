"""Self-contact against the multi-field reference (Homel & Herbold 2017, section 3.1).

A scene with ``partition = "damage_gradient"`` whose bodies share one contact
group meets itself through surface-flagged damage-gradient fields; the paper
compares it with the single field (no ``[contact]`` table: no-slip) and with
every body its own contact group (the multi-field reference). :func:`variants`
makes the three scenes, :func:`run_variants` runs them side by side, and the
functions below measure the billet's checks B1-B4 and the wedge's W1-W4
(``shared/benchmarks-homel-herbold.md`` sections 2 and 3).
"""

from __future__ import annotations

import math

import numpy as np

from pfmpm.post.fragments import closest_approach, domain_gap, particle_domains
from pfmpm.scene import Scene

__all__ = ["VARIANTS", "variants", "body_fields", "run_variants", "relative_difference",
           "interface_slip", "rigid_rotation"]

VARIANTS = ("single_field", "multi_field", "damage_gradient")
"""No-slip single field, every body its own contact group, and damage-gradient self-contact."""


def variants(scene: Scene) -> dict[str, Scene]:
    """The three runs of a self-contact scene: the scene itself (damage gradient),
    the same without ``[contact]`` (single field) and with every body its own
    discrete field with the scene's friction (multi-field, :func:`body_fields`)."""
    multi = body_fields(scene)
    single = {k: v for k, v in scene.to_dict().items() if k != "contact"}
    return {"single_field": Scene.from_dict(single), "multi_field": multi,
            "damage_gradient": scene}


def body_fields(scene: Scene) -> Scene:
    """A damage-gradient scene with every body its own velocity field and no
    partitioning (``partition = "bodies"``): the bodies meet by Coulomb
    contact with the scene's friction between them. It is the multi-field
    reference of :func:`variants`, and the single-field ("SF") run of the
    impact problems (Homel & Herbold 2017, sections 3.2-3.4), where the
    target is one body: unlike :func:`variants`' single field, a striker or
    platen is not welded to it, and only the crack faces' friction goes unused.
    The touch check (``touch_fill``) is the scene's."""
    contact = scene.contact
    if contact is None or not contact.damage_gradient:
        raise ValueError("a damage-gradient scene has partition = \"damage_gradient\"")
    return Scene.from_dict(dict(scene.to_dict(), contact={
        "friction": contact.friction, "touch_fill": contact.touch_fill,
        "pairs": [{"bodies": list(p.bodies), "friction": p.friction} for p in contact.pairs]}))


def run_variants(scene: Scene, times: list[float], samples: int = 20,
                 progress=None) -> dict[str, dict]:
    """Run the three variants of :func:`variants` to ``scene.time.end``.

    Returns, per variant: ``x0`` (initial positions), ``body``, ``mass``,
    ``states`` (per time of ``times``: the time, positions and velocities),
    ``closest`` (the smallest distance between particles of different bodies,
    in particle spacings) and ``gap`` (the smallest gap between their
    deformed domains, in cells: :func:`~pfmpm.post.fragments.domain_gap`),
    each over ``samples`` even times and those of ``times``,
    ``momentum`` (total momentum at each of them), ``contact`` (the contact
    record, or None) and ``steps``.
    """
    from pfmpm.simulation import Simulation

    out = {}
    for name, s in variants(scene).items():
        sim = Simulation(s)
        p = sim.particles
        steps = s.steps()
        marks = sorted({min(steps, int(round(t / s.dt()))) for t in times}
                       | {steps * k // samples for k in range(1, samples + 1)})
        want = {min(steps, int(round(t / s.dt()))) for t in times}
        record = {"x0": p.x.copy(), "body": p.body.copy(), "mass": p.mass.copy(), "states": [],
                  "closest": math.inf, "gap": math.inf, "momentum": [], "steps": steps}
        for mark in marks:
            sim.advance(mark - sim.step)
            record["closest"] = min(record["closest"], closest_approach(s, p.x, p.body))
            record["gap"] = min(record["gap"], domain_gap(s, p.x, p.body, *particle_domains(s, p)))
            e = sim.energies()
            record["momentum"].append((sim.time, e["momentum_x"], e["momentum_y"]))
            if mark in want:
                record["states"].append((sim.time, p.x.copy(), p.v.copy()))
            if progress:
                progress(name, sim.step, steps)
        record["contact"] = sim.solver.contact_stats()
        out[name] = record
    return out


def relative_difference(a: np.ndarray, b: np.ndarray, reference: np.ndarray) -> float:
    """||a - b|| / ||reference|| (L2 over all entries): the normalised difference of
    checks B1 and W2."""
    return float(np.linalg.norm(np.asarray(a) - np.asarray(b)) / np.linalg.norm(reference))


def interface_slip(x0: np.ndarray, x: np.ndarray, body: np.ndarray, lower: int, upper: int,
                   corner: tuple[float, float]) -> float:
    """Slip of check B2: the x displacement of the ``lower`` body's particle
    nearest ``corner`` (initially) minus that of the ``upper`` body's particle
    nearest to it at t = 0."""
    x0, x = np.asarray(x0), np.asarray(x)
    mine = np.flatnonzero(body == lower)
    a = mine[np.argmin(np.hypot(*(x0[mine] - corner).T))]
    theirs = np.flatnonzero(body == upper)
    b = theirs[np.argmin(np.hypot(*(x0[theirs] - x0[a]).T))]
    return float((x[a, 0] - x0[a, 0]) - (x[b, 0] - x0[b, 0]))


def rigid_rotation(x0: np.ndarray, x: np.ndarray) -> float:
    """The rotation angle (radians, counter-clockwise) of the least-squares rigid
    motion taking the points ``x0`` to ``x`` (check W1)."""
    a = np.asarray(x0) - np.mean(x0, axis=0)
    b = np.asarray(x) - np.mean(x, axis=0)
    return float(math.atan2(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]), np.sum(a * b)))
