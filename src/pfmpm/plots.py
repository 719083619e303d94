"""PNG plots of a run: energy histories, crack-tip speed and phase-field snapshots."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .output import read_csv  # noqa: E402

_ENERGY_CURVES = ("kinetic", "elastic", "fracture", "external_work", "total")


def energies(csv_path: Path, png_path: Path) -> None:
    """Energy histories of ``energies.csv``; ``total`` is the balance error."""
    e = read_csv(csv_path)
    fig, ax = plt.subplots(figsize=(6, 4))
    for name in _ENERGY_CURVES:
        if name in e and (name != "fracture" or np.any(e[name])):
            ax.plot(e["t"], e[name], label=name.replace("_", " "))
    ax.set_xlabel("t")
    ax.set_ylabel("energy")
    ax.legend()
    fig.tight_layout()
    fig.savefig(png_path, dpi=120)
    plt.close(fig)


def crack_tip(csv_path: Path, png_path: Path, rayleigh: float) -> None:
    """Crack-tip position and speed against 0.6 v_R and v_R."""
    e = read_csv(csv_path)
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(6, 6), sharex=True)
    top.plot(e["t"], e["crack_tip_x"])
    top.set_ylabel("crack tip x")
    bottom.plot(e["t"], e["crack_tip_speed"], label="crack tip")
    for factor, style in ((1.0, "--"), (0.6, ":")):
        label = "v_R" if factor == 1.0 else f"{factor:g} v_R"
        bottom.axhline(factor * rayleigh, color="k", linestyle=style, label=label)
    bottom.set_xlabel("t")
    bottom.set_ylabel("crack tip speed")
    bottom.legend()
    fig.tight_layout()
    fig.savefig(png_path, dpi=120)
    plt.close(fig)


def phase_field(snapshots, png_path: Path, polar=None) -> None:
    """Phase-field images of a :class:`~pfmpm.run.Snapshots`, one panel each.

    ``polar``: optional ``(centres, table)``, a :func:`pfmpm.anisotropy.polar_table`
    whose ``1/G_c(theta)`` curve is drawn around each centre, its largest
    radius a tenth of the image's shorter side: the crack's preferred directions.
    """
    n = len(snapshots.images)
    ny, nx = snapshots.images[0][1].shape
    # Wide domains stack their panels, tall ones put them side by side.
    if ny <= nx:
        width = 6.0
        fig, axes = plt.subplots(n, 1, figsize=(width, n * width * ny / nx + 0.6 * n), squeeze=False)
    else:
        height = 6.0
        fig, axes = plt.subplots(1, n, figsize=(n * height * nx / ny + 1.5, height + 0.6), squeeze=False)
    axes = axes.ravel()
    (x0, y0), size = snapshots.origin, snapshots.pixel
    extent = (x0, x0 + nx * size, y0, y0 + ny * size)
    for ax, (t, image) in zip(axes, snapshots.images):
        im = ax.imshow(image, origin="lower", extent=extent, vmin=0, vmax=1, cmap="inferno")
        ax.set_title(f"phase field c, t = {t:.4g}")
        ax.set_aspect("equal")
        if polar is not None:
            centres, table = polar
            scale = 0.1 * min(nx, ny) * size
            theta, r = np.radians(table[:, 0]), table[:, 2] / table[:, 2].max() * scale
            for cx, cy in centres:
                ax.plot(cx + r * np.cos(theta), cy + r * np.sin(theta), color="w", lw=1.0)
    fig.colorbar(im, ax=axes.tolist(), shrink=0.8)
    fig.savefig(png_path, dpi=120)
    plt.close(fig)
