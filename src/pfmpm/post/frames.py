"""The particle snapshots of a finished MPM run (``particles.pvd`` and its VTU files)."""

from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["Frame", "series", "read_frame"]


@dataclass
class Frame:
    """The particles of one snapshot.

    Attributes
    ----------
    t : float
        Time.
    x : ndarray (N, 2) or (N, 3)
        Positions, in the run's dimensions.
    data : dict of str to ndarray
        Point data by name (``c``, ``body``, ``velocity``, ...), 1D for scalars.
    """

    t: float
    x: np.ndarray
    data: dict


def series(run_dir: Path | str) -> list[tuple[float, Path]]:
    """(time, VTU file) of every snapshot of a run, in time order.

    Raises
    ------
    FileNotFoundError
        If the run has no ``particles.pvd`` (run with ``output.particles = false``?).
    """
    run_dir = Path(run_dir)
    index = run_dir / "particles.pvd"
    if not index.is_file():
        raise FileNotFoundError(f"{index}: no particle snapshots in {run_dir}")
    return [(float(item.get("timestep")), run_dir / item.get("file"))
            for item in ElementTree.parse(index).iter("DataSet")]


def read_frame(t: float, path: Path | str, dim: int = 2) -> Frame:
    """Read one VTU snapshot written by :class:`pfmpm.output.ParticleSeries`
    of a ``dim``-dimensional run (VTU points always have three coordinates;
    a 2D run's third is zero)."""
    import meshio

    mesh = meshio.read(path)
    data = {name: (v.ravel() if v.ndim == 2 and v.shape[1] == 1 else v)
            for name, v in mesh.point_data.items()}
    return Frame(t=t, x=np.ascontiguousarray(mesh.points[:, :dim]), data=data)
