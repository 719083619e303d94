"""Run output: particle time series (VTU files with a PVD index) and CSV logs.

The VTU files are VTK XML unstructured grids of vertex cells with base64
binary data, readable by ParaView and meshio; their field data names what
integer point data stands for (``body plate = 0``).
"""

from __future__ import annotations

import base64
import csv
import itertools
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import BinaryIO
from xml.sax.saxutils import quoteattr

import numpy as np

_VTK_TYPES = {np.dtype("float64"): "Float64", np.dtype("int32"): "Int32", np.dtype("int64"): "Int64"}
_BLOCK = 1 << 16  # particles converted and encoded at a time


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


def vtk_values(values: np.ndarray, layout: str) -> np.ndarray:
    """A particle column as VTK point data: a symmetric tensor becomes the six
    components (xx, yy, zz, xy, yz, xz) ParaView reads as a symmetric tensor.
    A 3D one (layout ``xx,yy,xy,zz,yz,xz``) is reordered; a plane one
    (``xx,yy,xy``, or ``xx,yy,xy,zz`` with its out-of-plane entry) gets
    yz = xz = 0, and zz = 0 where the column has none (the strain of a
    plane-strain run; a plane-stress run keeps no out-of-plane strain); a
    2-component vector gets z = 0 so ParaView draws it as a vector; every
    other column is written as it is."""
    if layout == "xx,yy,xy,zz,yz,xz":
        return values[:, [0, 1, 3, 2, 4, 5]]
    if layout in ("xx,yy,xy", "xx,yy,xy,zz"):
        tensor = np.zeros((len(values), 6))
        if layout == "xx,yy,xy":
            tensor[:, [0, 1, 3]] = values
        else:
            tensor[:, [0, 1, 2, 3]] = values[:, [0, 1, 3, 2]]
        return tensor
    if values.ndim == 2 and values.shape[1] == 2:
        padded = np.zeros((len(values), 3), dtype=values.dtype)
        padded[:, :2] = values
        return padded
    return values


class Rows:
    """A field of ``n`` rows that is made a block at a time as it is written,
    never whole: ``blocks()`` yields arrays of consecutive rows, in order,
    that add up to ``n``. :func:`write_vtu` takes one wherever it takes an
    array (a particle's displacement, say, which would otherwise be a copy
    of the positions)."""

    def __init__(self, n: int, blocks):
        self.n, self.blocks = n, blocks

    def __len__(self) -> int:
        return self.n

    @classmethod
    def of(cls, n: int, rows, dtype=np.float64) -> "Rows":
        """The field whose rows ``[a, b)`` are ``rows(a, b)``, as ``dtype``."""
        starts = range(0, max(n, 1), _BLOCK)  # an empty field still has a block, for its type
        return cls(n, lambda: (np.asarray(rows(a, min(a + _BLOCK, n)), dtype=dtype) for a in starts))


def _write_data_array(f: BinaryIO, name: str, values: "np.ndarray | Rows", layout: str = "") -> None:
    """One binary ``DataArray`` of :func:`vtk_values`: base64 of a UInt64 byte
    count and the values, converted and encoded ``_BLOCK`` rows at a time
    (a :class:`Rows` block at a time), so that a snapshot holds neither its
    text nor a converted copy of a column."""
    blocks = (values.blocks() if isinstance(values, Rows)
              else (values[a:a + _BLOCK] for a in range(0, max(len(values), 1), _BLOCK)))
    first = next(blocks)
    head = vtk_values(first[:1], layout)
    ncomp = 1 if head.ndim == 1 else head.shape[1]
    f.write(f'<DataArray type="{_VTK_TYPES[head.dtype]}" Name="{name}" '
            f'NumberOfComponents="{ncomp}" format="binary">'.encode())
    pending = np.uint64(len(values) * ncomp * head.itemsize).tobytes()
    for rows in itertools.chain([first], blocks):
        block = pending + np.ascontiguousarray(vtk_values(rows, layout)).tobytes()
        whole = len(block) - len(block) % 3  # base64 of pieces of 3k bytes joins up
        f.write(base64.b64encode(block[:whole]))
        pending = block[whole:]
    f.write(base64.b64encode(pending) + b"</DataArray>")


def write_vtu(path: Path, points: np.ndarray, point_data: Iterable[tuple[str, np.ndarray, str]],
              field_data: Mapping[str, int] | None = None) -> None:
    """Write 2D or 3D points as VTK vertices with point data.

    Parameters
    ----------
    path : Path
        File to write.
    points : (N, 2) or (N, 3) ndarray
        Coordinates (z = 0 is added to 2D ones).
    point_data : iterable of (name, (N,) or (N, k) ndarray or Rows, layout)
        Fields, written as :func:`vtk_values` of their layout (``""`` for
        none). The arrays are read, never copied whole, and may be made as
        the iterable is walked: a snapshot then holds one at a time, or,
        given as :class:`Rows`, none.
    field_data : mapping of str to int, optional
        Named integers of the whole file (VTK field data, one Int32 array
        each), e.g. ``{"body plate": 0}``: what each value of an integer
        point array stands for.
    """
    n = len(points)
    fields = [f'<DataArray type="Int32" Name={quoteattr(name)} NumberOfTuples="1" format="ascii">{int(value)}'
              "</DataArray>" for name, value in (field_data or {}).items()]
    tmp = path.with_suffix(".tmp")
    with open(tmp, "wb") as f:
        f.write("\n".join([
            '<?xml version="1.0"?>',
            '<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">',
            "<UnstructuredGrid>",
            *(["<FieldData>", *fields, "</FieldData>"] if fields else []),
            f'<Piece NumberOfPoints="{n}" NumberOfCells="{n}">',
            "<PointData>\n"]).encode())
        for name, values, layout in point_data:
            _write_data_array(f, name, values, layout)
            f.write(b"\n")
            del values  # before the iterable makes the next
        f.write(b"</PointData>\n<Points>\n")
        _write_data_array(f, "Points", points)
        f.write(b"\n</Points>\n<Cells>\n")
        _write_data_array(f, "connectivity", Rows.of(n, np.arange, np.int64))
        f.write(b"\n")
        _write_data_array(f, "offsets", Rows.of(n, lambda a, b: np.arange(a + 1, b + 1), np.int64))
        f.write(b"\n")
        _write_data_array(f, "types", Rows.of(n, lambda a, b: np.ones(b - a), np.int32))  # VTK_VERTEX
        f.write(b"\n</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>")
    tmp.replace(path)


class ParticleSeries:
    """Particle snapshots ``particles_NNNNNN.vtu`` with a ``particles.pvd`` index.

    The index is rewritten after every snapshot, so an interrupted run leaves
    a valid series of the snapshots written so far. Each file has the
    ``field_data`` of :func:`write_vtu`.
    """

    def __init__(self, directory: Path, entries=(), field_data: Mapping[str, int] | None = None):
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self._entries: list[tuple[float, str]] = [(float(t), str(f)) for t, f in entries]
        self._field_data = dict(field_data or {})

    @property
    def entries(self) -> list[tuple[float, str]]:
        """(time, file name) of each snapshot so far; pass them back to continue the series."""
        return list(self._entries)

    def write(self, step: int, time: float, points: np.ndarray,
              point_data: Iterable[tuple[str, np.ndarray, str]]) -> Path:
        """Write snapshot ``step`` at ``time`` (:func:`write_vtu`) and the index."""
        name = f"particles_{step:06d}.vtu"
        write_vtu(self.directory / name, points, point_data, self._field_data)
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
