"""Initial cracks as history fields.

Both the MPM and the FEM paths impose a scene's ``[[cracks]]`` with
:func:`initial_history`, so a crack starts the same way in each; the
measures of cracks (tip, arms, fragments, ...) are in :mod:`pfmpm.post`.
"""

from __future__ import annotations

import numpy as np

from .scene import Crack, FractureSpec
from .scene.shapes import distance_to_polyline

__all__ = ["distance_to_polyline", "initial_history"]


def initial_history(xy: np.ndarray, crack: Crack, fracture: FractureSpec) -> np.ndarray:
    """History field of an initial crack (Borden et al. 2012).

    ``H0 = B G_c / (4 l0) (1 - d / w)`` within the half width ``w`` of the
    crack polyline (``w = l0 / 2`` unless the crack sets it), 0 beyond.

    Parameters
    ----------
    xy : ndarray (N, 2)
        Points (particles, or the FEM's edge midpoints).
    crack : Crack
    fracture : FractureSpec
        The material's parameters (G_c, l0).

    Returns
    -------
    ndarray (N,)
    """
    w = crack.half_width if crack.half_width is not None else 0.5 * fracture.l0
    d = distance_to_polyline(xy, crack.points)
    return np.where(d <= w, crack.B * fracture.Gc / (4 * fracture.l0) * (1 - d / w), 0.0)
