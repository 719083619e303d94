"""The measures of the disk-beam impact (K&T 2019, section 5.3): how far the
beam's crack has risen, its fracture energy counted as the paper counts it,
and the Hertzian cone index."""

from __future__ import annotations

import math

import numpy as np

from pfmpm.scene import Rectangle, Scene

__all__ = ["crack_rise", "running_crack", "cone_index"]


def _rectangle(scene: Scene, name: str) -> Rectangle:
    """The rectangle of body ``name``."""
    shape = scene.body(name).shape
    if not isinstance(shape, Rectangle):
        raise ValueError(f"body {name!r}: the disk-beam measures need a rectangle, not a {shape.kind}")
    return shape


def crack_rise(scene: Scene, x: np.ndarray, body: np.ndarray, c: np.ndarray, name: str,
               line_x: float) -> float:
    """Height to which a crack has risen from the bottom face of a rectangular
    body along the vertical line ``x = line_x``.

    The body's particles within 2 l0 of the line are put in bins one grid
    cell high from its bottom face; a bin is cracked when one of them has
    ``c`` below the scene's ``output.crack_threshold``; the rise is the
    height of the cracked bins counted from the bottom until the first
    uncracked one.

    Parameters
    ----------
    scene : Scene
    x : ndarray (N, 2)
        Particle positions.
    body : ndarray (N,)
        Body index of each particle.
    c : ndarray (N,)
        Phase field.
    name : str
        The rectangular body (the beam).
    line_x : float
        The vertical line (the impact line).

    Returns
    -------
    float
        A whole number of cells, from 0 to the body's depth rounded up to a cell.
    """
    index = [b.name for b in scene.bodies].index(name)
    beam = _rectangle(scene, name)
    (_, y0), (_, y1) = beam.min, beam.max
    l0, h = scene.fracture_of(scene.bodies[index]).l0, scene.grid.h
    near = (body == index) & (np.abs(x[:, 0] - line_x) < 2.0 * l0)
    y, cn = x[near, 1], c[near]
    bins = np.floor((y - y0) / h).astype(int)
    cracked = np.zeros(int(round((y1 - y0) / h)) + 1, dtype=bool)
    inside = (bins >= 0) & (bins < len(cracked))
    cracked[bins[inside & (cn < scene.output.crack_threshold)]] = True
    return float(np.argmin(cracked) if not cracked.all() else len(cracked)) * h


def running_crack(scene: Scene, name: str, t, rise, energy) -> dict:
    """The fracture energy of a running crack, as K&T read it (section 5.3).

    The paper reads the beam's fracture energy where its crack starts to run
    and where it has run through the depth, and compares the difference with
    ``A_f G_c`` (case i: 311.82 - 94.29 = 217.53 mJ against 212.13 mJ).

    Parameters
    ----------
    scene : Scene
    name : str
        The cracking rectangular body (the beam); ``G_c`` is its material's
        and ``A_f`` its depth times the scene's thickness.
    t, rise, energy : sequence of float
        Samples in time order: time, :func:`crack_rise` and the body's
        fracture energy.

    Returns
    -------
    dict
        Empty if the crack never reached the bottom face; else ``start``
        (the last sample before the crack appears at the bottom face, or the
        first sample if it is there from the start) and ``end`` (the first
        sample at which the crack reaches its final height) as indices,
        ``t_start``, ``t_end``, ``energy_start``, ``energy_end``,
        ``rise_end``, ``depth``, ``running`` (the energy between them),
        ``per_rise`` (``running`` over ``G_c t rise_end``), ``per_area``
        (``running`` over ``A_f G_c``: the paper's measure) and ``slope``,
        the energy per unit rise while the crack runs from 20 to 80 % of the
        depth (a least-squares slope) over ``G_c t``, NaN with fewer than 3
        such samples or a single rise among them.
    """
    t, rise, energy = (np.asarray(a, dtype=float) for a in (t, rise, energy))
    if rise.max() == 0.0:
        return {}
    beam = _rectangle(scene, name)
    depth = beam.max[1] - beam.min[1]
    per_length = scene.fracture_of(scene.body(name)).Gc * scene.thickness
    start = max(int(np.argmax(rise > 0.0)) - 1, 0)
    end = int(np.argmax(rise >= rise.max()))
    running = energy[end] - energy[start]
    sel = (rise >= 0.2 * depth) & (rise <= 0.8 * depth) & (np.arange(len(t)) <= end)
    fit = np.count_nonzero(sel) >= 3 and np.ptp(rise[sel]) > 0
    slope = np.polyfit(rise[sel], energy[sel], 1)[0] / per_length if fit else math.nan
    return {
        "start": start,
        "end": end,
        "t_start": float(t[start]),
        "t_end": float(t[end]),
        "energy_start": float(energy[start]),
        "energy_end": float(energy[end]),
        "rise_end": float(rise[end]),
        "depth": float(depth),
        "running": float(running),
        "per_rise": float(running / (per_length * rise[end])),
        "per_area": float(running / (per_length * depth)),
        "slope": float(slope),
    }


def cone_index(scene: Scene, x: np.ndarray, body: np.ndarray, c: np.ndarray, volume: np.ndarray,
               name: str, impact_x: float) -> tuple[int, float]:
    """Whether a Hertzian cone crack has formed in a rectangular body hit from above.

    The cone index beta is 1 when the body has crack (``c`` below the scene's
    ``output.crack_threshold``) in the middle half of its depth farther than
    a fifth of the depth from the impact line: crack that neither the
    flexural crack rising from the bottom under the impact (or its
    widening) nor the damage right under the contact explains, the inclined
    flanks of a cone running from the contact edges towards the bottom.

    Parameters
    ----------
    scene : Scene
    x : ndarray (N, 2)
        Particle positions.
    body : ndarray (N,)
        Body index of each particle.
    c : ndarray (N,)
        Phase field.
    volume : ndarray (N,)
        Particle volumes.
    name : str
        The rectangular body (the beam).
    impact_x : float
        The vertical impact line (the disk's centre).

    Returns
    -------
    (int, float)
        beta, and the area (volume over thickness) of that off-axis crack.
    """
    index = [b.name for b in scene.bodies].index(name)
    beam = _rectangle(scene, name)
    (_, y0), (_, y1) = beam.min, beam.max
    mine = body == index
    xs, ys, cs, vs = x[mine, 0], x[mine, 1], c[mine], volume[mine]
    depth = y1 - y0
    middle = (ys > y0 + 0.25 * depth) & (ys < y1 - 0.25 * depth)
    flank = (cs < scene.output.crack_threshold) & middle & (np.abs(xs - impact_x) > 0.2 * depth)
    area = float(vs[flank].sum()) / scene.thickness
    return int(area > 0.0), area
