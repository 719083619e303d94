"""Crack initiation and branching read from the crack-tip columns of a run's
``energies.csv`` (recorded by :class:`pfmpm.observe.CrackTip`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..observe import BRANCH_OFFSET
from ..output import read_csv
from ..scene import Crack

__all__ = ["INITIATION_ADVANCE", "BRANCH_OFFSET", "BRANCH_AFTER", "initiation_time", "branch_time", "read_columns",
           "crack_area"]

INITIATION_ADVANCE = 0.5
"""Crack initiation: the tip has moved this far (mm) past its position at t = 0."""
BRANCH_AFTER = 5.0
"""Branching (:func:`branch_time`): the tip lies BRANCH_OFFSET (mm) off the
notch line while this far (mm) ahead of the notch tip."""


def read_columns(csv_or_columns) -> Mapping[str, np.ndarray]:
    """Columns of an ``energies.csv`` given as a path or already read."""
    if isinstance(csv_or_columns, Mapping):
        return csv_or_columns
    return read_csv(Path(csv_or_columns))


def initiation_time(e, advance: float = INITIATION_ADVANCE) -> float:
    """First time ``crack_tip_x`` exceeds its value at t = 0 by ``advance``
    (in 3D ``crack_front``, the front's extent along ``output.crack_direction``).

    Parameters
    ----------
    e : path or mapping of str -> ndarray
        An ``energies.csv`` with crack-tip (or crack-front) columns, or its columns.
    advance : float
        Distance the tip has to move, in the units of the scene (mm).

    Returns
    -------
    float
        The time, or NaN if the tip never gets that far.
    """
    e = read_columns(e)
    tip = e["crack_tip_x"] if "crack_tip_x" in e else e["crack_front"]
    moved = tip > tip[0] + advance
    return float(e["t"][np.argmax(moved)]) if moved.any() else math.nan


def branch_time(e, crack: Crack, offset: float = BRANCH_OFFSET, after: float = BRANCH_AFTER) -> float:
    """First time the crack tip leaves the notch line: when the crack branches.

    The notch line is the continuation of the last segment of ``crack``.
    The tip counts as off the line when it is more than ``offset`` from it
    and more than ``after`` ahead of the notch tip (along the line).  The
    tip of ``energies.csv`` is the cracked point farthest from the notch tip
    (:class:`CrackTip`): it stays on the line while a single crack runs
    along it, and jumps onto one of the branches once two diverge.  For the
    Borden plate (notch from (0, 20) to (50, 20)) with the defaults: the
    first time ``|crack_tip_y - 20| > 1`` while ``crack_tip_x > 55``.

    Parameters
    ----------
    e : path or mapping of str -> ndarray
        An ``energies.csv`` with crack-tip columns, or its columns.
    crack : Crack
        The initial crack whose tip is tracked (the scene's first).
    offset, after : float
        Distances in the units of the scene (mm).

    Returns
    -------
    float
        The time, or NaN if the tip never leaves the line.
    """
    e = read_columns(e)
    (bx, by), direction = crack.tip()
    d = np.asarray(direction) / math.hypot(*direction)
    rx, ry = e["crack_tip_x"] - bx, e["crack_tip_y"] - by
    along, across = rx * d[0] + ry * d[1], np.abs(rx * d[1] - ry * d[0])
    off = (along > after) & (across > offset)
    return float(e["t"][np.argmax(off)]) if off.any() else math.nan


def crack_area(fracture_energy, Gc) -> float:
    """The crack surface area ``int Z dV`` of particle data: the sum of each
    particle's fracture energy (the core's column ``fracture_energy``,
    ``G_c V_p Z(c_p, grad c_p)``, K&T eq. 4 with the density of
    ``Fracture::crack_density``) over its material's ``G_c``.  Of particles in
    2D or 3D alike; in 2D an area times the thickness.

    Parameters
    ----------
    fracture_energy : array (N,)
        The particles' fracture energies.
    Gc : float or array (N,)
        Their critical energy release rates (of each particle's material).
    """
    energy = np.asarray(fracture_energy, dtype=float)
    return float(np.sum(energy / np.broadcast_to(np.asarray(Gc, dtype=float), energy.shape)))
