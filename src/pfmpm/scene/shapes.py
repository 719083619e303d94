"""The shapes bodies and their holes are made of (TOML ``type`` of a
``shape`` or ``holes`` table). In 2D: rectangles, disks, rings, polygons, the
cells of a mesh file and the pixels of one colour of an image; in 3D: boxes,
spheres, cylinders, the volume cells of a mesh file and the extrusion of any
2D shape along z."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np

from .validation import SceneError, fmt, integer, real, seq, store, text, vec2, vector

__all__ = ["Shape", "Rectangle", "Disk", "Ring", "Polygon", "MeshShape", "ImageShape", "Box", "Sphere",
           "Cylinder", "Extrusion", "SHAPES", "image_colors", "distance_to_polyline",
           "distance_to_polygon"]


def distance_to_polyline(xy: np.ndarray, points) -> np.ndarray:
    """Distance from each row of ``xy`` (N, 2) to the polyline through ``points``
    (the bands of initial cracks and of initial damage)."""
    xy = np.asarray(xy, dtype=float)
    pts = np.asarray(points, dtype=float)
    d = np.full(len(xy), np.inf)
    for a, b in zip(pts[:-1], pts[1:]):
        ab = b - a
        t = np.clip(((xy - a) @ ab) / max(ab @ ab, np.finfo(float).tiny), 0.0, 1.0)
        d = np.minimum(d, np.hypot(*(xy - a - t[:, None] * ab).T))
    return d


def distance_to_polygon(xyz: np.ndarray, points) -> np.ndarray:
    """Distance from each row of ``xyz`` (N, 3) to the convex planar polygon
    with corners ``points`` (in order around it; the patch of a 3D initial
    crack, :func:`~pfmpm.scene.validation.planar_polygon`): the distance to
    the plane where a point's foot lies inside the polygon, else to the
    nearest of its sides."""
    xyz = np.asarray(xyz, dtype=float)
    pts = np.asarray(points, dtype=float)
    normal = np.cross(pts, np.roll(pts, -1, axis=0)).sum(axis=0)  # Newell: along the polygon's turn
    normal /= np.sqrt(normal @ normal)
    rel = xyz - pts[0]
    height = rel @ normal
    inside = np.ones(len(xyz), dtype=bool)
    side = np.full(len(xyz), np.inf)
    for a, b in zip(pts, np.roll(pts, -1, axis=0)):
        ab = b - a
        inside &= (xyz - a) @ np.cross(normal, ab) >= 0.0  # on the inner side of side ab
        t = np.clip(((xyz - a) @ ab) / (ab @ ab), 0.0, 1.0)
        gap = xyz - a - t[:, None] * ab
        side = np.minimum(side, np.sqrt(np.einsum("ij,ij->i", gap, gap)))
    return np.where(inside, np.abs(height), side)


class Shape:
    """Base of the shapes that bodies and holes are made of.

    Subclasses set ``kind`` (the TOML ``type``) and, for a 3D shape,
    ``dim = 3`` (a mesh sets it per instance, as its file's cells are), and
    implement :meth:`contains` and :meth:`bounds`.
    """

    kind: ClassVar[str]
    dim: ClassVar[int] = 2
    """The directions of the space the shape lies in: 2 or 3."""

    def contains(self, *coords: np.ndarray) -> np.ndarray:
        """Return a boolean array, True where the point of coordinates
        ``coords`` (``x, y``, or ``x, y, z`` in 3D) is inside."""
        raise NotImplementedError

    def bounds(self) -> tuple[float, ...]:
        """Return the bounding box: ``(xmin, ymin, xmax, ymax)``, or in 3D
        ``(xmin, ymin, zmin, xmax, ymax, zmax)``."""
        raise NotImplementedError

    def check_dimension(self, dim: int) -> None:
        """Check that the shape fits a ``dim``-dimensional scene (the grid's)."""
        if self.dim != dim:
            hint = ("; extrude it (type = \"extrusion\") or use a box, sphere or cylinder" if dim == 3
                    else "")
            raise SceneError("", f"a {self.dim}D shape ({self.kind}) in a {dim}D scene"
                                 f" (grid.size has {dim} entries){hint}", self.kind)


@dataclass(frozen=True)
class Rectangle(Shape):
    """Axis-aligned rectangle ``min <= (x, y) <= max`` (closed).

    Parameters
    ----------
    min, max : (float, float)
        Lower-left and upper-right corners, ``min < max`` componentwise.
    """

    kind: ClassVar[str] = "rectangle"
    min: tuple[float, float]
    max: tuple[float, float]

    def __post_init__(self):
        store(self, "min", vec2("min", self.min))
        store(self, "max", vec2("max", self.max))
        if not (self.min[0] < self.max[0] and self.min[1] < self.max[1]):
            raise SceneError("max", f"must exceed min = {fmt(self.min)} componentwise", self.max)

    def contains(self, x, y):
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        return (x >= self.min[0]) & (x <= self.max[0]) & (y >= self.min[1]) & (y <= self.max[1])

    def bounds(self):
        return (*self.min, *self.max)


@dataclass(frozen=True)
class Disk(Shape):
    """Closed disk.

    Parameters
    ----------
    center : (float, float)
        Centre.
    radius : float
        Radius, > 0.
    """

    kind: ClassVar[str] = "disk"
    center: tuple[float, float]
    radius: float

    def __post_init__(self):
        store(self, "center", vec2("center", self.center))
        store(self, "radius", real("radius", self.radius, gt=0))

    def contains(self, x, y):
        dx = np.asarray(x, dtype=float) - self.center[0]
        dy = np.asarray(y, dtype=float) - self.center[1]
        with np.errstate(over="ignore"):
            return dx * dx + dy * dy <= self.radius * self.radius

    def bounds(self):
        (cx, cy), r = self.center, self.radius
        return (cx - r, cy - r, cx + r, cy + r)


@dataclass(frozen=True)
class Ring(Shape):
    """Annulus ``inner_radius <= |p - center| <= outer_radius``.

    Parameters
    ----------
    center : (float, float)
        Centre.
    inner_radius : float
        Inner radius, >= 0.
    outer_radius : float
        Outer radius, > ``inner_radius``.
    """

    kind: ClassVar[str] = "ring"
    center: tuple[float, float]
    inner_radius: float
    outer_radius: float

    def __post_init__(self):
        store(self, "center", vec2("center", self.center))
        store(self, "inner_radius", real("inner_radius", self.inner_radius, ge=0))
        store(self, "outer_radius", real("outer_radius", self.outer_radius, gt=self.inner_radius))

    def contains(self, x, y):
        dx = np.asarray(x, dtype=float) - self.center[0]
        dy = np.asarray(y, dtype=float) - self.center[1]
        with np.errstate(over="ignore"):
            r2 = dx * dx + dy * dy
            return (r2 >= self.inner_radius * self.inner_radius) & (
                r2 <= self.outer_radius * self.outer_radius)

    def bounds(self):
        (cx, cy), r = self.center, self.outer_radius
        return (cx - r, cy - r, cx + r, cy + r)


@dataclass(frozen=True)
class Polygon(Shape):
    """Simple polygon; inside is decided by the even-odd rule.

    Parameters
    ----------
    vertices : sequence of (float, float)
        At least 3 vertices enclosing a non-zero area (self-intersection is
        not checked).
    """

    kind: ClassVar[str] = "polygon"
    vertices: tuple[tuple[float, float], ...]

    def __post_init__(self):
        points = seq("vertices", self.vertices, "[x, y] points")
        if len(points) < 3:
            raise SceneError("vertices", "must have at least 3 points", self.vertices)
        store(self, "vertices", tuple(vec2(f"vertices[{i}]", p) for i, p in enumerate(points)))
        v = np.array(self.vertices)
        v = v / max(np.abs(v).max(), np.finfo(float).tiny)  # scaled to [-1, 1]: no overflow
        area = 0.5 * abs(np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]))
        extent = np.ptp(v, axis=0)
        if not area > 1e-12 * float(extent @ extent):
            raise SceneError("vertices", "polygon is degenerate (zero area)", self.vertices)

    def contains(self, x, y):
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        inside = np.zeros(np.broadcast(x, y).shape, dtype=bool)
        ring = self.vertices[1:] + self.vertices[:1]
        for (x1, y1), (x2, y2) in zip(self.vertices, ring):
            if y1 == y2:
                continue  # horizontal edges never cross a horizontal ray
            crosses = (y1 > y) != (y2 > y)
            with np.errstate(over="ignore", invalid="ignore"):
                x_cross = x1 + (y - y1) * ((x2 - x1) / (y2 - y1))
            inside ^= crosses & (x < x_cross)
        return inside

    def bounds(self):
        v = np.array(self.vertices)
        return (*map(float, v.min(axis=0)), *map(float, v.max(axis=0)))


#: meshio cell types read as triangles, each by its corner vertices (and quads cut in two).
_MESH_CELLS = {"triangle": 3, "triangle6": 3, "triangle7": 3, "quad": 4, "quad8": 4, "quad9": 4}

_HEX_TETS = ((0, 1, 2, 6), (0, 2, 3, 6), (0, 3, 7, 6), (0, 7, 4, 6), (0, 4, 5, 6), (0, 5, 1, 6))
"""A hexahedron (meshio's and VTK's corner order: 0-3 one face, 4-7 the
opposite one, 4 across from 0) as six tetrahedra about its diagonal 0-6: each
face is cut along a diagonal that a neighbour sharing the face, numbered the
same way, cuts it along too."""

#: meshio volume cell types, each as tetrahedra of its corner vertices (higher-order cells by their corners).
_VOLUME_CELLS = {
    **dict.fromkeys(("tetra", "tetra10"), ((0, 1, 2, 3),)),
    **dict.fromkeys(("hexahedron", "hexahedron20", "hexahedron24", "hexahedron27"), _HEX_TETS),
    **dict.fromkeys(("wedge", "wedge15", "wedge18"), ((0, 1, 2, 3), (1, 2, 3, 4), (2, 3, 4, 5))),
    **dict.fromkeys(("pyramid", "pyramid13", "pyramid14"), ((0, 1, 2, 4), (0, 2, 3, 4))),
}

_BARY_TOL = 1e-9
"""Barycentric slack of a point in a tetrahedron, relative to its size: a
point on a face that two cells share is inside both, and on the mesh's outer
surface inside it."""
_PAIRS = 1 << 18
"""(point, candidate tetrahedron) pairs tested per vectorised batch (~50 MB)."""


class _TetLocator:
    """Which points lie in some tetrahedron of a set: a uniform grid of bins
    over the tetrahedra's bounding box, each bin listing the tetrahedra whose
    bounding boxes reach it (a CSR table), and a barycentric test of each
    point against the tetrahedra of its bin, ``_PAIRS`` pairs at a time.

    Parameters
    ----------
    points : (n, 3) array
        The vertices.
    tets : (m, 4) array of int
        The tetrahedra's vertices, of non-zero volume (either orientation).
    """

    def __init__(self, points: np.ndarray, tets: np.ndarray):
        corners = points[tets]  # (m, 4, 3)
        self._origin = corners[:, 0]
        # lambda_{1,2,3} = inv([v1 - v0, v2 - v0, v3 - v0]) (p - v0); lambda_0 = 1 - their sum
        self._inverse = np.linalg.inv(np.swapaxes(corners[:, 1:] - corners[:, :1], 1, 2))
        lo, hi = corners.min(axis=1), corners.max(axis=1)
        pad = _BARY_TOL * (hi - lo).max(axis=1, keepdims=True)
        lo, hi = lo - pad, hi + pad
        self._lo = lo.min(axis=0)
        extent = hi.max(axis=0) - self._lo
        # Bins half a typical cell's extent in each direction: a cell's box
        # reaches about 3 x 3 x 3 bins, and a bin meets the boxes of a few
        # tens of tetrahedra.
        side = 0.5 * np.median(hi - lo, axis=0)
        while np.prod(np.ceil(extent / side)) > 8 * len(tets) + 64:
            side *= 1.25
        self._side = side
        self._bins = np.maximum(np.ceil(extent / side).astype(np.int64), 1)
        index = np.int32 if max(len(tets), int(np.prod(self._bins))) < 2**31 else np.int64  # of bins and tetrahedra
        bins, owners = [], []
        step = max(_PAIRS // 27, 1)
        for a in range(0, len(tets), step):  # the (bin, tetrahedron) pairs, a batch of tetrahedra at a time
            first, last = self._cell(lo[a:a + step]), self._cell(hi[a:a + step])
            span = last - first + 1  # bins reached in each direction
            reach = np.prod(span, axis=1)
            tet = np.repeat(np.arange(len(span)), reach)
            k = np.arange(len(tet)) - np.repeat(np.cumsum(reach) - reach, reach)  # 0 .. reach - 1 per tetrahedron
            k, dz = np.divmod(k, span[tet, 2])
            dx, dy = np.divmod(k, span[tet, 1])
            bins.append(self._flat(first[tet] + np.column_stack([dx, dy, dz])).astype(index))
            owners.append((tet + a).astype(index))
        bins = np.concatenate(bins)
        order = np.argsort(bins, kind="stable")
        self._tets = np.concatenate(owners)[order]
        self._start = np.concatenate([[0], np.cumsum(np.bincount(bins, minlength=int(np.prod(self._bins))))])

    def _cell(self, p: np.ndarray) -> np.ndarray:
        """The bin indices (k, 3) of points (k, 3), clipped to the grid of bins."""
        return np.clip(np.floor((p - self._lo) / self._side), 0, self._bins - 1).astype(np.int64)

    def _flat(self, ijk: np.ndarray) -> np.ndarray:
        return (ijk[:, 0] * self._bins[1] + ijk[:, 1]) * self._bins[2] + ijk[:, 2]

    def contains(self, p: np.ndarray) -> np.ndarray:
        """True for each point of ``p`` (k, 3) inside (or on) a tetrahedron."""
        inside = np.zeros(len(p), dtype=bool)
        with np.errstate(invalid="ignore", over="ignore"):
            outer = self._lo + self._side * self._bins
            near = np.all((p >= self._lo) & (p <= outer), axis=1)  # NaN and inf are not
        near = np.flatnonzero(near)
        b = self._flat(self._cell(p[near]))
        first, count = self._start[b], self._start[b + 1] - self._start[b]
        ends = np.cumsum(count)
        a = 0
        while a < len(near):  # batches of whole points, about _PAIRS pairs each
            z = max(int(np.searchsorted(ends, ends[a] - count[a] + _PAIRS, side="right")), a + 1)
            n = count[a:z]
            which = np.repeat(np.arange(a, z), n)
            k = np.arange(len(which)) - np.repeat(np.cumsum(n) - n, n) + np.repeat(first[a:z], n)
            tet = self._tets[k]
            lam = np.einsum("kij,kj->ki", self._inverse[tet], p[near[which]] - self._origin[tet])
            hit = np.all(lam >= -_BARY_TOL, axis=1) & (lam.sum(axis=1) <= 1.0 + _BARY_TOL)
            inside[near[which[hit]]] = True
            a = z
        return inside


@dataclass(frozen=True)
class MeshShape(Shape):
    """The region covered by the cells of a mesh file that meshio reads
    (gmsh ``.msh``, VTK ``.vtk``/``.vtu``, ...), a 2D or a 3D shape as the
    file's cells are.

    A mesh with volume cells is a 3D shape (``dim = 3``): its tetrahedra and
    hexahedra (also wedges and pyramids; higher-order cells by their
    corners), each hexahedron cut into six tetrahedra, its other cells
    ignored.  Any other is a 2D shape of its triangles and quadrilaterals
    (by their corners), its points all at one z.  Line and vertex cells are
    ignored.  Where no cell lies there is no body: a cavity the mesh leaves
    out stays empty.  A body of this shape is filled with the scene's
    particle lattice like any other, so its particles' volume is that of the
    lattice cells inside the mesh.

    Parameters
    ----------
    file : str
        The mesh file.  In a scene file a relative path is taken from the
        scene file's folder; elsewhere from the current directory.
    scale : float
        Factor applied to the mesh coordinates (e.g. 1000 for a mesh in m in
        an mm scene), > 0.
    offset : (float, float) or (float, float, float)
        Added to the coordinates after scaling, one entry per direction of
        the mesh; default zero.
    """

    kind: ClassVar[str] = "mesh"
    file: str
    scale: float = 1.0
    offset: tuple[float, ...] | None = None

    def __post_init__(self):
        store(self, "file", str(Path(text("file", self.file)).absolute()))
        store(self, "scale", real("scale", self.scale, gt=0))
        offset = None if self.offset is None else vector("offset", self.offset)
        import meshio

        try:
            mesh = meshio.read(self.file)
        except (Exception, SystemExit) as err:  # meshio raises many kinds, and exits on some files
            raise SceneError("file", f"cannot be read as a mesh ({type(err).__name__}: {err})",
                             self.file) from None
        have = ", ".join(sorted({b.type for b in mesh.cells})) or "none"
        object.__setattr__(self, "_have", have)
        points = np.asarray(mesh.points, dtype=float)
        tets = [block.data[:, list(tet)] for block in mesh.cells for tet in _VOLUME_CELLS.get(block.type, ())]
        if tets:
            self._volume_cells(points, np.concatenate(tets).astype(np.int64), offset)
        else:
            self._plane_cells(mesh, points, offset)

    def _volume_cells(self, points: np.ndarray, tets: np.ndarray, offset) -> None:
        """Keep the tetrahedra of a 3D mesh, its points scaled and offset."""
        if points.shape[1] != 3:
            raise SceneError("file", f"has volume cells ({self._have}) but {points.shape[1]}D points", self.file)
        object.__setattr__(self, "dim", 3)
        store(self, "offset", (0.0,) * 3 if offset is None else offset)
        if len(self.offset) != 3:
            raise SceneError("offset", f"has {len(self.offset)} components, but the mesh is 3D (it has"
                                       f" {self._have})", self.offset)
        used, tets = np.unique(tets, return_inverse=True)
        xyz = points[used] * self.scale + np.asarray(self.offset)
        tets = tets.reshape(-1, 4)
        edges = xyz[tets[:, 1:]] - xyz[tets[:, :1]]
        volume = np.abs(np.linalg.det(edges)) / 6.0
        solid = volume > 1e-12 * np.abs(edges).max(axis=(1, 2)) ** 3  # flat ones cover no volume: left out
        if not solid.any():
            raise SceneError("file", f"has volume cells ({self._have}) but all of zero volume", self.file)
        tets, volume = tets[solid], volume[solid]
        object.__setattr__(self, "_points", xyz)
        object.__setattr__(self, "_tets", tets)
        object.__setattr__(self, "_measure", float(volume.sum()))

    def _plane_cells(self, mesh, points: np.ndarray, offset) -> None:
        """Keep the triangles of a 2D mesh, its points scaled and offset."""
        triangles = []
        for block in mesh.cells:
            corners = _MESH_CELLS.get(block.type)
            if corners == 3:
                triangles.append(block.data[:, :3])
            elif corners == 4:
                quads = block.data[:, :4]
                triangles += [quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]]
        if not triangles:
            raise SceneError("file", f"has no triangle or quadrilateral cells (it has {self._have}) and no"
                                     " tetrahedra or hexahedra", self.file)
        if points.shape[1] > 2 and np.ptp(points[:, 2]) > 1e-9 * max(np.ptp(points[:, :2]), 1e-300):
            raise SceneError("file", f"has no tetrahedra or hexahedra (it has {self._have}) and is not flat"
                                     " (its points have different z): a 3D body needs volume cells, a 2D"
                                     " one a flat mesh", self.file)
        store(self, "offset", (0.0,) * 2 if offset is None else offset)
        if len(self.offset) != 2:
            raise SceneError("file", f"has no tetrahedra or hexahedra (it has {self._have}): a 2D mesh, but"
                                     f" offset = {fmt(self.offset)} has {len(self.offset)} components", self.file)
        tri = np.concatenate(triangles).astype(np.int64)
        used, tri = np.unique(tri, return_inverse=True)
        xy = points[used, :2] * self.scale + np.asarray(self.offset)
        tri = tri.reshape(-1, 3)
        a, b, c = xy[tri[:, 0]], xy[tri[:, 1]], xy[tri[:, 2]]
        area = 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1]))
        if not np.all(np.abs(area) > 0):
            raise SceneError("file", f"has {int(np.sum(area == 0))} cells of zero area", self.file)
        object.__setattr__(self, "_points", xy)
        object.__setattr__(self, "_triangles", tri)
        object.__setattr__(self, "_measure", float(np.abs(area).sum()))

    @property
    def area(self) -> float:
        """The area of a 2D mesh's cells (after ``scale``)."""
        if self.dim != 2:
            raise AttributeError(f"a {self.dim}D mesh has a volume, not an area")
        return self._measure

    @property
    def volume(self) -> float:
        """The volume of a 3D mesh's cells (after ``scale``)."""
        if self.dim != 3:
            raise AttributeError(f"a {self.dim}D mesh has an area, not a volume")
        return self._measure

    def check_dimension(self, dim: int) -> None:
        if self.dim == dim:
            return
        if dim == 3:
            reason = (f"has no tetrahedra or hexahedra (it has {self._have}): a 2D mesh in a 3D scene"
                      " (grid.size has 3 entries); mesh its volume, or extrude it (type = \"extrusion\")")
        else:
            reason = (f"has volume cells (it has {self._have}): a 3D mesh in a 2D scene (grid.size has 2"
                      " entries)")
        raise SceneError("file", reason, self.file)

    def contains(self, *coords):
        if len(coords) != self.dim:
            raise ValueError(f"a {self.dim}D mesh takes {self.dim} coordinates, not {len(coords)}")
        coords = np.broadcast_arrays(*(np.asarray(c, dtype=float) for c in coords))
        if self.dim == 3:
            if not hasattr(self, "_locator"):
                object.__setattr__(self, "_locator", _TetLocator(self._points, self._tets))
            shape = coords[0].shape
            return self._locator.contains(np.column_stack([c.ravel() for c in coords])).reshape(shape)
        if not hasattr(self, "_finder"):
            from matplotlib.tri import Triangulation

            finder = Triangulation(self._points[:, 0], self._points[:, 1], self._triangles).get_trifinder()
            object.__setattr__(self, "_finder", finder)
        return self._finder(*coords) >= 0

    def bounds(self):
        return (*map(float, self._points.min(axis=0)), *map(float, self._points.max(axis=0)))


def _read_image(path: str) -> np.ndarray:
    """The RGBA pixels (rows top down) of a PNG file as uint8, (rows, columns, 4)."""
    import matplotlib.image as mpimg

    image = mpimg.imread(path)
    if image.dtype != np.uint8:
        image = np.round(np.asarray(image, dtype=float) * 255).astype(np.uint8)
    if image.ndim == 2:
        image = np.repeat(image[:, :, None], 3, axis=2)
    if image.shape[2] == 3:
        image = np.concatenate([image, np.full(image.shape[:2] + (1,), 255, np.uint8)], axis=2)
    return image


def _color(value) -> tuple[int, int, int]:
    """An RGB colour from ``"#rrggbb"`` or ``[r, g, b]`` (0-255)."""
    if isinstance(value, str):
        hexa = value.removeprefix("#")
        if len(hexa) != 6 or any(ch not in "0123456789abcdefABCDEF" for ch in hexa):
            raise SceneError("color", "must be \"#rrggbb\" or [r, g, b] with 0-255", value)
        return tuple(int(hexa[k: k + 2], 16) for k in (0, 2, 4))
    items = seq("color", value, "3 integers 0-255")
    if len(items) != 3:
        raise SceneError("color", "must be \"#rrggbb\" or [r, g, b] with 0-255", value)
    rgb = tuple(integer(f"color[{k}]", v, ge=0) for k, v in enumerate(items))
    if max(rgb) > 255:
        raise SceneError("color", "must be \"#rrggbb\" or [r, g, b] with 0-255", value)
    return rgb


def image_colors(file: str) -> dict[str, int]:
    """The colours of a PNG mask, ``"#rrggbb"`` to their pixel counts, most
    pixels first; transparent pixels left out.  Each colour can be the
    ``color`` of an :class:`ImageShape`, one body per colour."""
    image = _read_image(file)
    opaque = image[..., 3] > 0
    colours, counts = np.unique(image[opaque][:, :3], axis=0, return_counts=True)
    order = np.argsort(-counts, kind="stable")
    return {"#" + "".join(f"{v:02x}" for v in colours[k]): int(counts[k]) for k in order}


@dataclass(frozen=True)
class ImageShape(Shape):
    """The pixels of one colour of a PNG image: a mask drawn in any paint
    program, one body per colour (:func:`image_colors` lists them).

    Parameters
    ----------
    file : str
        The PNG file.  In a scene file a relative path is taken from the
        scene file's folder; elsewhere from the current directory.
    pixel : float
        The side of a pixel in scene units, > 0.
    color : str or (int, int, int)
        The body's colour, ``"#rrggbb"`` or ``[r, g, b]`` (0-255);
        transparent pixels never count.
    origin : (float, float)
        Where the image's lower-left corner lies.
    """

    kind: ClassVar[str] = "image"
    file: str
    pixel: float
    color: str | tuple[int, int, int]
    origin: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self):
        store(self, "file", str(Path(text("file", self.file)).absolute()))
        store(self, "pixel", real("pixel", self.pixel, gt=0))
        rgb = _color(self.color)
        store(self, "color", "#" + "".join(f"{v:02x}" for v in rgb))
        store(self, "origin", vec2("origin", self.origin))
        try:
            image = _read_image(self.file)
        except (OSError, ValueError, SyntaxError) as err:
            raise SceneError("file", f"cannot be read as a PNG image ({err})", self.file) from None
        mask = np.all(image[..., :3] == rgb, axis=2) & (image[..., 3] > 0)
        if not mask.any():
            raise SceneError("color", f"no pixel of {self.file} has it", self.color)
        object.__setattr__(self, "_mask", mask[::-1])  # rows bottom up, as y grows

    @property
    def area(self) -> float:
        """The area of the body's pixels."""
        return float(self._mask.sum()) * self.pixel ** 2

    def contains(self, x, y):
        x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        rows, cols = self._mask.shape
        with np.errstate(invalid="ignore", over="ignore"):
            i = np.floor((x - self.origin[0]) / self.pixel)
            j = np.floor((y - self.origin[1]) / self.pixel)
        inside = (i >= 0) & (i < cols) & (j >= 0) & (j < rows)
        out = np.zeros(x.shape, dtype=bool)
        out[inside] = self._mask[j[inside].astype(np.int64), i[inside].astype(np.int64)]
        return out

    def bounds(self):
        rows, cols = np.nonzero(self._mask)
        (ox, oy), p = self.origin, self.pixel
        return (ox + cols.min() * p, oy + rows.min() * p, ox + (cols.max() + 1) * p, oy + (rows.max() + 1) * p)


def _vec3(path: str, value) -> tuple[float, float, float]:
    """Check a point or vector of 3D space."""
    v = vector(path, value)
    if len(v) != 3:
        raise SceneError(path, "must be a list of 3 numbers (a 3D point)", value)
    return v


@dataclass(frozen=True)
class Box(Shape):
    """Axis-aligned box ``min <= (x, y, z) <= max`` (closed), a 3D shape.

    Parameters
    ----------
    min, max : (float, float, float)
        Opposite corners, ``min < max`` componentwise.
    """

    kind: ClassVar[str] = "box"
    dim: ClassVar[int] = 3
    min: tuple[float, float, float]
    max: tuple[float, float, float]

    def __post_init__(self):
        store(self, "min", _vec3("min", self.min))
        store(self, "max", _vec3("max", self.max))
        if not all(a < b for a, b in zip(self.min, self.max)):
            raise SceneError("max", f"must exceed min = {fmt(self.min)} componentwise", self.max)

    def contains(self, x, y, z):
        inside = np.ones(np.broadcast(x, y, z).shape, dtype=bool)
        for c, lo, hi in zip((x, y, z), self.min, self.max):
            c = np.asarray(c, dtype=float)
            inside &= (c >= lo) & (c <= hi)
        return inside

    def bounds(self):
        return (*self.min, *self.max)


@dataclass(frozen=True)
class Sphere(Shape):
    """Closed ball, a 3D shape.

    Parameters
    ----------
    center : (float, float, float)
        Centre.
    radius : float
        Radius, > 0.
    """

    kind: ClassVar[str] = "sphere"
    dim: ClassVar[int] = 3
    center: tuple[float, float, float]
    radius: float

    def __post_init__(self):
        store(self, "center", _vec3("center", self.center))
        store(self, "radius", real("radius", self.radius, gt=0))

    def contains(self, x, y, z):
        with np.errstate(over="ignore"):
            r2 = sum((np.asarray(c, dtype=float) - o) ** 2 for c, o in zip((x, y, z), self.center))
            return r2 <= self.radius * self.radius

    def bounds(self):
        r = self.radius
        return (*(o - r for o in self.center), *(o + r for o in self.center))


@dataclass(frozen=True)
class Cylinder(Shape):
    """Closed circular cylinder about the segment from ``start`` to ``end``
    (its axis, with flat ends there), a 3D shape.

    Parameters
    ----------
    start, end : (float, float, float)
        The centres of its two ends, apart.
    radius : float
        Radius, > 0.
    """

    kind: ClassVar[str] = "cylinder"
    dim: ClassVar[int] = 3
    start: tuple[float, float, float]
    end: tuple[float, float, float]
    radius: float

    def __post_init__(self):
        store(self, "start", _vec3("start", self.start))
        store(self, "end", _vec3("end", self.end))
        store(self, "radius", real("radius", self.radius, gt=0))
        axis = np.subtract(self.end, self.start)
        if not 0 < float(np.sqrt(axis @ axis)) < np.inf:
            raise SceneError("end", f"must lie a finite distance from start = {fmt(self.start)}", self.end)

    def contains(self, x, y, z):
        a, axis = np.asarray(self.start), np.subtract(self.end, self.start)
        d = [np.asarray(c, dtype=float) - o for c, o in zip((x, y, z), a)]
        length2 = float(axis @ axis)
        with np.errstate(over="ignore", invalid="ignore"):
            along = sum(di * ai for di, ai in zip(d, axis))  # (p - start) . axis
            across2 = sum(di * di for di in d) - along * along / length2
            return (along >= 0) & (along <= length2) & (across2 <= self.radius * self.radius)

    def bounds(self):
        a, b = np.asarray(self.start), np.asarray(self.end)
        e = (b - a) / np.sqrt((b - a) @ (b - a))
        reach = self.radius * np.sqrt(np.maximum(1.0 - e * e, 0.0))  # an end disk's extent per direction
        lo, hi = np.minimum(a, b) - reach, np.maximum(a, b) + reach
        return (*map(float, lo), *map(float, hi))


@dataclass(frozen=True)
class Extrusion(Shape):
    """A 2D shape extruded along z from ``z0`` to ``z1`` (closed), a 3D shape:
    a disk makes a cylinder along z, a rectangle a box, a mesh or an image
    a prism of its outline.

    Parameters
    ----------
    shape : Shape
        Any 2D shape (rectangle, disk, ring, polygon, mesh, image).
    z0, z1 : float
        The extent along z, ``z0 < z1``.
    """

    kind: ClassVar[str] = "extrusion"
    dim: ClassVar[int] = 3
    shape: Shape
    z0: float
    z1: float

    def __post_init__(self):
        if not isinstance(self.shape, Shape):
            raise SceneError("shape", "must be a 2D shape (" + ", ".join(
                k for k, cls in SHAPES.items() if cls.dim == 2) + ")", self.shape)
        if self.shape.dim != 2:
            raise SceneError("shape", f"a {self.shape.dim}D shape ({self.shape.kind}): an extrusion"
                                      " takes a 2D one", self.shape.kind)
        store(self, "z0", real("z0", self.z0))
        store(self, "z1", real("z1", self.z1, gt=self.z0))

    def contains(self, x, y, z):
        z = np.asarray(z, dtype=float)
        return self.shape.contains(x, y) & (z >= self.z0) & (z <= self.z1)

    def bounds(self):
        x0, y0, x1, y1 = self.shape.bounds()
        return (x0, y0, self.z0, x1, y1, self.z1)


SHAPES: dict[str, type[Shape]] = {cls.kind: cls for cls in (Rectangle, Disk, Ring, Polygon, MeshShape,
                                                             ImageShape, Box, Sphere, Cylinder, Extrusion)}
"""Shape classes by their TOML ``type``."""
