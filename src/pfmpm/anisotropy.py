"""Anisotropic surface energy of the fourth-order phase field (Kakouris & Triantafyllou 2019, eqs. 4, 6-8).

The crack density of K&T eq. 4 with the anisotropy tensor ``gamma`` (K&T eq. 6, in
Voigt form on the curvature ``kappa = (c_11, c_22, c_12)``) is::

    Z = (1 - c)^2 / (4 l0) + l0 |grad c|^2 + l0^3 kappa^T gamma kappa.

Across a straight crack with unit normal ``n`` the phase field varies along
``n`` only, so ``kappa = c'' (n1^2, n2^2, n1 n2)`` and the functional becomes
one-dimensional with the single coefficient

    gamma_n = m^T gamma m,   m = (n1^2, n2^2, n1 n2)   (n in the material frame).

With ``d = 1 - c`` and lengths in units of ``l0``, the minimiser of
``2 * int_0^inf (d^2/4 + d'^2 + gamma_n d''^2) dx`` with ``d(0) = 1`` and
``d'(0) = 0`` (the profile is smooth and even) solves
``d/4 - d'' + gamma_n d'''' = 0``: ``d = A exp(-k1 x) + B exp(-k2 x)`` with
``k1^2, k2^2`` the roots of ``gamma_n s^2 - s + 1/4 = 0``. Integrating by
parts, the minimum equals ``2 gamma_n d'''(0) = 2 gamma_n k1 k2 (k1 + k2)``,
and with ``k1 k2 = 1 / (2 sqrt(gamma_n))``, ``k1^2 + k2^2 = 1 / gamma_n``:

    G_c(theta) / G-bar_c = sqrt(1 + sqrt(gamma_n(theta))).

This is K&T eq. 8 in closed form (the paper integrates numerically over
``|x| < 50 l0``); ``gamma = 0`` gives ``G-bar_c`` exactly, and the four
(G_c,min, G_c,max) pairs of the paper come out within 0.2 %.

Angles: ``theta`` is the crack direction, counter-clockwise from x; the
material orientation ``phi`` is the principal material direction (the fibres of
the paper's section 5.4), clockwise from x (the paper's convention):
``p = (cos phi, -sin phi)``. A crack running along ``p`` has
``gamma_n = gamma_1111``, so gamma's axis 1 lies across ``p``:
``e1 = (sin phi, cos phi)``, ``e2 = -p`` (docs/method.md says why).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

__all__ = ["check_gamma", "normal_coefficient", "surface_energy", "surface_energy_ratio",
           "profile", "weak_directions", "polar_table", "write_polar_csv", "THETA_CONVENTION",
           "polar_panel", "plot_polar", "parse_gamma"]


def check_gamma(gamma) -> np.ndarray:
    """Return ``gamma`` as a 3 x 3 float array after checking it.

    The fourth-order term must be a non-negative energy for every curvature,
    so ``gamma`` must be finite, symmetric and positive semi-definite.

    Raises
    ------
    ValueError
        Saying which condition fails, with the offending entries or eigenvalue.
    """
    g = np.asarray(gamma, dtype=float)
    if g.shape != (3, 3):
        raise ValueError(f"must be a 3 x 3 matrix, got shape {g.shape}")
    if not np.all(np.isfinite(g)):
        raise ValueError("must be finite")
    scale = max(np.abs(g).max(), 1.0)
    for i, j in ((0, 1), (0, 2), (1, 2)):
        if abs(g[i, j] - g[j, i]) > 1e-12 * scale:
            raise ValueError(f"must be symmetric: entry ({i + 1},{j + 1}) = {g[i, j]:g} "
                             f"but ({j + 1},{i + 1}) = {g[j, i]:g}")
    smallest = np.linalg.eigvalsh(g).min()
    if smallest < -1e-12 * scale:
        raise ValueError(f"must be positive semi-definite: smallest eigenvalue {smallest:g}")
    return g


def normal_coefficient(gamma, theta_deg, phi_deg: float = 0.0) -> np.ndarray:
    """``gamma_n`` of a straight crack running at ``theta_deg``.

    Parameters
    ----------
    gamma : (3, 3) array_like
        Voigt tensor of K&T eq. 6 in the material frame (its symmetric part counts).
    theta_deg : float or array_like
        Crack direction(s), degrees counter-clockwise from x.
    phi_deg : float
        Principal material direction, degrees clockwise from x.
    """
    g = np.asarray(gamma, dtype=float)
    g = 0.5 * (g + g.T)
    # Crack normal in the global frame, then its components on gamma's axes
    # e1 = (sin phi, cos phi) and e2 = (-cos phi, sin phi).
    a = np.radians(np.asarray(theta_deg, dtype=float))
    nx, ny = -np.sin(a), np.cos(a)
    p = math.radians(phi_deg)
    n1 = nx * math.sin(p) + ny * math.cos(p)
    n2 = -nx * math.cos(p) + ny * math.sin(p)
    m = np.stack([n1 * n1, n2 * n2, n1 * n2])
    return np.einsum("i...,ij,j...->...", m, g, m)


def surface_energy_ratio(gamma_n) -> np.ndarray:
    """``G_c / G-bar_c = sqrt(1 + sqrt(gamma_n))`` (K&T eq. 8 in closed form, module docstring)."""
    gn = np.asarray(gamma_n, dtype=float)
    return np.sqrt(1.0 + np.sqrt(np.maximum(gn, 0.0)))


def surface_energy(gamma, gc_bar: float, theta_deg, phi_deg: float = 0.0) -> np.ndarray:
    """``G_c(theta)`` of K&T eq. 8 for crack directions ``theta_deg``."""
    return gc_bar * surface_energy_ratio(normal_coefficient(gamma, theta_deg, phi_deg))


def profile(gamma_n: float, distance, l0: float) -> np.ndarray:
    """The 1D crack profile ``1 - c`` at ``distance`` from the crack line.

    The minimiser of the module docstring: ``d(0) = 1``, ``d'(0) = 0``; for
    ``gamma_n = 0`` the second-order profile ``exp(-|x| / (2 l0))``.
    """
    x = np.abs(np.asarray(distance, dtype=float)) / l0
    if gamma_n == 0.0:
        return np.exp(-0.5 * x)
    root = np.sqrt(complex(1.0 - gamma_n))
    k1 = np.sqrt((1.0 + root) / (2.0 * gamma_n))
    k2 = np.sqrt((1.0 - root) / (2.0 * gamma_n))
    if abs(k1 - k2) < 1e-6 * abs(k1):  # the double root gamma_n = 1
        k = k1.real
        return (1.0 + k * x) * np.exp(-k * x)
    d = (k2 * np.exp(-k1 * x) - k1 * np.exp(-k2 * x)) / (k2 - k1)
    return d.real


def weak_directions(gamma, phi_deg: float = 0.0, samples: int = 3600) -> np.ndarray:
    """Crack directions (degrees in [0, 360)) where ``1/G_c(theta)`` has a strict local maximum.

    A crack prefers these directions. Sampled every ``360/samples`` degrees;
    empty for a ``G_c`` independent of direction.
    """
    theta = np.arange(samples) * (360.0 / samples)
    inv = 1.0 / surface_energy_ratio(normal_coefficient(gamma, theta, phi_deg))
    if np.ptp(inv) <= 1e-12 * inv.max():
        return np.empty(0)
    peak = (inv > np.roll(inv, 1)) & (inv >= np.roll(inv, -1))
    return theta[peak]


def polar_table(gamma, gc_bar: float, phi_deg: float = 0.0, samples: int = 721) -> np.ndarray:
    """Rows ``(theta_deg, gc, inv_gc)`` for ``samples`` directions over 0-360 degrees."""
    theta = np.linspace(0.0, 360.0, samples)
    gc = surface_energy(gamma, gc_bar, theta, phi_deg)
    return np.column_stack([theta, gc, 1.0 / gc])


def write_polar_csv(table: np.ndarray, path: Path) -> None:
    """Write :func:`polar_table` rows with the header ``theta_deg,gc,inv_gc``."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["theta_deg", "gc", "inv_gc"])
        w.writerows(table.tolist())


THETA_CONVENTION = "θ: the crack's direction, counter-clockwise from x (its normal at θ + 90°)"
"""What the angle of the polar plots is, written on them."""


def polar_panel(ax, values: np.ndarray, theta_deg: np.ndarray, label: str) -> None:
    """Draw one polar curve on a polar axes: the values against ``theta_deg``,
    from 0 to 1.1 times their largest, with the radial scale in the title
    instead of tick labels, which would lie on the curve."""
    ax.plot(np.radians(theta_deg), values)
    top = 1.1 * float(np.max(values))
    ax.set_rlim(0, top)
    ax.set_rticks(np.linspace(0.25, 1.0, 4) * top)
    ax.set_yticklabels([])
    ax.tick_params(axis="x", labelsize=8, pad=1)
    ax.set_title(f"{label}\n(outer ring {top:.3g})", fontsize=9)


def plot_polar(table: np.ndarray, path: Path, title: str = "") -> None:
    """Polar plots of ``G_c(theta)`` and ``1/G_c(theta)`` side by side (PNG),
    with the angle convention (:data:`THETA_CONVENTION`) below them."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, subplot_kw={"projection": "polar"}, figsize=(9, 5))
    polar_panel(axes[0], table[:, 1], table[:, 0], r"$G_c(\theta)$")
    polar_panel(axes[1], table[:, 2], table[:, 0], r"$1/G_c(\theta)$")
    if title:
        fig.suptitle(title)
    fig.text(0.5, 0.02, THETA_CONVENTION, ha="center", fontsize=9)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    fig.savefig(path, dpi=120)
    plt.close(fig)


def parse_gamma(text: str) -> np.ndarray:
    """Parse ``"g11,g12,g13;g21,g22,g23;g31,g32,g33"`` into a 3 x 3 array.

    Raises
    ------
    ValueError
        Naming the malformed row or entry.
    """
    rows = text.split(";")
    if len(rows) != 3:
        raise ValueError(f"expected 3 rows separated by ';', got {len(rows)}")
    out = np.zeros((3, 3))
    for i, row in enumerate(rows):
        entries = row.split(",")
        if len(entries) != 3:
            raise ValueError(f"row {i + 1} needs 3 comma-separated numbers, got {row!r}")
        for j, e in enumerate(entries):
            try:
                out[i, j] = float(e)
            except ValueError:
                raise ValueError(f"entry ({i + 1},{j + 1}) = {e.strip()!r} is not a number") from None
    return out
