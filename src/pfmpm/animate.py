"""``pfmpm animate OUT``: an animation of a field over the frames of a run.

An MPM run's frames are its particle series (``particles.pvd``), a FEM run's
its ``fields.xdmf``; each frame is drawn as an image whose pixels take the
value of the nearest point (:func:`pfmpm.observe.nearest_image`), with matplotlib's
animation writers: GIF through Pillow, MP4 through ffmpeg where it is installed.
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


def frames(run_dir: Path | str, field: str) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """The frames of a run: ``(t, xy, values)`` of ``field`` at its points, a
    vector field by its magnitude.

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

        found = [(t, read_frame(t, path)) for t, path in series(run_dir)]
        out = [(t, f.x, f.data.get(field)) for t, f in found]
        have = sorted(found[0][1].data) if found else []
    elif (run_dir / "fields.xdmf").is_file():
        out, have = _xdmf_frames(run_dir / "fields.xdmf", field)
    else:
        raise FileNotFoundError(f"{run_dir}: no frames (particles.pvd of an MPM run, fields.xdmf of a FEM run)")
    if not out or out[0][2] is None:
        raise KeyError(f"{run_dir}: no field {field!r} in its frames (they have: {', '.join(have)})")
    return [(t, xy, values if values.ndim == 1 else np.hypot(values[:, 0], values[:, 1]))
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


def animate(run_dir: Path | str, output: Path | str | None = None, field: str = "c", fps: float = 6.0) -> Path:
    """Write an animation of ``field`` over the frames of a run.

    Parameters
    ----------
    run_dir : path
        The run's output directory.
    output : path, optional
        ``.gif`` (Pillow) or ``.mp4`` (ffmpeg); default ``<run_dir>/<field>.gif``.
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
        For an output other than .gif and .mp4, or .mp4 without ffmpeg, or
        the run of a 3D scene.
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
    else:
        raise ValueError(f"{output}: write a .gif or an .mp4")
    summary = run_dir / "summary.json"
    written = json.loads(summary.read_text()) if summary.is_file() else {}
    if len(written.get("grid", {}).get("cells", ())) == 3:
        raise ValueError(f"{run_dir}: a 3D run, and pfmpm animate draws 2D ones; open its particles.pvd"
                         " in ParaView")
    shots = frames(run_dir, field)
    units = unit_system(written.get("units", ""))
    # One pixel per point spacing of the first frame, over the box of all frames.
    from scipy.spatial import cKDTree

    xy0 = shots[0][1]
    spacing = float(np.median(cKDTree(xy0).query(xy0, k=2)[0][:, 1])) if len(xy0) > 1 else 1.0
    lo = np.min([xy.min(axis=0) for _, xy, _ in shots], axis=0) - 0.5 * spacing
    hi = np.max([xy.max(axis=0) for _, xy, _ in shots], axis=0) + 0.5 * spacing
    shape = tuple(int(n) for n in np.ceil((hi - lo) / spacing))
    phase = field == "c"
    limits = (0.0, 1.0) if phase or field == "damage" else (
        min(np.nanmin(v) for _, _, v in shots), max(np.nanmax(v) for _, _, v in shots))
    width = 7.0
    fig, ax = plt.subplots(figsize=(width, max(2.5, width * shape[1] / shape[0] * 0.9 + 1.0)))
    image = ax.imshow(np.full(shape[::-1], np.nan), origin="lower", vmin=limits[0], vmax=limits[1],
                      extent=(lo[0], lo[0] + shape[0] * spacing, lo[1], lo[1] + shape[1] * spacing),
                      cmap="inferno" if phase else "viridis", interpolation="nearest")
    ax.set_xlabel(units.label("x", "length"))
    ax.set_ylabel(units.label("y", "length"))
    ax.set_aspect("equal")
    if phase:
        label = PHASE_FIELD_LABEL
    elif field in VECTOR_QUANTITIES:
        label = units.label(f"|{field}|", VECTOR_QUANTITIES[field])
    else:
        label = field
    fig.colorbar(image, ax=ax, label=label)
    output.parent.mkdir(parents=True, exist_ok=True)
    with writer.saving(fig, str(output), dpi=100):
        for t, xy, values in shots:
            image.set_data(nearest_image(xy, values, lo, spacing, shape, spacing))
            ax.set_title(f"{'phase field c' if phase else field} at t = {t:.4g}"
                         + (f" {units.time}" if units.declared else ""))
            writer.grab_frame()
    plt.close(fig)
    return output
