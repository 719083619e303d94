"""What acts on the bodies: tractions and body forces (``[[loads]]``) with
their amplitudes over time, grid walls (``[[walls]]``) and initial cracks
(``[[cracks]]``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .validation import (SceneError, boolean, choice, fmt, integer, planar_polygon, polyline, real, same_dimension,
                         seq, store, text, vec2, vector)

__all__ = ["EDGES", "SIDES", "SIDES_3D", "WALL_TYPES", "COMPONENTS", "COMPONENTS_3D", "Ramp", "Table",
           "AMPLITUDES", "SIDE_NAME", "normal_axis", "face_axes", "Traction", "BodyForce", "LOADS", "WallSpec", "Prescribed",
           "MAX_REGIONS", "Crack"]

EDGES = ("top", "bottom", "left", "right")
SIDES = ("left", "right", "bottom", "top")
"""The sides of a 2D grid (and the edges of a 2D body), in the order of the core's ``Side``."""
SIDES_3D = SIDES + ("back", "front")
"""The sides of a 3D grid: those of 2D, then z min (back) and z max (front)."""
WALL_TYPES = ("fixed", "slip")
COMPONENTS = ("x", "y", "xy")
"""The components a prescribed region of a 2D scene may hold."""
COMPONENTS_3D = ("x", "y", "z", "xy", "xz", "yz", "xyz")
"""The components a prescribed region of a 3D scene may hold."""


def _check_side(path: str, side: str, dim: int) -> None:
    """Check that ``side`` (a grid side or a body's face) exists in ``dim`` directions."""
    if dim == 2 and side in ("back", "front"):
        raise SceneError(path, "a side of a 3D grid (z min or max); a 2D grid has "
                         + ", ".join(SIDES), side)
MAX_REGIONS = 4  # the core's max_regions


@dataclass(frozen=True)
class Ramp:
    """A smooth ramp of a load (``amplitude = { type = "ramp", time = T }``):
    ``a(t) = s^2 (3 - 2 s)`` with ``s = t / T``, from 0 at t = 0 to 1 at T,
    then 1. Its rate is zero at both ends, so the load starts and levels off
    without the jump in rate that sends a wave through the body.

    Parameters
    ----------
    time : float
        Duration T of the ramp, > 0.
    """

    kind: ClassVar[str] = "ramp"
    time: float

    def __post_init__(self):
        store(self, "time", real("time", self.time, gt=0.0))

    def __call__(self, t: float) -> float:
        s = min(max(t / self.time, 0.0), 1.0)
        return s * s * (3.0 - 2.0 * s)


@dataclass(frozen=True)
class Table:
    """A load's amplitude as a table (``amplitude = { type = "table", times
    = [...], values = [...] }``): linear between the points, the first value
    before the first time and the last after the last.

    Parameters
    ----------
    times : sequence of float
        Strictly increasing times, at least one.
    values : sequence of float
        The amplitude at each time (finite; the load is multiplied by it).
    """

    kind: ClassVar[str] = "table"
    times: tuple[float, ...]
    values: tuple[float, ...]

    def __post_init__(self):
        times = seq("times", self.times, "times")
        values = seq("values", self.values, "values")
        if not times:
            raise SceneError("times", "needs at least one time", self.times)
        if len(values) != len(times):
            raise SceneError("values", f"must have one value per time ({len(times)})", self.values)
        times = tuple(real(f"times[{i}]", t) for i, t in enumerate(times))
        for i in range(1, len(times)):
            if times[i] <= times[i - 1]:
                raise SceneError(f"times[{i}]", f"must be greater than times[{i - 1}] = {fmt(times[i - 1])}",
                                 times[i])
        store(self, "times", times)
        store(self, "values", tuple(real(f"values[{i}]", v) for i, v in enumerate(values)))

    def __call__(self, t: float) -> float:
        return float(np.interp(t, self.times, self.values))


AMPLITUDES: dict[str, type] = {cls.kind: cls for cls in (Ramp, Table)}
"""Amplitude classes by their TOML ``type``."""


_NORMALS = {"left": 0, "right": 0, "bottom": 1, "top": 1, "back": 2, "front": 2}
"""The axis normal to each edge (face) of a body."""
SIDE_NAME = {2: "edge", 3: "face"}
"""What a body's side is called in each dimension."""


def normal_axis(edge: str) -> int:
    """The axis normal to a body's ``edge`` (a face in 3D)."""
    return _NORMALS[edge]


def face_axes(edge: str, dim: int) -> tuple[int, ...]:
    """The axes along a body's ``edge`` (a face in 3D), in axis order: all
    but its normal."""
    return tuple(k for k in range(dim) if k != _NORMALS[edge])


def _span(value) -> tuple[float, float] | tuple[tuple[float, float], tuple[float, float]]:
    """Check a traction's span: ``[a, b]`` (2D) or ``[[a, b], [c, d]]``
    (3D), each interval with a < b; its dimension is checked against the
    scene's (:meth:`Traction.check_dimension`)."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    shape = "must be [a, b] (an edge's, 2D) or [[a, b], [c, d]] (a face's, 3D)"
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise SceneError("span", shape, value)
    nested = [isinstance(v, (list, tuple, np.ndarray)) for v in value]
    if all(nested):
        intervals = tuple(vec2(f"span[{k}]", v) for k, v in enumerate(value))
    elif not any(nested):
        intervals = (vec2("span", value),)
    else:
        raise SceneError("span", shape, value)
    if not all(a < b for a, b in intervals):
        ordered = "[a, b] with a < b" if len(intervals) == 1 else "[[a, b], [c, d]] with a < b and c < d"
        raise SceneError("span", f"must be {ordered}", value)
    return intervals[0] if len(intervals) == 1 else intervals


def _amplitude(value) -> Ramp | Table | None:
    """Check a load's ``amplitude``: None (constant) or an amplitude."""
    if value is not None and not isinstance(value, (Ramp, Table)):
        raise SceneError("amplitude", "must be a Ramp or a Table", value)
    return value


@dataclass(frozen=True)
class Traction:
    """Traction on the outermost particle layer of a body on one side.

    Parameters
    ----------
    body : str
        Name of the loaded body.
    edge : str
        ``"top"``, ``"bottom"``, ``"left"`` or ``"right"``; in 3D also
        ``"back"`` (z min) and ``"front"`` (z max), the edge then a face.
    traction : sequence of float
        Traction vector (force per unit boundary area, stress units), one
        component per direction.
    amplitude : Ramp or Table or None
        The factor of the traction over time; ``None``: constant (a step at
        t = 0).
    span : (float, float) or ((float, float), (float, float)) or None
        Only part of the edge or face. In 2D one interval ``[a, b]`` of the
        coordinate along the edge (x on the top and bottom edges, y on the
        left and right ones); in 3D a rectangular patch of the face, one
        interval per axis along it in axis order (``[[x0, x1], [z0, z1]]``
        on the top and bottom faces, ``[[y0, y1], [z0, z1]]`` on the left
        and right ones, ``[[x0, x1], [y0, y1]]`` on the back and front
        ones). The particles of the layer whose coordinates lie in it are
        loaded, each carrying its share of the edge or face (the FEM's
        facets whose midpoint or centroid lies in it). ``None``: the whole
        edge or face.
    """

    kind: ClassVar[str] = "traction"
    body: str
    edge: str
    traction: tuple[float, ...]
    amplitude: Ramp | Table | None = None
    span: tuple[float, float] | tuple[tuple[float, float], tuple[float, float]] | None = None

    def __post_init__(self):
        store(self, "body", text("body", self.body))
        store(self, "edge", choice("edge", self.edge, EDGES + ("back", "front")))
        store(self, "traction", vector("traction", self.traction))
        store(self, "amplitude", _amplitude(self.amplitude))
        if self.span is not None:
            store(self, "span", _span(self.span))

    def check_dimension(self, dim: int) -> None:
        """Check the edge, the traction and the span's shape against a
        ``dim``-dimensional scene."""
        _check_side("edge", self.edge, dim)
        same_dimension("traction", self.traction, dim)
        if self.span is not None and len(self.intervals) != dim - 1:
            axes = " then ".join("xyz"[k] for k in face_axes(self.edge, dim))
            want = ("one interval [a, b], along " if dim == 2
                    else "two intervals [[a, b], [c, d]], along ") + f"{axes} on the {self.edge} {SIDE_NAME[dim]}"
            raise SceneError("span", f"in {dim}D a span is {want}", self.span)

    @property
    def intervals(self) -> tuple[tuple[float, float], ...]:
        """The span as intervals, one per axis along the edge or face; ()
        without one."""
        if self.span is None:
            return ()
        return (self.span,) if isinstance(self.span[0], float) else self.span

    def patch(self) -> tuple[tuple[int, float, float], ...]:
        """The span as ``(axis, a, b)``: the loaded part of the edge or face
        is where ``a <= x[axis] <= b`` for each; () without a span."""
        intervals = self.intervals
        return tuple((axis, a, b) for axis, (a, b) in zip(face_axes(self.edge, len(intervals) + 1), intervals))


@dataclass(frozen=True)
class BodyForce:
    """Uniform acceleration (gravity-like) on the particles of a body.

    Parameters
    ----------
    acceleration : sequence of float
        Acceleration vector, one component per direction.
    body : str or None
        Name of the loaded body; ``None`` loads all bodies.
    amplitude : Ramp or Table or None
        The factor of the acceleration over time; ``None``: constant.
    """

    kind: ClassVar[str] = "body_force"
    acceleration: tuple[float, ...]
    body: str | None = None
    amplitude: Ramp | Table | None = None

    def __post_init__(self):
        store(self, "acceleration", vector("acceleration", self.acceleration))
        if self.body is not None:
            store(self, "body", text("body", self.body))
        store(self, "amplitude", _amplitude(self.amplitude))

    def check_dimension(self, dim: int) -> None:
        """Check the acceleration against a ``dim``-dimensional scene."""
        same_dimension("acceleration", self.acceleration, dim)


LOADS: dict[str, type] = {cls.kind: cls for cls in (Traction, BodyForce)}
"""Load classes by their TOML ``type``."""


@dataclass(frozen=True)
class Prescribed:
    """Prescribed motion (``[[prescribed]]``): grid nodes that move with a
    given velocity, or by a given displacement, along the held components.
    The nodes are those whose control points lie in a box, or those a set of
    particles reaches (in their stencils), followed as the particles move: a
    body, one face of it, or some of its particles. Particles whose nodes are
    all held move with them; those partly over them are pulled along. The
    reaction (the momentum it adds to the bodies), the work it does on them
    and its displacement are in ``energies.csv`` (``impulse_<name>_x|y``,
    ``work_<name>``, part of ``total``, ``displacement_<name>_x|y``; and
    ``_z`` in 3D). Its vectors have one component per direction.

    Parameters
    ----------
    name : str
        Unique name, in the column names (not a grid side's).
    min, max : sequence of float or None
        A box: its corners, min < max; it must hold a grid node.
    body : str or None
        Instead of a box, the particles of this body: all of them, or with
        ``face`` or ``particles`` some.
    face : str or None
        With ``body``: ``"left"``, ``"right"``, ``"bottom"`` or ``"top"``
        (and in 3D ``"back"`` or ``"front"``),
        the body's particle layer on that side at t = 0 (within 0.51
        particle spacings of its outermost particle there, as a traction's
        edge).
    particles : sequence of int or None
        With ``body``: indices into the body's particles (0 to n - 1, in
        seeding order, as ``initial_damage``'s), each once.
    velocity : sequence of float or None
        The velocity, times ``amplitude(t)`` at each step's midpoint.
    displacement : sequence of float or None
        The displacement ``U (a(t) - a(0))``: each step the nodes move by
        ``U (a(t + dt) - a(t))``, so it is exact at every step; needs an
        ``amplitude``. Exactly one of ``velocity`` and ``displacement``.
    components : str or None
        ``"x"``, ``"y"`` or ``"xy"`` (in 3D also ``"z"``, ``"xz"``, ``"yz"``
        and ``"xyz"``): the components held; ``None``: all of them.
    amplitude : Ramp or Table or None
        The factor over time; ``None``: constant (velocity only).
    moving : bool
        For a box: whether it moves with the region's displacement (a rigid
        striker or a moving wall, which carries the material it holds
        along); ``False``, the default: it stays put (a grip or a support).
        The FEM holds the vertices in the box at t = 0 either way, which move
        with it. A body's region follows its particles anyway.
    """

    name: str
    min: tuple[float, ...] | None = None
    max: tuple[float, ...] | None = None
    velocity: tuple[float, ...] | None = None
    displacement: tuple[float, ...] | None = None
    components: str | None = None
    amplitude: Ramp | Table | None = None
    moving: bool = False
    body: str | None = None
    face: str | None = None
    particles: tuple[int, ...] | None = None

    def __post_init__(self):
        store(self, "name", text("name", self.name))
        if self.name in SIDES_3D:
            raise SceneError("name", "is a grid side's, which names the walls' columns", self.name)
        if self.body is None:
            self._check_box()
        else:
            self._check_body()
        if (self.velocity is None) == (self.displacement is None):
            raise SceneError("velocity", "give exactly one of velocity and displacement")
        if self.velocity is not None:
            store(self, "velocity", vector("velocity", self.velocity))
        else:
            store(self, "displacement", vector("displacement", self.displacement))
            if self.amplitude is None:
                raise SceneError("amplitude", "a displacement needs one (it is U (a(t) - a(0)))")
        if self.box:
            motion = "velocity" if self.velocity is not None else "displacement"
            for key in ("min", "max"):
                if len(getattr(self, key)) != self.dim:
                    raise SceneError(key, f"must have {self.dim} components, as {motion} has",
                                     getattr(self, key))
        if self.components is None:
            store(self, "components", "xyz"[:self.dim])
        store(self, "components", choice("components", self.components,
                                         COMPONENTS if self.dim == 2 else COMPONENTS_3D))
        store(self, "amplitude", _amplitude(self.amplitude))
        store(self, "moving", boolean("moving", self.moving))
        if self.moving and self.body is not None:
            raise SceneError("moving", "is for a box: a body's region follows its particles", self.moving)

    def _check_box(self) -> None:
        for key in ("face", "particles"):
            if getattr(self, key) is not None:
                raise SceneError(key, "needs a body", getattr(self, key))
        for key in ("min", "max"):
            if getattr(self, key) is None:
                raise SceneError(key, "missing: give a box (min and max) or a body")
        store(self, "min", vector("min", self.min))
        store(self, "max", vector("max", self.max))
        if not all(a < b for a, b in zip(self.min, self.max)):
            every = "both directions" if len(self.min) == 2 else "every direction"
            raise SceneError("max", f"must exceed min = {fmt(self.min)} in {every}", self.max)

    def _check_body(self) -> None:
        store(self, "body", text("body", self.body))
        for key in ("min", "max"):
            if getattr(self, key) is not None:
                raise SceneError(key, "give a box or a body, not both", getattr(self, key))
        if self.face is not None:
            store(self, "face", choice("face", self.face, SIDES_3D))
        if self.particles is not None:
            if self.face is not None:
                raise SceneError("particles", "give a face or particles, not both")
            indices = seq("particles", self.particles, "particle indices")
            if not indices:
                raise SceneError("particles", "must name at least one particle", self.particles)
            indices = tuple(integer(f"particles[{i}]", v, ge=0) for i, v in enumerate(indices))
            if len(set(indices)) != len(indices):
                raise SceneError("particles", "names a particle twice", list(indices))
            store(self, "particles", indices)

    @property
    def box(self) -> bool:
        """Whether it holds the nodes in a box (else those its body's particles reach)."""
        return self.body is None

    @property
    def dim(self) -> int:
        """The directions of its velocity or displacement: 2 or 3."""
        return len(self.velocity if self.velocity is not None else self.displacement)

    def check_dimension(self, dim: int) -> None:
        """Check the region's vectors and face against a ``dim``-dimensional scene."""
        key = "velocity" if self.velocity is not None else "displacement"
        same_dimension(key, getattr(self, key), dim)
        if self.face is not None:
            _check_side("face", self.face, dim)

    @property
    def mask(self) -> int:
        """The held components as the core's bits (1: x, 2: y, 4: z)."""
        return sum(1 << d for d, name in enumerate("xyz") if name in self.components)

    @property
    def steady(self) -> bool:
        """Whether its velocity is the same at every step."""
        return self.amplitude is None

    def velocity_over(self, t: float, dt: float) -> tuple[float, ...]:
        """The nodes' velocity over the step from ``t`` to ``t + dt``."""
        if self.velocity is not None:
            a = 1.0 if self.amplitude is None else self.amplitude(t + 0.5 * dt)
            return tuple(a * v for v in self.velocity)
        rate = (self.amplitude(t + dt) - self.amplitude(t)) / dt
        return tuple(rate * u for u in self.displacement)


@dataclass(frozen=True)
class WallSpec:
    """Velocity boundary condition on one side of the grid (``[[walls]]``); the
    core's ``Grid.set_wall`` applies it.

    Parameters
    ----------
    side : str
        ``"left"``, ``"right"``, ``"bottom"`` or ``"top"``; in 3D also
        ``"back"`` (z min) and ``"front"`` (z max).
    type : str
        ``"fixed"`` (every velocity component zero) or ``"slip"`` (normal
        component zero).
    """

    side: str
    type: str

    def __post_init__(self):
        store(self, "side", choice("side", self.side, SIDES_3D))
        store(self, "type", choice("type", self.type, WALL_TYPES))

    def check_dimension(self, dim: int) -> None:
        """Check that the side exists in a ``dim``-dimensional scene."""
        _check_side("side", self.side, dim)


@dataclass(frozen=True)
class Crack:
    """An initial crack, imposed as an initial history field (Borden et al. 2012).

    Points within ``half_width`` of the crack (a polyline in 2D, a planar
    patch in 3D) get ``H0 = B G_c / (4 l0) (1 - d / half_width)`` at
    distance ``d``; with the default ``half_width = l0 / 2`` this is
    Borden's formula.

    Parameters
    ----------
    points : sequence of (float, float) or of (float, float, float)
        In 2D the vertices of a polyline, at least two; in 3D the corners of
        a convex planar polygon, at least three, in order around it.
    body : str or None
        Body whose particles get the history; ``None``: every body that can crack.
    B : float
        Strength of the imposed history, > 0 (large: ``c`` near 0 on the line).
    half_width : float or None
        Half width of the band, > 0; ``None`` means ``l0 / 2``.
    """

    points: tuple[tuple[float, ...], ...]
    body: str | None = None
    B: float = 1e3
    half_width: float | None = None

    def __post_init__(self):
        points = seq("points", self.points, "points")
        three = bool(points) and all(isinstance(p, (list, tuple, np.ndarray)) and len(p) == 3 for p in points)
        store(self, "points", planar_polygon("points", points) if three else polyline("points", points))
        if self.body is not None:
            store(self, "body", text("body", self.body))
        store(self, "B", real("B", self.B, gt=0))
        if self.half_width is not None:
            store(self, "half_width", real("half_width", self.half_width, gt=0))

    @property
    def dim(self) -> int:
        """The directions of its points: 2 (a polyline) or 3 (a planar patch)."""
        return len(self.points[0])

    def check_dimension(self, dim: int) -> None:
        """Check that the crack is a polyline of a 2D scene or a patch of a 3D one."""
        if self.dim != dim:
            want = ("a polyline of [x, y] points" if dim == 2
                    else "a convex planar polygon of three or more [x, y, z] points")
            raise SceneError("points", f"{self.dim}D points in a {dim}D scene (grid.size has {dim}"
                                       f" entries): give {want}", self.points)

    def tip(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """The tip at the crack's last point and the direction it points in,
        along its last segment (not of unit length); a 2D crack's."""
        if self.dim != 2:
            raise ValueError("a 3D crack (a planar patch) has no tip: its front is measured along"
                             " output.crack_direction")
        (ax, ay), (bx, by) = self.points[-2], self.points[-1]
        return (bx, by), (bx - ax, by - ay)
