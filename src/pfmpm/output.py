"""Run output: particle time series (VTU files with a PVD index) and CSV logs.

The VTU files are VTK XML unstructured grids of vertex cells with base64
binary data, readable by ParaView and meshio.
"""

from __future__ import annotations

import base64
import csv
from pathlib import Path

import numpy as np

_VTK_TYPES = {np.dtype("float64"): "Float64", np.dtype("int32"): "Int32", np.dtype("int64"): "Int64"}


def check_directory(path: Path | str) -> Path:
    """``path`` as an output directory, which need not exist yet.

    Raises
    ------
    NotADirectoryError
        Naming ``path`` and the file in the way, if it or a folder above it
        is a file.
    """
    path = Path(path)
    for p in (path, *path.parents):
        if p.exists() and not p.is_dir():
            where = "is a file" if p == path else f"lies under the file {p}"
            raise NotADirectoryError(f"output directory {path} {where}")
    return path


def _data_array(name: str, values: np.ndarray) -> str:
    values = np.ascontiguousarray(values)
    ncomp = 1 if values.ndim == 1 else values.shape[1]
    raw = values.tobytes()
    payload = base64.b64encode(np.uint64(len(raw)).tobytes() + raw).decode("ascii")
    return (
        f'<DataArray type="{_VTK_TYPES[values.dtype]}" Name="{name}" '
        f'NumberOfComponents="{ncomp}" format="binary">{payload}</DataArray>'
    )


def vtk_values(values: np.ndarray, layout: str) -> np.ndarray:
    """A particle column as VTK point data: a plane tensor (layout ``xx,yy,xy``,
    or ``xx,yy,xy,zz`` with its out-of-plane entry) becomes the symmetric
    tensor (xx, yy, zz, xy, yz, xz) ParaView reads, zz = 0 where the column
    has none (the strain of a plane-strain run; a plane-stress run keeps no
    out-of-plane strain); every other column is written as it is."""
    if layout in ("xx,yy,xy", "xx,yy,xy,zz"):
        tensor = np.zeros((len(values), 6))
        if layout == "xx,yy,xy":
            tensor[:, [0, 1, 3]] = values
        else:
            tensor[:, [0, 1, 2, 3]] = values[:, [0, 1, 3, 2]]
        return tensor
    return values


def write_vtu(path: Path, points: np.ndarray, point_data: dict[str, np.ndarray]) -> None:
    """Write 2D points as VTK vertices with point data.

    Parameters
    ----------
    path : Path
        File to write.
    points : (N, 2) ndarray
        Coordinates (z = 0 is added).
    point_data : dict of name -> (N,) or (N, k) ndarray
        Fields; 2-component vectors are padded to 3 so ParaView shows them as vectors.
    """
    n = len(points)
    xyz = np.zeros((n, 3))
    xyz[:, :2] = points
    arrays = []
    for name, values in point_data.items():
        if values.ndim == 2 and values.shape[1] == 2:
            padded = np.zeros((n, 3), dtype=values.dtype)
            padded[:, :2] = values
            values = padded
        arrays.append(_data_array(name, values))
    cells = np.arange(n, dtype=np.int64)
    text = "\n".join(
        [
            '<?xml version="1.0"?>',
            '<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">',
            "<UnstructuredGrid>",
            f'<Piece NumberOfPoints="{n}" NumberOfCells="{n}">',
            "<PointData>",
            *arrays,
            "</PointData>",
            "<Points>",
            _data_array("Points", xyz),
            "</Points>",
            "<Cells>",
            _data_array("connectivity", cells),
            _data_array("offsets", cells + 1),
            _data_array("types", np.ones(n, dtype=np.int32)),  # VTK_VERTEX
            "</Cells>",
            "</Piece>",
            "</UnstructuredGrid>",
            "</VTKFile>",
        ]
    )
    tmp = path.with_suffix(".tmp")
    tmp.write_text(text)
    tmp.replace(path)


class ParticleSeries:
    """Particle snapshots ``particles_NNNNNN.vtu`` with a ``particles.pvd`` index.

    The index is rewritten after every snapshot, so an interrupted run leaves
    a valid series of the snapshots written so far.
    """

    def __init__(self, directory: Path, entries=()):
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self._entries: list[tuple[float, str]] = [(float(t), str(f)) for t, f in entries]

    @property
    def entries(self) -> list[tuple[float, str]]:
        """(time, file name) of each snapshot so far; pass them back to continue the series."""
        return list(self._entries)

    def write(self, step: int, time: float, points: np.ndarray, point_data: dict[str, np.ndarray]) -> Path:
        name = f"particles_{step:06d}.vtu"
        write_vtu(self.directory / name, points, point_data)
        self._entries.append((time, name))
        lines = ['<?xml version="1.0"?>', '<VTKFile type="Collection" version="0.1">', "<Collection>"]
        lines += [f'<DataSet timestep="{t!r}" part="0" file="{f}"/>' for t, f in self._entries]
        lines += ["</Collection>", "</VTKFile>"]
        index = self.directory / "particles.pvd"
        tmp = index.with_suffix(".tmp")
        tmp.write_text("\n".join(lines) + "\n")
        tmp.replace(index)
        return self.directory / name


class CsvLog:
    """A CSV file written row by row and flushed after each row.

    With ``append``, rows are added to an existing file that already has a
    header, under that header's columns (a run resumed from a checkpoint of
    an older pfmpm keeps the columns its file started with); each must be one
    of ``columns``.
    """

    def __init__(self, path: Path, columns: list[str], append: bool = False):
        self.columns = list(columns)
        if append:
            with open(path, newline="") as f:
                header = next(csv.reader(f), self.columns)
            if unknown := [c for c in header if c not in self.columns]:
                raise ValueError(f"{path}: column {unknown[0]} is not one of this run's")
            self.columns = header
        self._file = open(path, "a" if append else "w", newline="")
        self._writer = csv.writer(self._file)
        if not append:
            self._writer.writerow(self.columns)
        self._file.flush()

    def write(self, row: dict[str, float]) -> None:
        self._writer.writerow([_cell(row[c]) for c in self.columns])
        self._file.flush()

    def close(self) -> None:
        self._file.close()


def _cell(value) -> str:
    """Integers as integers, floats with every digit (repr round-trips)."""
    return str(value) if isinstance(value, int) else repr(float(value))


def read_csv(path: Path) -> dict[str, np.ndarray]:
    """Read a CSV log written by :class:`CsvLog` as columns."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], np.array(rows[1:], dtype=float).reshape(-1, len(rows[0]))
    return {name: body[:, k] for k, name in enumerate(header)}
