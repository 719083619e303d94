"""Initial cracks as history fields.

Both the MPM and the FEM paths impose a scene's ``[[cracks]]`` with
:func:`initial_history`, so a crack starts the same way in each; the
measures of cracks (tip, arms, fragments, ...) are in :mod:`pfmpm.post`.
"""

from __future__ import annotations

import numpy as np

from .scene import Crack, FractureSpec
from .scene.shapes import distance_to_polygon, distance_to_polyline

__all__ = ["distance_to_polyline", "distance_to_polygon", "distance_to_crack", "initial_history"]


def distance_to_crack(x: np.ndarray, crack: Crack) -> np.ndarray:
    """Distance from each row of ``x`` to the crack: its polyline for (N, 2)
    points and a 2D crack, its planar patch for (N, 3) points and a 3D one.

    Raises
    ------
    ValueError
        If the points and the crack have different dimensions.
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 2 or x.shape[1] != crack.dim:
        raise ValueError(f"points of shape {x.shape} for a {crack.dim}D crack: need (N, {crack.dim})")
    return (distance_to_polyline if crack.dim == 2 else distance_to_polygon)(x, crack.points)


def initial_history(x: np.ndarray, crack: Crack, fracture: FractureSpec) -> np.ndarray:
    """History field of an initial crack (Borden et al. 2012).

    ``H0 = B G_c / (4 l0) (1 - d / w)`` within the half width ``w`` of the
    crack (a polyline in 2D, a planar patch in 3D: :func:`distance_to_crack`;
    ``w = l0 / 2`` unless the crack sets it), 0 beyond.

    Parameters
    ----------
    x : ndarray (N, 2) or (N, 3)
        Points (particles, or the FEM's history points), as many coordinates
        as the crack's points have.
    crack : Crack
    fracture : FractureSpec
        The material's parameters (G_c, l0).

    Returns
    -------
    ndarray (N,)
    """
    w = crack.half_width if crack.half_width is not None else 0.5 * fracture.l0
    d = distance_to_crack(x, crack)
    return np.where(d <= w, crack.B * fracture.Gc / (4 * fracture.l0) * (1 - d / w), 0.0)
