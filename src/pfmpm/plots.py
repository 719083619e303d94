"""PNG plots of a run: energy histories, crack tips, the crack path and
phase-field snapshots, their axes labelled in the scene's units
(:class:`~pfmpm.scene.units.UnitSystem`)."""

from __future__ import annotations

import functools
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .output import read_csv  # noqa: E402
from .scene.units import NO_UNITS, UnitSystem  # noqa: E402

_ENERGY_CURVES = {
    "kinetic": "kinetic",
    "elastic": "elastic",
    "fracture": "fracture",
    "external_work": "external work",
    "friction_dissipation": "friction dissipation",
    "wall_work": "wall work",
}
PHASE_FIELD_LABEL = "phase field c (1 intact, 0 broken)"
"""The colour-bar label of the phase-field images."""


def _closing(plot):
    """A plot that closes the figures it opened when it fails: a long-lived
    process (a notebook, the tests) does not collect them."""

    @functools.wraps(plot)
    def wrapper(*args, **kwargs):
        before = set(plt.get_fignums())
        try:
            return plot(*args, **kwargs)
        except BaseException:
            for number in set(plt.get_fignums()) - before:
                plt.close(number)
            raise

    return wrapper


@_closing
def energies(csv_path: Path, png_path: Path, units: UnitSystem = NO_UNITS) -> None:
    """Energy histories of ``energies.csv`` and the balance residual: ``total``
    (kinetic + elastic + fracture + dissipation - work) minus its value at t = 0,
    zero where the energy balance closes."""
    e = read_csv(csv_path)
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    for name, label in _ENERGY_CURVES.items():
        if name in e and (name in ("kinetic", "elastic", "external_work") or np.any(e[name])):
            ax.plot(e["t"], e[name], label=label)
    ax.plot(e["t"], e["total"] - e["total"][0], "k--", label="balance residual (total - total at t = 0)")
    ax.set_xlabel(units.label("time t", "time"))
    ax.set_ylabel(units.label("energy", "energy"))
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png_path, dpi=120)
    plt.close(fig)


@_closing
def forces(forces: dict, png_path: Path, units: UnitSystem = NO_UNITS) -> None:
    """The reactions of the walls and prescribed regions (top) and the bodies' net forces (bottom) against
    time, each the mean over an interval between rows
    (:func:`pfmpm.post.forces.mean_forces`)."""
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(6.5, 6.0), sharex=True)
    for name, values in forces.items():
        if name == "t":
            continue
        ax = top if name.startswith(("wall_", "region_")) else bottom
        ax.plot(forces["t"], values, label=name.replace("_", " "))
    top.set_title("reactions of the walls and prescribed regions" if top.lines else "no walls", fontsize=9)
    bottom.set_title("net force on each body (momentum rate)", fontsize=9)
    for ax in (top, bottom):
        ax.set_ylabel(units.label("force", "force"))
        if ax.lines:
            ax.legend(fontsize=8)
    bottom.set_xlabel(units.label("time t", "time"))
    fig.tight_layout()
    fig.savefig(png_path, dpi=120)
    plt.close(fig)


@_closing
def load_displacement(curve: dict, png_path: Path, units: UnitSystem = NO_UNITS) -> None:
    """A prescribed region's load against its displacement
    (:func:`pfmpm.post.forces.load_displacement`)."""
    fig, ax = plt.subplots(figsize=(6.0, 4.2))
    ax.plot(curve["displacement"], curve["load"])
    d = curve["component"]
    ax.set_xlabel(units.label(f"displacement of {curve['region']} along {d}", "length"))
    ax.set_ylabel(units.label(f"load along {d} (the region's force on the bodies)", "force"))
    fig.tight_layout()
    fig.savefig(png_path, dpi=120)
    plt.close(fig)


@_closing
def crack_arms(arms, png_path: Path, rayleigh: float, units: UnitSystem = NO_UNITS) -> None:
    """Each crack arm's path length from its crack's start and its speed,
    against 0.6 v_R and v_R (a :class:`pfmpm.post.cracks.Cracks`)."""
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(6.5, 6), sharex=True)
    for a, arm in enumerate(arms.arms):
        label = f"arm {a + 1} (crack {arm.crack + 1})"
        top.plot(arm.t, arm.length, f"C{a % 10}-", label=label)
        bottom.plot(arm.t, arm.speed, f"C{a % 10}-", label=label)
    for factor, style in ((1.0, "-."), (0.6, ":")):
        label = "v_R" if factor == 1.0 else f"{factor:g} v_R"
        bottom.axhline(factor * rayleigh, color="0.5", linestyle=style, label=label)
    top.set_ylabel(units.label("arm length", "length"))
    bottom.set_ylabel(units.label("tip speed", "speed"))
    bottom.set_xlabel(units.label("time t", "time"))
    if arms.arms:
        top.legend(fontsize=8)
    bottom.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png_path, dpi=120)
    plt.close(fig)


@_closing
def crack_path(arms, xy: np.ndarray, times: np.ndarray, png_path: Path,
               bounds: tuple[float, float, float, float], units: UnitSystem = NO_UNITS) -> None:
    """The crack path in x-y: the cracked points coloured by the time each
    cracked, and the track of each crack arm's tip.

    Parameters
    ----------
    arms : pfmpm.post.cracks.Cracks
    xy : (N, 2) ndarray
        Where the points (particles or mesh vertices) cracked.
    times : (N,) ndarray
        When each cracked; NaN for those intact.
    png_path : path
    bounds : (xmin, ymin, xmax, ymax)
        The region drawn (the crackable bodies).
    """
    cracked = np.isfinite(times)
    end = float(times[cracked].max()) if cracked.any() else 1.0
    x0, y0, x1, y1 = bounds
    width = 7.0
    aspect = (y1 - y0) / (x1 - x0) if x1 > x0 and y1 > y0 else 1.0  # a body can be a point
    fig, ax = plt.subplots(figsize=(width, max(2.5, width * aspect * 0.85 + 1.0)))
    order = np.argsort(times[cracked], kind="stable")
    if cracked.any():
        dots = ax.scatter(xy[cracked, 0][order], xy[cracked, 1][order], c=times[cracked][order],
                          s=2, cmap="viridis", linewidths=0, vmin=0.0, vmax=end)
        fig.colorbar(dots, ax=ax, label=units.label("time cracked", "time"))
    for a, arm in enumerate(arms.arms):
        ax.plot(arm.x, arm.y, f"C{a % 10}-", lw=1.2, label=f"arm {a + 1} (crack {arm.crack + 1})")
    if x1 > x0 and y1 > y0:  # else matplotlib's own limits (a body can be a point)
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel(units.label("x", "length"))
    ax.set_ylabel(units.label("y", "length"))
    ax.set_title("crack path: cracked points by time, and each arm's tip", fontsize=10)
    if arms.arms:
        ax.legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    fig.savefig(png_path, dpi=150)
    plt.close(fig)


@_closing
def phase_field(snapshots, png_path: Path, polar=None, units: UnitSystem = NO_UNITS) -> None:
    """Phase-field images of a :class:`~pfmpm.observe.Snapshots`, one panel each.

    ``polar``: optional ``(centres, table)``, a :func:`pfmpm.anisotropy.polar_table`
    whose ``1/G_c(theta)`` curve is drawn around each centre, its largest
    radius a tenth of the image's shorter side: the crack's preferred directions.
    """
    n = len(snapshots.images)
    ny, nx = snapshots.images[0][1].shape
    # Wide domains stack their panels, tall ones put them side by side.
    if ny <= nx:
        width = 6.0
        fig, axes = plt.subplots(n, 1, figsize=(width + 1.2, n * (width * ny / nx + 0.9)), squeeze=False)
    else:
        height = 6.0
        fig, axes = plt.subplots(1, n, figsize=(n * (height * nx / ny + 0.9) + 1.5, height + 0.9),
                                 squeeze=False)
    axes = axes.ravel()
    (x0, y0), size = snapshots.origin, snapshots.pixel
    extent = (x0, x0 + nx * size, y0, y0 + ny * size)
    for ax, (t, image) in zip(axes, snapshots.images):
        im = ax.imshow(image, origin="lower", extent=extent, vmin=0, vmax=1, cmap="inferno",
                       interpolation="nearest")
        ax.set_title(f"phase field c at t = {t:.4g}" + (f" {units.time}" if units.declared else ""),
                     fontsize=10)
        ax.set_aspect("equal")
        ax.set_xlabel(units.label("x", "length"))
        ax.set_ylabel(units.label("y", "length"))
        if polar is not None:
            centres, table = polar
            scale = 0.1 * min(nx, ny) * size
            theta, r = np.radians(table[:, 0]), table[:, 2] / table[:, 2].max() * scale
            for cx, cy in centres:
                ax.plot(cx + r * np.cos(theta), cy + r * np.sin(theta), color="w", lw=1.0)
    fig.colorbar(im, ax=axes.tolist(), shrink=0.8, label=PHASE_FIELD_LABEL)
    fig.savefig(png_path, dpi=120)
    plt.close(fig)
