"""``pfmpm animate OUT``: an animation of a field over the frames of a run,
or a picture of its last frame.

An MPM run's frames are its particle series (``particles.pvd``), a FEM run's
its ``fields.xdmf``. A 2D frame is drawn as an image whose pixels take the
value of the nearest point (:func:`pfmpm.observe.nearest_image`); a 3D frame
as its particles in perspective, coloured by the field and shaded by depth
(matplotlib's mplot3d, off-screen). Animations go through matplotlib's
writers: GIF through Pillow, MP4 through ffmpeg where it is installed; a
``.png`` is the last frame alone.
"""

from __future__ import annotations

import json
import shutil
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import numpy as np

from .observe import nearest_image
from .plots import PHASE_FIELD_LABEL, plt
from .scene.units import unit_system

__all__ = ["frames", "animate"]

VECTOR_QUANTITIES = {"displacement": "length", "velocity": "speed"}
"""The vector fields drawn by their magnitude, with the quantity of their unit."""


def frames(run_dir: Path | str, field: str, dim: int = 2) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """The frames of a ``dim``-dimensional run: ``(t, x, values)`` of ``field``
    at its points (x with ``dim`` coordinates), a vector field by its magnitude.

    Raises
    ------
    FileNotFoundError
        If the run has no frames (``particles.pvd`` or ``fields.xdmf``).
    KeyError
        Naming the field and those the run has, if it has no such field.
    """
    run_dir = Path(run_dir)
    if (run_dir / "particles.pvd").is_file():
        from .post.frames import read_frame, series

        found = [(t, read_frame(t, path, dim)) for t, path in series(run_dir)]
        out = [(t, f.x, f.data.get(field)) for t, f in found]
        have = sorted(found[0][1].data) if found else []
    elif (run_dir / "fields.xdmf").is_file():
        out, have = _xdmf_frames(run_dir / "fields.xdmf", field)
    else:
        raise FileNotFoundError(f"{run_dir}: no frames (particles.pvd of an MPM run, fields.xdmf of a FEM run)")
    if not out or out[0][2] is None:
        raise KeyError(f"{run_dir}: no field {field!r} in its frames (they have: {', '.join(have)})")
    return [(t, xy, values if values.ndim == 1 else np.linalg.norm(values[:, :dim], axis=1))
            for t, xy, values in out]


def _xdmf_frames(path: Path, field: str):
    """The frames of one vertex field of a DOLFINx XDMF series, and the fields it has."""
    import h5py

    root = ElementTree.parse(path).getroot()
    grids = root.find("Domain").findall("Grid")

    def dataset(item):
        name, _, where = item.text.strip().partition(":")
        return path.parent / name, where

    mesh = next(g for g in grids if g.get("GridType") == "Uniform")
    h5, where = dataset(mesh.find("Geometry/DataItem"))
    series = {g.get("Name"): g for g in grids if g.get("CollectionType") == "Temporal"}
    have = [name for name, g in series.items() if g.find("Grid/Attribute").get("Center") == "Node"]
    if field not in have:
        return [], have
    out = []
    with h5py.File(h5, "r") as f:
        xy = f[where][()][:, :2]
        for step in series[field].findall("Grid"):
            _, data = dataset(step.find("Attribute/DataItem"))  # DOLFINx keeps one HDF5 file
            values = f[data][()]
            out.append((float(step.find("Time").get("Value")), xy, values.squeeze()))
    return out, have


MAX_POINTS_3D = 200_000
"""The most particles a 3D frame draws: a larger run's are thinned evenly
(every k-th in particle order), so that a picture stays quick to draw."""


def animate(run_dir: Path | str, output: Path | str | None = None, field: str = "c", fps: float = 6.0) -> Path:
    """Write an animation of ``field`` over the frames of a run, or a picture
    of its last frame.

    Parameters
    ----------
    run_dir : path
        The run's output directory.
    output : path, optional
        ``.gif`` (Pillow) or ``.mp4`` (ffmpeg), or ``.png`` for the last
        frame alone; default ``<run_dir>/<field>.gif``.
    field : str
        A field of the frames: ``c`` (the phase field), ``damage``,
        ``velocity``, ``displacement`` (by magnitude), ...
    fps : float
        Frames per second.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    FileNotFoundError, KeyError
        See :func:`frames`.
    ValueError
        For an output other than .gif, .mp4 and .png, or .mp4 without ffmpeg.
    """
    from matplotlib import animation

    run_dir = Path(run_dir)
    output = Path(output) if output is not None else run_dir / f"{field}.gif"
    if output.suffix == ".gif":
        writer = animation.PillowWriter(fps=fps)
    elif output.suffix == ".mp4":
        if shutil.which("ffmpeg") is None:
            raise ValueError(f"{output}: an MP4 needs ffmpeg, which is not installed; write a .gif")
        writer = animation.FFMpegWriter(fps=fps)
    elif output.suffix == ".png":
        writer = None
    else:
        raise ValueError(f"{output}: write a .gif, an .mp4 or a .png (the last frame)")
    summary = run_dir / "summary.json"
    written = json.loads(summary.read_text()) if summary.is_file() else {}
    dim = len(written.get("grid", {}).get("cells", ())) or 2
    shots = frames(run_dir, field, dim)
    if writer is None:
        shots = shots[-1:]
    units = unit_system(written.get("units", ""))
    phase = field == "c"
    limits = (0.0, 1.0) if phase or field == "damage" else (
        min(np.nanmin(v) for _, _, v in shots), max(np.nanmax(v) for _, _, v in shots))
    if phase:
        label = PHASE_FIELD_LABEL
    elif field in VECTOR_QUANTITIES:
        label = units.label(f"|{field}|", VECTOR_QUANTITIES[field])
    else:
        label = field
    cmap = "inferno" if phase else "viridis"
    fig, draw = (_particles_3d if dim == 3 else _image_2d)(shots, limits, label, cmap, units)

    def title(t):
        return (f"{'phase field c' if phase else field} at t = {t:.4g}"
                + (f" {units.time}" if units.declared else ""))

    output.parent.mkdir(parents=True, exist_ok=True)
    if writer is None:
        draw(*shots[-1][1:], title(shots[-1][0]))
        fig.savefig(output, dpi=150)
    else:
        with writer.saving(fig, str(output), dpi=100):
            for t, x, values in shots:
                draw(x, values, title(t))
                writer.grab_frame()
    plt.close(fig)
    return output


def _image_2d(shots, limits, label, cmap, units):
    """The figure of 2D frames and its drawing function: each frame an image,
    one pixel per point spacing of the first frame, over the box of all frames."""
    from scipy.spatial import cKDTree

    xy0 = shots[0][1]
    spacing = float(np.median(cKDTree(xy0).query(xy0, k=2)[0][:, 1])) if len(xy0) > 1 else 1.0
    lo = np.min([xy.min(axis=0) for _, xy, _ in shots], axis=0) - 0.5 * spacing
    hi = np.max([xy.max(axis=0) for _, xy, _ in shots], axis=0) + 0.5 * spacing
    shape = tuple(int(n) for n in np.ceil((hi - lo) / spacing))
    width = 7.0
    fig, ax = plt.subplots(figsize=(width, max(2.5, width * shape[1] / shape[0] * 0.9 + 1.0)))
    image = ax.imshow(np.full(shape[::-1], np.nan), origin="lower", vmin=limits[0], vmax=limits[1],
                      extent=(lo[0], lo[0] + shape[0] * spacing, lo[1], lo[1] + shape[1] * spacing),
                      cmap=cmap, interpolation="nearest")
    ax.set_xlabel(units.label("x", "length"))
    ax.set_ylabel(units.label("y", "length"))
    ax.set_aspect("equal")
    fig.colorbar(image, ax=ax, label=label)

    def draw(xy, values, title):
        image.set_data(nearest_image(xy, values, lo, spacing, shape, spacing))
        ax.set_title(title)

    return fig, draw


def _particles_3d(shots, limits, label, cmap, units):
    """The figure of 3D frames and its drawing function: the particles (at
    most :data:`MAX_POINTS_3D`, evenly thinned) in perspective over the box
    of all frames, true to scale, coloured by the field and shaded by depth."""
    lo = np.min([x.min(axis=0) for _, x, _ in shots], axis=0)
    hi = np.max([x.max(axis=0) for _, x, _ in shots], axis=0)
    n = len(shots[0][1])
    every = max(1, -(-n // MAX_POINTS_3D))
    fig = plt.figure(figsize=(8.0, 6.5), layout="constrained")
    ax = fig.add_subplot(projection="3d")
    ax.set_box_aspect(np.maximum(hi - lo, 1e-12 * np.max(hi - lo)))
    for set_limits, a, b in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), lo, hi):
        set_limits(a, b)
    from matplotlib.ticker import MaxNLocator

    extent = hi - lo
    for axis, name, e in zip((ax.xaxis, ax.yaxis, ax.zaxis), "xyz", extent):
        axis.set_label_text(units.label(name, "length"))
        # Ticks in proportion to the side, true to scale: a short side gets two.
        axis.set_major_locator(MaxNLocator(max(2, round(6 * e / max(extent.max(), 1e-300)))))
    # A marker about one particle spacing across at this scale.
    size = max(0.5, 1.5e4 / max(1, n // every) ** (2.0 / 3.0))
    norm = plt.Normalize(*limits)
    fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax, label=label, shrink=0.7)
    drawn = []

    def draw(x, values, title):
        for points in drawn:
            points.remove()
        x, values = x[::every], values[::every]
        drawn[:] = [ax.scatter(x[:, 0], x[:, 1], x[:, 2], c=values, s=size, cmap=cmap, norm=norm,
                               depthshade=True, linewidths=0)]
        ax.set_title(title)

    return fig, draw
