"""Scene declaration for pfmpm: dataclasses, TOML loading, validation and particles.

A scene describes one 2D explicit MPM run: the background grid, the time
interval, the output cadence, the materials, the bodies (shapes filled with
particles), the loads and the grid walls.  Scenes are written in TOML (see
``docs``) or built directly from the dataclasses below; both routes run the
same validation and report the first problem as a :class:`SceneError` whose
one-line message names the offending key path, e.g.::

    materials[0].E = -5.0: must be > 0
    grid.hx: unknown key (allowed: size, h, origin, degree)

Units are any consistent set (typically mm, µs, µg, N, MPa).
"""

from __future__ import annotations

import copy
import dataclasses
import math
import numbers
import os
import re
import tomllib
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar

import numpy as np

from .anisotropy import check_gamma

__all__ = [
    "SceneError",
    "Grid",
    "Time",
    "Output",
    "Material",
    "Fracture",
    "Anisotropy",
    "Shape",
    "Rectangle",
    "Disk",
    "Ring",
    "Polygon",
    "Body",
    "Traction",
    "BodyForce",
    "Wall",
    "Crack",
    "PhaseField",
    "ContactPair",
    "Contact",
    "Scene",
    "apply_overrides",
    "wave_speed",
    "rayleigh_speed",
]

PLANES = ("strain", "stress")
DEGREES = (1, 2, 3)
MODELS = ("linear_elastic",)
SPLITS = ("spectral", "volumetric_deviatoric", "none")
SYMMETRIES = ("isotropic2", "isotropic4", "cubic", "orthotropic", "general")
EDGES = ("top", "bottom", "left", "right")
SIDES = ("left", "right", "bottom", "top")
WALL_TYPES = ("fixed", "slip")
PRECONDITIONERS = ("automatic", "jacobi", "ssor", "multigrid")

_MAX_COUNT = 2**31 - 1  # cells and particles are indexed with int32
_MAX_STEPS = 2**53  # step counts beyond this are not representable exactly
_CHUNK = 1 << 20  # candidate particles examined per vectorised batch
_WHOLE_TOL = 1e-9  # relative tolerance of "size / h is a whole number"
_EDGE_TOL = 0.51  # edge layer thickness in particle spacings
_BYTES_PER_TABLE_CELL = 128  # B-spline polynomial table, per cell of each direction
_BYTES_PER_PARTICLE = 320  # particle state, sort and phase-field arrays, setup temporaries
_NO_VALUE = object()
_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


#: Critical time step of the lumped-mass B-spline grid in units of h / c, per
#: degree, as (bodies clear of the grid sides, bodies on a side). Each is the
#: 1D limit 2 / sqrt(max eig(M_L^-1 K)) of interior functions only, or of all
#: functions including the open-knot end ones (degree 2: 1.634 and 0.862;
#: degree 3: 1.929 and 0.653; degree 1: 1 and 1), over sqrt(2) for two
#: directions and capped at 1, the CFL limit the paper uses (eq. 84).
#: tests/test_elastic.py recomputes these from the basis.
CRITICAL_FACTOR = {1: (0.707, 0.707), 2: (1.0, 0.609), 3: (1.0, 0.461)}


class SceneError(ValueError):
    """Invalid scene input, reported as one line naming the key path.

    Parameters
    ----------
    path : str
        Dotted key path of the offending entry (``""`` for the scene itself).
    reason : str
        What is wrong.
    value : object, optional
        The offending value, shown in the message when given.

    Notes
    -----
    The message reads ``"<path> = <value>: <reason>"``, or
    ``"<path>: <reason>"`` when there is no value.
    """

    def __init__(self, path: str, reason: str, value: Any = _NO_VALUE):
        self.path = path
        self.reason = reason
        self.value = value
        where = path or "scene"
        if value is _NO_VALUE:
            text = f"{where}: {reason}"
        else:
            text = f"{where} = {_fmt(value)}: {reason}"
        super().__init__(text)

    def within(self, prefix: str) -> "SceneError":
        """Return the same error with its path nested under ``prefix``."""
        if not self.path:
            path = prefix
        elif self.path.startswith("["):
            path = prefix + self.path
        else:
            path = f"{prefix}.{self.path}"
        return SceneError(path, self.reason, self.value)


@contextmanager
def _at(prefix: str) -> Iterator[None]:
    """Prefix the path of any :class:`SceneError` raised in the block."""
    try:
        yield
    except SceneError as err:
        raise err.within(prefix) from None


def _key(key: Any) -> str:
    """A table key as a path segment: bare if TOML allows it bare, else quoted."""
    text = str(key)
    return text if _BARE_KEY.fullmatch(text) else _fmt(text)


def _fmt(value: Any, limit: int = 80) -> str:
    """Format a value TOML-like on one line, shortened to ``limit`` characters."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, (list, tuple)):
        text = "[" + ", ".join(_fmt(v, limit) for v in value) + "]"
    else:
        text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


# ----------------------------------------------------------------------------
# Field validators: each checks one value and returns it normalised.
# ----------------------------------------------------------------------------


def _real(path: str, value: Any, *, gt=None, ge=None, lt=None, le=None) -> float:
    """Check a finite real number (ints accepted, bools rejected) within bounds."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise SceneError(path, "must be a number", value)
    try:
        x = float(value)
    except OverflowError:
        raise SceneError(path, "must be finite", value) from None
    if not math.isfinite(x):
        raise SceneError(path, "must be finite", value)
    bounds = [(gt, ">", x > gt if gt is not None else True),
              (ge, ">=", x >= ge if ge is not None else True),
              (lt, "<", x < lt if lt is not None else True),
              (le, "<=", x <= le if le is not None else True)]
    if not all(ok for _, _, ok in bounds):
        rule = " and ".join(f"{op} {b:g}" for b, op, _ in bounds if b is not None)
        raise SceneError(path, f"must be {rule}", value)
    return x


def _integer(path: str, value: Any, *, ge: int | None = None) -> int:
    """Check an integer (bools rejected), optionally ``>= ge``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise SceneError(path, "must be an integer", value)
    if ge is not None and value < ge:
        raise SceneError(path, f"must be >= {ge}", value)
    return int(value)


def _vec2(path: str, value: Any, **bounds: float) -> tuple[float, float]:
    """Check a 2-vector of finite numbers, each within ``bounds``."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise SceneError(path, "must be a list of 2 numbers", value)
    return (_real(f"{path}[0]", value[0], **bounds), _real(f"{path}[1]", value[1], **bounds))


def _text(path: str, value: Any, *, empty: bool = False) -> str:
    """Check a string, non-empty unless ``empty``."""
    if not isinstance(value, str):
        raise SceneError(path, "must be a string", value)
    if not empty and not value:
        raise SceneError(path, "must not be empty", value)
    return value


def _choice(path: str, value: Any, choices: tuple) -> Any:
    """Check that a value is one of ``choices`` (and of the same type)."""
    if not any(type(value) is type(c) and value == c for c in choices):
        raise SceneError(path, "must be one of " + ", ".join(_fmt(c) for c in choices), value)
    return value


def _seq(path: str, value: Any, what: str) -> tuple:
    """Check a list, tuple or array and return it as a tuple."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)):
        raise SceneError(path, f"must be a list of {what}", value)
    return tuple(value)


def _set(obj: Any, name: str, value: Any) -> None:
    """Store a normalised field value on a frozen dataclass."""
    object.__setattr__(obj, name, value)


# ----------------------------------------------------------------------------
# Scene components
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class Grid:
    """Uniform background grid of square cells.

    Parameters
    ----------
    size : (float, float)
        Extent in x and y; each must be a whole number of cells of ``h``.
    h : float
        Cell side.
    origin : (float, float)
        Lower-left corner.
    degree : int
        B-spline degree of the shape functions, 1, 2 or 3.
    """

    size: tuple[float, float]
    h: float
    origin: tuple[float, float] = (0.0, 0.0)
    degree: int = 2

    def __post_init__(self):
        _set(self, "size", _vec2("size", self.size, gt=0))
        _set(self, "h", _real("h", self.h, gt=0))
        _set(self, "origin", _vec2("origin", self.origin))
        _set(self, "degree", _choice("degree", _integer("degree", self.degree), DEGREES))
        for s in self.size:
            n = s / self.h
            if n > _MAX_COUNT:
                raise SceneError("size", f"{n:.3g} cells of h = {self.h:g} exceed the limit"
                                         f" of {_MAX_COUNT}", self.size)
            if round(n) < 1:
                raise SceneError("size", f"smaller than one cell of h = {self.h:g}", self.size)
            if abs(n - round(n)) > _WHOLE_TOL * n:
                raise SceneError("size", f"not a whole number of cells of h = {self.h:g}", self.size)
        nx, ny = self.cells
        if min(nx, ny) < self.degree:
            raise SceneError("size", f"{nx} x {ny} cells of h = {self.h:g}: degree {self.degree}"
                                     f" B-splines need at least {self.degree} cells a side", self.size)
        if nx * ny > _MAX_COUNT:
            raise SceneError("size", f"{nx} x {ny} cells exceed the limit of {_MAX_COUNT}", self.size)
        if not all(math.isfinite(o + s) for o, s in zip(self.origin, self.size)):
            raise SceneError("origin", "origin + size is not finite", self.origin)

    @property
    def cells(self) -> tuple[int, int]:
        """Number of cells ``(nx, ny)``."""
        return (round(self.size[0] / self.h), round(self.size[1] / self.h))

    def _box(self) -> str:
        """The grid rectangle as text, ``[x0, x1] x [y0, y1]``."""
        (x0, y0), (sx, sy) = self.origin, self.size
        return f"[{x0:g}, {x0 + sx:g}] x [{y0:g}, {y0 + sy:g}]"


@dataclass(frozen=True)
class Time:
    """Simulated time interval and step control.

    Parameters
    ----------
    end : float
        End time.
    dt : float or None
        Fixed time step; ``None`` uses the stable step.  Must not exceed the
        stability limit (checked by :class:`Scene`).
    cfl : float
        Courant factor ``alpha_c`` in ``(0, 1]``.
    """

    end: float
    dt: float | None = None
    cfl: float = 0.8

    def __post_init__(self):
        _set(self, "end", _real("end", self.end, gt=0))
        if self.dt is not None:
            _set(self, "dt", _real("dt", self.dt, gt=0))
        _set(self, "cfl", _real("cfl", self.cfl, gt=0, le=1))


@dataclass(frozen=True)
class Output:
    """Output cadence.

    Parameters
    ----------
    every : int
        Write the particles every ``every`` steps.
    energies_every : int
        Write an ``energies.csv`` row every ``energies_every`` steps.
    particles : bool
        Whether to write the particle time series at all.
    snapshots : sequence of float
        Times at which to draw the phase field (``phase_field.png``); the
        nearest output step is used.
    crack_threshold : float
        A particle belongs to a crack when its phase field is below this, in
        ``(0, 1)``; it sets where the crack tip is.
    crack_speed_samples : int
        ``energies.csv`` rows in the least-squares fit that smooths the
        crack-tip speed, at least 2.
    """

    every: int = 100
    energies_every: int = 10
    particles: bool = True
    snapshots: tuple[float, ...] = ()
    crack_threshold: float = 0.2
    crack_speed_samples: int = 9

    def __post_init__(self):
        _set(self, "every", _integer("every", self.every, ge=1))
        _set(self, "energies_every", _integer("energies_every", self.energies_every, ge=1))
        if not isinstance(self.particles, bool):
            raise SceneError("particles", "must be true or false", self.particles)
        times = _seq("snapshots", self.snapshots, "times")
        _set(self, "snapshots", tuple(_real(f"snapshots[{i}]", t, ge=0) for i, t in enumerate(times)))
        _set(self, "crack_threshold", _real("crack_threshold", self.crack_threshold, gt=0, lt=1))
        _set(self, "crack_speed_samples", _integer("crack_speed_samples", self.crack_speed_samples, ge=2))


@dataclass(frozen=True)
class Anisotropy:
    """Anisotropic surface energy: the tensor gamma of eq. 6 in the material frame.

    gamma acts on the curvature ``kappa = (c_11, c_22, c_12)`` (the fourth-order
    term of eq. 4 is ``l0^3 kappa^T gamma kappa``); the body's ``orientation``
    turns the material axes, and ``gamma_1111`` is the coefficient of a crack
    running along it. :mod:`pfmpm.anisotropy` gives the resulting ``G_c(theta)``.

    Parameters
    ----------
    symmetry : str
        ``"isotropic2"``: gamma = 0, the second-order functional (no keys).
        ``"isotropic4"``: ``g1111`` (default 1) with g2222 = g1111, g1122 = 0,
        g1212 = 2 g1111, so that ``G_c = G-bar_c sqrt(1 + sqrt(g1111))`` in
        every direction. ``"cubic"``: ``g1111`` (= g2222), ``g1212``,
        optional ``g1122``. ``"orthotropic"``: ``g1111``, ``g2222``,
        ``g1212``, optional ``g1122``. ``"general"``: ``gamma``, the full
        symmetric 3 x 3 Voigt matrix.
    g1111, g2222, g1122, g1212 : float
        Components of gamma, >= 0 (g1122 may be negative as long as gamma
        stays positive semi-definite).
    gamma : 3 x 3 nested sequence
        The whole matrix, for ``symmetry = "general"``.
    """

    symmetry: str
    g1111: float | None = None
    g2222: float | None = None
    g1122: float | None = None
    g1212: float | None = None
    gamma: tuple[tuple[float, ...], ...] | None = None

    _KEYS: ClassVar[dict[str, tuple[tuple[str, ...], tuple[str, ...]]]] = {
        # symmetry: (required keys, optional keys)
        "isotropic2": ((), ()),
        "isotropic4": ((), ("g1111",)),
        "cubic": (("g1111", "g1212"), ("g1122",)),
        "orthotropic": (("g1111", "g2222", "g1212"), ("g1122",)),
        "general": (("gamma",), ()),
    }

    def __post_init__(self):
        _set(self, "symmetry", _choice("symmetry", self.symmetry, SYMMETRIES))
        required, optional = self._KEYS[self.symmetry]
        for key in ("g1111", "g2222", "g1122", "g1212", "gamma"):
            value = getattr(self, key)
            if value is None and key in required:
                raise SceneError(key, f"required for symmetry {self.symmetry!r}")
            if value is not None and key not in required + optional:
                raise SceneError(key, f"not used by symmetry {self.symmetry!r} (it takes "
                                 + (", ".join(required + optional) or "no components") + ")")
        for key in ("g1111", "g2222", "g1212"):
            if getattr(self, key) is not None:
                _set(self, key, _real(key, getattr(self, key), ge=0))
        if self.g1122 is not None:
            _set(self, "g1122", _real("g1122", self.g1122))
        if self.gamma is not None:
            rows = _seq("gamma", self.gamma, "3 rows of 3 numbers")
            if len(rows) != 3:
                raise SceneError("gamma", "must have 3 rows of 3 numbers", self.gamma)
            matrix = []
            for i, row in enumerate(rows):
                row = _seq(f"gamma[{i}]", row, "3 numbers")
                if len(row) != 3:
                    raise SceneError(f"gamma[{i}]", "must have 3 numbers", row)
                matrix.append(tuple(_real(f"gamma[{i}][{j}]", v) for j, v in enumerate(row)))
            _set(self, "gamma", tuple(matrix))
        try:
            check_gamma(self.matrix())
        except ValueError as e:
            raise SceneError("gamma" if self.symmetry == "general" else "symmetry",
                             f"gamma {e}", self.matrix().tolist()) from None

    def matrix(self) -> np.ndarray:
        """gamma as a 3 x 3 array (material frame)."""
        if self.symmetry == "general":
            return np.array(self.gamma, dtype=float)
        if self.symmetry == "isotropic2":
            return np.zeros((3, 3))
        if self.symmetry == "isotropic4":
            g = 1.0 if self.g1111 is None else self.g1111
            return np.diag([g, g, 2.0 * g])
        g2222 = self.g1111 if self.symmetry == "cubic" else self.g2222
        g1122 = self.g1122 or 0.0
        return np.array([[self.g1111, g1122, 0.0], [g1122, g2222, 0.0], [0.0, 0.0, self.g1212]])

    @property
    def fourth_order(self) -> bool:
        """Whether gamma != 0."""
        return bool(np.any(self.matrix() != 0.0))


@dataclass(frozen=True)
class Fracture:
    """Phase-field fracture parameters (AT2, eqs. 4, 14-15).

    Parameters
    ----------
    Gc : float
        Critical energy release rate, > 0; with a fourth-order ``anisotropy``
        it is the reference value G-bar_c of eq. 8.
    l0 : float
        Length scale, > 0; the scene requires at least the grid spacing.
    k_f : float
        Residual stiffness in ``[0, 1)``: ``g(c) = (1 - k_f) c^2 + k_f``.
    split : str
        Which energy cracking degrades: ``"spectral"`` (Miehe, eq. 14),
        ``"volumetric_deviatoric"`` (Amor) or ``"none"``.
    anisotropy : Anisotropy or None
        The tensor gamma of the fourth-order functional (eqs. 4-6); ``None``:
        the second-order isotropic functional.
    """

    Gc: float
    l0: float
    k_f: float = 0.0
    split: str = "spectral"
    anisotropy: Anisotropy | None = None

    def __post_init__(self):
        _set(self, "Gc", _real("Gc", self.Gc, gt=0))
        _set(self, "l0", _real("l0", self.l0, gt=0))
        _set(self, "k_f", _real("k_f", self.k_f, ge=0, lt=1))
        _set(self, "split", _choice("split", self.split, SPLITS))
        if self.anisotropy is not None and not isinstance(self.anisotropy, Anisotropy):
            raise SceneError("anisotropy", "must be an anisotropy table", self.anisotropy)

    def gamma(self) -> np.ndarray:
        """gamma of eq. 6 in the material frame (zero without anisotropy)."""
        return np.zeros((3, 3)) if self.anisotropy is None else self.anisotropy.matrix()


@dataclass(frozen=True)
class Material:
    """Material parameters.

    Parameters
    ----------
    name : str
        Unique name, referenced by bodies.
    E : float
        Young's modulus, > 0.
    nu : float
        Poisson's ratio, in ``(-1, 0.5)``.
    density : float
        Mass density, > 0.
    model : str
        Constitutive model; only ``"linear_elastic"`` for now.
    fracture : Fracture or None
        Phase-field parameters; ``None``: the material cannot crack, and its
        particles take no part in the phase-field solve.
    """

    name: str
    E: float
    nu: float
    density: float
    model: str = "linear_elastic"
    fracture: Fracture | None = None

    def __post_init__(self):
        _set(self, "name", _text("name", self.name))
        _set(self, "E", _real("E", self.E, gt=0))
        _set(self, "nu", _real("nu", self.nu, gt=-1, lt=0.5))
        _set(self, "density", _real("density", self.density, gt=0))
        _set(self, "model", _choice("model", self.model, MODELS))
        if self.fracture is not None and not isinstance(self.fracture, Fracture):
            raise SceneError("fracture", "must be a Fracture table", self.fracture)


class Shape:
    """Base of the 2D shapes that bodies and holes are made of.

    Subclasses set ``kind`` (the TOML ``type``) and implement
    :meth:`contains` and :meth:`bounds`.
    """

    kind: ClassVar[str]

    def contains(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Return a boolean array, True where the point ``(x, y)`` is inside."""
        raise NotImplementedError

    def bounds(self) -> tuple[float, float, float, float]:
        """Return the bounding box ``(xmin, ymin, xmax, ymax)``."""
        raise NotImplementedError


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
        _set(self, "min", _vec2("min", self.min))
        _set(self, "max", _vec2("max", self.max))
        if not (self.min[0] < self.max[0] and self.min[1] < self.max[1]):
            raise SceneError("max", f"must exceed min = {_fmt(self.min)} componentwise", self.max)

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
        _set(self, "center", _vec2("center", self.center))
        _set(self, "radius", _real("radius", self.radius, gt=0))

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
        _set(self, "center", _vec2("center", self.center))
        _set(self, "inner_radius", _real("inner_radius", self.inner_radius, ge=0))
        _set(self, "outer_radius", _real("outer_radius", self.outer_radius, gt=self.inner_radius))

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
        points = _seq("vertices", self.vertices, "[x, y] points")
        if len(points) < 3:
            raise SceneError("vertices", "must have at least 3 points", self.vertices)
        _set(self, "vertices", tuple(_vec2(f"vertices[{i}]", p) for i, p in enumerate(points)))
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


SHAPES: dict[str, type[Shape]] = {cls.kind: cls for cls in (Rectangle, Disk, Ring, Polygon)}


@dataclass(frozen=True)
class Body:
    """A body: a shape minus holes, filled with particles of one material.

    Parameters
    ----------
    name : str
        Unique name, referenced by loads.
    material : str
        Name of the body's material.
    shape : Shape
        Region filled with particles.
    holes : sequence of Shape
        Regions removed from ``shape`` (notches, holes).
    particles_per_cell : int
        ``n``: particles are placed on an ``n x n`` lattice of sub-cell
        centres in every grid cell.
    velocity : (float, float)
        Initial velocity.
    velocity_gradient : ((float, float), (float, float))
        Initial velocity gradient ``G``: a particle at ``x`` starts with
        ``velocity + G x`` (``G[i][j] = d v_i / d x_j``), e.g. a uniform
        stretching rate.
    orientation : float
        Principal material direction phi (the fibres) in degrees, clockwise
        from x (the paper's convention): turns the anisotropy tensor of the
        body's material, so that a crack along phi has ``gamma_n = gamma_1111``.
        Per-particle orientations can be set on ``Simulation.particles.phi``
        (radians) before the first step.
    """

    name: str
    material: str
    shape: Shape
    holes: tuple[Shape, ...] = ()
    particles_per_cell: int = 2
    velocity: tuple[float, float] = (0.0, 0.0)
    velocity_gradient: tuple[tuple[float, float], tuple[float, float]] = ((0.0, 0.0), (0.0, 0.0))
    orientation: float = 0.0

    def __post_init__(self):
        _set(self, "name", _text("name", self.name))
        _set(self, "material", _text("material", self.material))
        if not isinstance(self.shape, Shape):
            raise SceneError("shape", "must be a shape (" + ", ".join(SHAPES) + ")", self.shape)
        holes = _seq("holes", self.holes, "shapes")
        for i, hole in enumerate(holes):
            if not isinstance(hole, Shape):
                raise SceneError(f"holes[{i}]", "must be a shape (" + ", ".join(SHAPES) + ")", hole)
        _set(self, "holes", holes)
        _set(self, "particles_per_cell", _integer("particles_per_cell", self.particles_per_cell, ge=1))
        _set(self, "velocity", _vec2("velocity", self.velocity))
        rows = _seq("velocity_gradient", self.velocity_gradient, "2 rows of 2 numbers")
        if len(rows) != 2:
            raise SceneError("velocity_gradient", "must have 2 rows of 2 numbers", self.velocity_gradient)
        _set(self, "velocity_gradient",
             tuple(_vec2(f"velocity_gradient[{i}]", row) for i, row in enumerate(rows)))
        _set(self, "orientation", _real("orientation", self.orientation))

    def contains(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Return True where ``(x, y)`` lies in the shape and in no hole."""
        inside = self.shape.contains(x, y)
        for hole in self.holes:
            inside &= ~hole.contains(x, y)
        return inside

    def max_speed(self) -> float:
        """Largest initial particle speed: the velocity plus the gradient over the bounding box."""
        x0, y0, x1, y1 = self.shape.bounds()
        (gxx, gxy), (gyx, gyy) = self.velocity_gradient
        vx, vy = self.velocity
        speeds = [math.hypot(vx + gxx * x + gxy * y, vy + gyx * x + gyy * y)
                  for x in (x0, x1) for y in (y0, y1)]
        return max(speeds) if all(map(math.isfinite, speeds)) else math.inf


@dataclass(frozen=True)
class Traction:
    """Traction on the outermost particle layer of a body on one side.

    Parameters
    ----------
    body : str
        Name of the loaded body.
    edge : str
        ``"top"``, ``"bottom"``, ``"left"`` or ``"right"``.
    traction : (float, float)
        Traction vector (force per unit boundary area, stress units).
    """

    kind: ClassVar[str] = "traction"
    body: str
    edge: str
    traction: tuple[float, float]

    def __post_init__(self):
        _set(self, "body", _text("body", self.body))
        _set(self, "edge", _choice("edge", self.edge, EDGES))
        _set(self, "traction", _vec2("traction", self.traction))


@dataclass(frozen=True)
class BodyForce:
    """Uniform acceleration (gravity-like) on the particles of a body.

    Parameters
    ----------
    acceleration : (float, float)
        Acceleration vector.
    body : str or None
        Name of the loaded body; ``None`` loads all bodies.
    """

    kind: ClassVar[str] = "body_force"
    acceleration: tuple[float, float]
    body: str | None = None

    def __post_init__(self):
        _set(self, "acceleration", _vec2("acceleration", self.acceleration))
        if self.body is not None:
            _set(self, "body", _text("body", self.body))


LOADS: dict[str, type] = {cls.kind: cls for cls in (Traction, BodyForce)}


@dataclass(frozen=True)
class Wall:
    """Velocity boundary condition on one side of the grid.

    Parameters
    ----------
    side : str
        ``"left"``, ``"right"``, ``"bottom"`` or ``"top"``.
    type : str
        ``"fixed"`` (both velocity components zero) or ``"slip"`` (normal
        component zero).
    """

    side: str
    type: str

    def __post_init__(self):
        _set(self, "side", _choice("side", self.side, SIDES))
        _set(self, "type", _choice("type", self.type, WALL_TYPES))


@dataclass(frozen=True)
class Crack:
    """An initial crack, imposed as an initial history field (Borden et al. 2012).

    Particles within ``half_width`` of the polyline get
    ``H0 = B G_c / (4 l0) (1 - d / half_width)`` at distance ``d``; with the
    default ``half_width = l0 / 2`` this is Borden's formula.

    Parameters
    ----------
    points : sequence of (float, float)
        Polyline vertices, at least two.
    body : str or None
        Body whose particles get the history; ``None``: every body that can crack.
    B : float
        Strength of the imposed history, > 0 (large: ``c`` near 0 on the line).
    half_width : float or None
        Half width of the band, > 0; ``None`` means ``l0 / 2``.
    """

    points: tuple[tuple[float, float], ...]
    body: str | None = None
    B: float = 1e3
    half_width: float | None = None

    def __post_init__(self):
        points = _seq("points", self.points, "points")
        if len(points) < 2:
            raise SceneError("points", "needs at least two points", self.points)
        _set(self, "points", tuple(_vec2(f"points[{i}]", p) for i, p in enumerate(points)))
        for i in range(1, len(self.points)):
            (ax, ay), (bx, by) = self.points[i - 1], self.points[i]
            if not 0 < math.hypot(bx - ax, by - ay) < math.inf:
                raise SceneError(f"points[{i}]", f"segment from points[{i - 1}] = {_fmt(self.points[i - 1])}"
                                                 " must have a positive finite length", self.points[i])
        if self.body is not None:
            _set(self, "body", _text("body", self.body))
        _set(self, "B", _real("B", self.B, gt=0))
        if self.half_width is not None:
            _set(self, "half_width", _real("half_width", self.half_width, gt=0))


@dataclass(frozen=True)
class PhaseField:
    """Phase-field solver settings.

    Parameters
    ----------
    tol : float
        Tolerance tol_c of the phase-field solve, relative to ``||F||``
        (eq. 52), in ``(0, 1)``.
    max_iterations : int
        Conjugate-gradient iterations allowed per step; the run stops with
        an error when they do not reach ``tol``.
    preconditioner : str
        Of the conjugate gradients: ``"jacobi"``, ``"ssor"`` (symmetric
        Gauss-Seidel), ``"multigrid"`` (a geometric V-cycle on the B-spline
        grid), or ``"automatic"``: jacobi for the second-order model, ssor for
        the fourth-order one.
    """

    tol: float = 1e-6
    max_iterations: int = 1000
    preconditioner: str = "automatic"

    def __post_init__(self):
        _set(self, "tol", _real("tol", self.tol, gt=0, lt=1))
        _set(self, "max_iterations", _integer("max_iterations", self.max_iterations, ge=1))
        if self.max_iterations > _MAX_COUNT:
            raise SceneError("max_iterations", f"must be <= {_MAX_COUNT}", self.max_iterations)
        _set(self, "preconditioner", _choice("preconditioner", self.preconditioner, PRECONDITIONERS))


@dataclass(frozen=True)
class ContactPair:
    """The friction coefficient between two bodies, overriding ``contact.friction``.

    Parameters
    ----------
    bodies : (str, str)
        Names of two different bodies.
    friction : float
        Coulomb coefficient mu_f, >= 0.
    """

    bodies: tuple[str, str]
    friction: float

    def __post_init__(self):
        bodies = _seq("bodies", self.bodies, "2 body names")
        if len(bodies) != 2:
            raise SceneError("bodies", "must be a list of 2 body names", self.bodies)
        _set(self, "bodies", (_text("bodies[0]", bodies[0]), _text("bodies[1]", bodies[1])))
        if bodies[0] == bodies[1]:
            raise SceneError("bodies", "must name two different bodies", self.bodies)
        _set(self, "friction", _real("friction", self.friction, ge=0))


@dataclass(frozen=True)
class Contact:
    """Multi-body frictional contact: every body its own discrete field.

    With a ``[contact]`` table each body has its own velocity field (and its
    own phase field) on the shared grid, and bodies interact only through
    Coulomb frictional contact at the grid nodes they share (Kakouris &
    Triantafyllou 2019, eqs. 63-77). Without it, all bodies move as one
    continuum.

    Parameters
    ----------
    friction : float
        Coulomb coefficient mu_f between any two bodies, >= 0.
    pairs : sequence of ContactPair
        Per-pair coefficients replacing ``friction``.
    """

    friction: float = 0.0
    pairs: tuple[ContactPair, ...] = ()

    def __post_init__(self):
        _set(self, "friction", _real("friction", self.friction, ge=0))
        pairs = _seq("pairs", self.pairs, "ContactPair")
        for i, pair in enumerate(pairs):
            if not isinstance(pair, ContactPair):
                raise SceneError(f"pairs[{i}]", "must be a ContactPair", pair)
        _set(self, "pairs", pairs)

    def friction_matrix(self, bodies: tuple[str, ...]) -> np.ndarray:
        """Coefficients between every two bodies, shape (n, n), in the order of ``bodies``."""
        index = {name: i for i, name in enumerate(bodies)}
        mu = np.full((len(bodies), len(bodies)), self.friction)
        for pair in self.pairs:
            a, b = index[pair.bodies[0]], index[pair.bodies[1]]
            mu[a, b] = mu[b, a] = pair.friction
        return mu


def rayleigh_speed(E: float, nu: float, rho: float) -> float:
    """Rayleigh wave speed from Viktorov's approximation ``c_s (0.862 + 1.14 nu) / (1 + nu)``."""
    return math.sqrt(E / (2 * (1 + nu) * rho)) * (0.862 + 1.14 * nu) / (1 + nu)


def wave_speed(E: float, nu: float, rho: float, plane: str) -> float:
    """P-wave speed of a linear elastic material in 2D.

    Parameters
    ----------
    E, nu, rho : float
        Young's modulus, Poisson's ratio and density.
    plane : str
        ``"strain"``: ``sqrt(E (1 - nu) / (rho (1 + nu) (1 - 2 nu)))``;
        ``"stress"``: ``sqrt(E / (rho (1 - nu^2)))``.

    Returns
    -------
    float
        The wave speed.
    """
    if plane == "strain":
        modulus, inertia = E * (1 - nu), rho * (1 + nu) * (1 - 2 * nu)
    elif plane == "stress":
        modulus, inertia = E, rho * (1 - nu * nu)
    else:
        raise SceneError("plane", "must be one of " + ", ".join(map(repr, PLANES)), plane)
    return math.sqrt(modulus / inertia) if inertia > 0 else math.inf


# ----------------------------------------------------------------------------
# The scene
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class Scene:
    """A complete, validated scene.

    Parameters
    ----------
    grid : Grid
    time : Time
    materials : sequence of Material
        At least one; names unique.
    bodies : sequence of Body
        At least one; names unique; each names a material, holds at least
        one particle and has none outside the grid.
    name, description : str
    plane : str
        ``"strain"`` or ``"stress"``.
    thickness : float
        Out-of-plane thickness, > 0.
    loads : sequence of Traction or BodyForce
    walls : sequence of Wall
        At most one per grid side.
    output : Output
    cracks : sequence of Crack
        Initial cracks, on bodies whose material can crack.
    phase_field : PhaseField
        Phase-field solver settings (used when some material can crack).
    contact : Contact or None
        Frictional contact between the bodies, each its own discrete field;
        ``None``: the bodies form one continuum.

    Raises
    ------
    SceneError
        On the first invalid entry.
    """

    grid: Grid
    time: Time
    materials: tuple[Material, ...]
    bodies: tuple[Body, ...]
    name: str = "scene"
    description: str = ""
    plane: str = "strain"
    thickness: float = 1.0
    loads: tuple[Traction | BodyForce, ...] = ()
    walls: tuple[Wall, ...] = ()
    output: Output = field(default_factory=Output)
    cracks: tuple[Crack, ...] = ()
    phase_field: PhaseField = field(default_factory=PhaseField)
    contact: Contact | None = None

    def __post_init__(self):
        self.validate()

    # -- validation ---------------------------------------------------------

    def validate(self) -> None:
        """Check the whole scene, normalising sequences to tuples.

        Raises
        ------
        SceneError
            On the first invalid entry, naming its key path.
        """
        _set(self, "name", _text("name", self.name))
        _set(self, "description", _text("description", self.description, empty=True))
        _set(self, "plane", _choice("plane", self.plane, PLANES))
        _set(self, "thickness", _real("thickness", self.thickness, gt=0))
        for key, cls in (("grid", Grid), ("time", Time), ("output", Output),
                         ("phase_field", PhaseField)):
            if not isinstance(getattr(self, key), cls):
                raise SceneError(key, f"must be a {cls.__name__}", getattr(self, key))
        _set(self, "materials", self._items("materials", (Material,), required=True))
        _set(self, "bodies", self._items("bodies", (Body,), required=True))
        _set(self, "loads", self._items("loads", (Traction, BodyForce)))
        _set(self, "walls", self._items("walls", (Wall,)))
        _set(self, "cracks", self._items("cracks", (Crack,)))
        materials = self._unique("materials", "name", "duplicate name")
        bodies = self._unique("bodies", "name", "duplicate name")
        self._unique("walls", "side", "duplicate wall on this side")
        for i, body in enumerate(self.bodies):
            _reference(f"bodies[{i}].material", body.material, materials, "material")
        for i, load in enumerate(self.loads):
            if load.body is not None:
                _reference(f"loads[{i}].body", load.body, bodies, "body")
        for i, body in enumerate(self.bodies):
            with _at(f"bodies[{i}]"):
                self._check_particles(body)
        self._check_memory()
        self._check_fracture(bodies)
        self._check_contact(bodies)
        self._check_time()

    def _items(self, key: str, classes: tuple[type, ...], required: bool = False) -> tuple:
        """Check that field ``key`` is a sequence of ``classes`` instances."""
        items = _seq(key, getattr(self, key), " or ".join(c.__name__ for c in classes))
        if required and not items:
            raise SceneError(key, "at least one entry is required")
        for i, item in enumerate(items):
            if not isinstance(item, classes):
                raise SceneError(f"{key}[{i}]", "must be a " + " or ".join(c.__name__ for c in classes), item)
        return items

    def _unique(self, key: str, attr: str, reason: str) -> dict[str, int]:
        """Check that ``attr`` is unique over field ``key``; map value -> index."""
        seen: dict[str, int] = {}
        for i, item in enumerate(getattr(self, key)):
            value = getattr(item, attr)
            if value in seen:
                raise SceneError(f"{key}[{i}].{attr}", f"{reason} (also {key}[{seen[value]}])", value)
            seen[value] = i
        return seen

    def _cell_range(self, body: Body, margin: int = 0) -> tuple[tuple[int, int], tuple[int, int]]:
        """Cell index ranges of the body's bounding box, clipped to the grid plus ``margin`` cells."""
        xmin, ymin, xmax, ymax = body.shape.bounds()
        (ox, oy), h, (nx, ny) = self.grid.origin, self.grid.h, self.grid.cells
        lo_x, hi_x = np.clip([(xmin - ox) / h, (xmax - ox) / h], -margin, nx + margin)
        lo_y, hi_y = np.clip([(ymin - oy) / h, (ymax - oy) / h], -margin, ny + margin)
        return ((math.floor(lo_x), math.ceil(hi_x)), (math.floor(lo_y), math.ceil(hi_y)))

    def _check_particles(self, body: Body) -> None:
        """Check that the body has particles, all inside the grid, and not too many."""
        grid = self.grid
        (ox, oy), h, (nx, ny) = grid.origin, grid.h, grid.cells
        xmin, ymin, xmax, ymax = body.shape.bounds()
        if xmin < ox - h or ymin < oy - h or xmax > ox + (nx + 1) * h or ymax > oy + (ny + 1) * h:
            raise SceneError("shape", f"bounds {_fmt(body.shape.bounds())} extend more than"
                                      f" one cell beyond the grid {grid._box()}")
        (i0, i1), (j0, j1) = self._cell_range(body, margin=1)
        n = body.particles_per_cell
        candidates = (i1 - i0) * (j1 - j0) * n * n
        if candidates > _MAX_COUNT:
            raise SceneError("", f"would need {candidates:.3g} candidate particles"
                                 f" (limit {_MAX_COUNT}); coarsen the grid or particles_per_cell")
        inner_i, inner_j = (max(i0, 0), min(i1, nx)), (max(j0, 0), min(j1, ny))
        strips = [((i0, i1), (j0, min(j1, 0))), ((i0, i1), (max(j0, ny), j1)),
                  ((i0, min(i1, 0)), inner_j), ((max(i0, nx), i1), inner_j)]
        outside = sum(len(p) for cells in strips for p in _lattice(body, grid, *cells))
        if outside:
            raise SceneError("", f"{outside} particles lie outside the grid {grid._box()}")
        if not any(len(p) for p in _lattice(body, grid, inner_i, inner_j)):
            raise SceneError("", f"has no particles (no sub-cell centre of the {n} x {n}"
                                 f" lattice per cell of h = {h:g} lies in its shape minus holes)")

    def _check_memory(self) -> None:
        """Check that the core's storage for the grid and particles fits in this machine's memory.

        A rough upper estimate (see the ``_BYTES_*`` constants), so that a
        scene too large to run fails here, naming the key to change, rather
        than in an allocation inside the C++ core.
        """
        (nx, ny), p = self.grid.cells, self.grid.degree
        nodes = (nx + 2 * p) * (ny + 2 * p)  # the phase field's padded layout
        stencil = ((2 * p + 1) ** 2 + 1) // 2
        cracks = any(m.fracture is not None for m in self.materials)
        grid = (_BYTES_PER_TABLE_CELL * (nx + ny) + (8 + 8 * (os.cpu_count() or 1)) * nx * ny
                + nodes * (4 + (24 + 8 * stencil if cracks else 0)))
        counts = []
        for body in self.bodies:
            (i0, i1), (j0, j1) = self._cell_range(body)
            counts.append((i1 - i0) * (j1 - j0) * body.particles_per_cell ** 2)
        need = grid + _BYTES_PER_PARTICLE * sum(counts)
        have = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        if need > have:
            i = int(np.argmax(counts))
            key = "grid.size" if grid >= _BYTES_PER_PARTICLE * counts[i] else f"bodies[{i}].particles_per_cell"
            raise SceneError(key, f"{nx} x {ny} cells and up to {sum(counts):.3g} particles need about"
                                  f" {need / 1e9:.3g} GB, more than this machine's {have / 1e9:.3g} GB")

    def _check_fracture(self, bodies: Mapping[str, int]) -> None:
        """Check that l0 is resolved by the grid and cracks lie on crackable bodies."""
        h = self.grid.h
        for i, material in enumerate(self.materials):
            if material.fracture is not None and material.fracture.l0 < h:
                raise SceneError(f"materials[{i}].fracture.l0",
                                 f"smaller than the grid spacing h = {h:g}, which cannot resolve"
                                 " the phase-field profile (use l0 >= h; the paper uses l0 = 2 h)",
                                 material.fracture.l0)
            anisotropy = material.fracture.anisotropy if material.fracture else None
            if anisotropy is not None and anisotropy.fourth_order and self.grid.degree < 2:
                raise SceneError(f"materials[{i}].fracture.anisotropy",
                                 "the fourth-order term needs second derivatives of C1 splines:"
                                 f" grid.degree must be 2 or 3, not {self.grid.degree}",
                                 anisotropy.symmetry)
        crackable = [b.name for b in self.bodies if self.fracture_of(b) is not None]
        (x0, y0), (sx, sy) = self.grid.origin, self.grid.size
        reach = max(sx, sy)
        for i, crack in enumerate(self.cracks):
            for j, (x, y) in enumerate(crack.points):
                if not (x0 - reach <= x <= x0 + sx + reach and y0 - reach <= y <= y0 + sy + reach):
                    raise SceneError(f"cracks[{i}].points[{j}]", "lies farther from the grid"
                                     f" {self.grid._box()} than its longer side", (x, y))
            if crack.body is not None:
                _reference(f"cracks[{i}].body", crack.body, bodies, "body")
                if crack.body not in crackable:
                    raise SceneError(f"cracks[{i}].body", "its material has no fracture table",
                                     crack.body)
            elif not crackable:
                raise SceneError(f"cracks[{i}]", "no body's material has a fracture table")

    def _check_contact(self, bodies: Mapping[str, int]) -> None:
        """Check the contact table: known bodies, quadratic or cubic grid, no overlap at t = 0."""
        contact = self.contact
        if contact is None:
            return
        if not isinstance(contact, Contact):
            raise SceneError("contact", "must be a Contact", contact)
        if self.grid.degree < 2:
            raise SceneError("grid.degree", "contact needs quadratic or cubic B-splines"
                                            " (a one-field node of tiny mass on a linear cell"
                                            " is unstable)", self.grid.degree)
        seen: dict[frozenset, int] = {}
        for i, pair in enumerate(contact.pairs):
            for k, name in enumerate(pair.bodies):
                _reference(f"contact.pairs[{i}].bodies[{k}]", name, bodies, "body")
            key = frozenset(pair.bodies)
            if key in seen:
                raise SceneError(f"contact.pairs[{i}].bodies",
                                 f"duplicate pair (also contact.pairs[{seen[key]}])", pair.bodies)
            seen[key] = i
        # Bodies in contact must start apart: no particle of one inside another.
        lattices = [np.concatenate(list(_lattice(b, self.grid, *self._cell_range(b))))
                    for b in self.bodies]
        for a, body in enumerate(self.bodies):
            for b, other in enumerate(self.bodies):
                if a == b:
                    continue
                x = lattices[b]
                inside = int(np.count_nonzero(body.contains(x[:, 0], x[:, 1])))
                if inside:
                    raise SceneError(f"bodies[{b}]", f"{inside} of its particles lie inside"
                                     f" bodies[{a}] ({body.name!r}) at t = 0; bodies in contact"
                                     " must not overlap", other.name)

    def material_of(self, body: Body) -> Material:
        """A body's material."""
        return next(m for m in self.materials if m.name == body.material)

    def fracture_of(self, body: Body) -> Fracture | None:
        """The fracture parameters of a body's material, or ``None``."""
        return self.material_of(body).fracture

    def crack_rayleigh_speed(self) -> float:
        """Rayleigh speed (:func:`rayleigh_speed`) of the first crackable body's material."""
        body = next(b for b in self.bodies if self.fracture_of(b) is not None)
        m = self.material_of(body)
        return rayleigh_speed(m.E, m.nu, m.density)

    def _check_time(self) -> None:
        """Check the stability limit, a fixed dt against it, and the step count."""
        for i, material in enumerate(self.materials):
            c = wave_speed(material.E, material.nu, material.density, self.plane)
            if not 0 < c < math.inf:
                raise SceneError(f"materials[{i}]", f"P-wave speed {c:g} is not a positive finite number")
        for i, body in enumerate(self.bodies):
            if not math.isfinite(math.hypot(*body.velocity)):
                raise SceneError(f"bodies[{i}].velocity", "speed is not finite", body.velocity)
            if not math.isfinite(body.max_speed()):
                raise SceneError(f"bodies[{i}].velocity_gradient", "gives a speed that is not finite"
                                 " over the body", body.velocity_gradient)
        limit = self.stable_dt()
        if not 0 < limit < math.inf:
            raise SceneError("time", f"the stability limit {limit:g} is not a positive finite step")
        dt = self.time.dt
        if dt is not None and dt > limit:
            raise SceneError("time.dt", f"exceeds the stability limit {limit:.4g}"
                                        " (cfl * kappa * h / (max wave speed + max body speed))", dt)
        steps = self.time.end / self.dt()
        if not steps <= _MAX_STEPS:
            raise SceneError("time.end", f"needs {steps:.3g} steps of dt = {self.dt():.4g}"
                                         f" (limit {_MAX_STEPS})", self.time.end)

    # -- derived quantities -------------------------------------------------

    def stable_dt(self) -> float:
        """Stability limit ``cfl * kappa * h / (c_max + v_max)`` (eqs. 83-84).

        ``c_max`` is the largest P-wave speed (see :func:`wave_speed`) over the
        materials used by bodies and ``v_max`` the largest initial particle speed.
        ``kappa`` (see :data:`CRITICAL_FACTOR`) is 1 for quadratic and cubic
        B-splines with the bodies clear of the grid's end functions, as in the
        paper; it is smaller for degree 1, and for bodies that start within
        ``degree`` cells of a grid side, where the open knot vector's end
        functions carry little lumped mass.
        """
        used = {body.material for body in self.bodies}
        c_max = max(wave_speed(m.E, m.nu, m.density, self.plane)
                    for m in self.materials if m.name in used)
        v_max = max(body.max_speed() for body in self.bodies)
        return self.time.cfl * self.critical_length() / (c_max + v_max)

    def critical_length(self) -> float:
        """``kappa * h`` of :meth:`stable_dt`: a step is stable while ``dt (c + |v|)`` stays below it."""
        interior, boundary = CRITICAL_FACTOR[self.grid.degree]
        kappa = boundary if any(self._near_side(b) for b in self.bodies) else interior
        return kappa * self.grid.h

    def _near_side(self, body: Body) -> bool:
        """Whether the body's bounding box reaches the end functions of the grid."""
        (i0, i1), (j0, j1) = self._cell_range(body)
        p, (nx, ny) = self.grid.degree, self.grid.cells
        return i0 < p or j0 < p or i1 > nx - p or j1 > ny - p

    def dt(self) -> float:
        """Time step: the fixed ``time.dt`` if given, else :meth:`stable_dt`."""
        return self.time.dt if self.time.dt is not None else self.stable_dt()

    def steps(self) -> int:
        """Number of steps of :meth:`dt` to reach ``time.end`` (round-off tolerant)."""
        n = self.time.end / self.dt()
        return max(1, math.ceil(n - _WHOLE_TOL * n))

    def particles(self) -> dict[str, np.ndarray]:
        """Generate the particles of all bodies.

        Particles sit at the centres of an ``n x n`` sub-cell lattice in each
        grid cell, kept if inside the body's shape and outside its holes.
        Bodies come in order; within a body particles are sorted by cell
        (row-major, y outer) then by sub-position.

        Returns
        -------
        dict of str to ndarray
            ``x`` (N, 2) positions, ``v`` (N, 2) velocities, ``mass`` (N,),
            ``volume`` (N,) ``= (h/n)^2 * thickness``, ``body`` (N,) int32
            body index, ``material`` (N,) int32 material index, ``phi`` (N,)
            material orientation in radians (clockwise from x) and ``fext``
            (N, 2) constant external forces: ``traction * (h/n) * thickness``
            on the edge layer of each traction load plus
            ``mass * acceleration`` of each body force.  The edge layer is
            the particles of the body within ``0.51 h/n`` of its extreme
            particle coordinate on that side.
        """
        h = self.grid.h
        materials = {m.name: i for i, m in enumerate(self.materials)}
        xs, vs, masses, volumes, body_ids, material_ids, slices = [], [], [], [], [], [], {}
        phis = []
        start = 0
        for b, body in enumerate(self.bodies):
            x = np.concatenate(list(_lattice(body, self.grid, *self._cell_range(body))))
            count = len(x)
            m = materials[body.material]
            spacing = h / body.particles_per_cell
            volume = spacing * spacing * self.thickness
            xs.append(x)
            vs.append(np.asarray(body.velocity) + x @ np.asarray(body.velocity_gradient).T)
            volumes.append(np.full(count, volume))
            masses.append(np.full(count, self.materials[m].density * volume))
            body_ids.append(np.full(count, b, dtype=np.int32))
            material_ids.append(np.full(count, m, dtype=np.int32))
            phis.append(np.full(count, math.radians(body.orientation)))
            slices[body.name] = (slice(start, start + count), spacing)
            start += count
        out = {
            "x": np.concatenate(xs),
            "v": np.concatenate(vs),
            "mass": np.concatenate(masses),
            "volume": np.concatenate(volumes),
            "body": np.concatenate(body_ids),
            "material": np.concatenate(material_ids),
            "phi": np.concatenate(phis),
            "fext": np.zeros((start, 2)),
        }
        for load in self.loads:
            if isinstance(load, Traction):
                part, spacing = slices[load.body]
                coord = out["x"][part, 0 if load.edge in ("left", "right") else 1]
                tol = _EDGE_TOL * spacing
                if load.edge in ("right", "top"):
                    layer = coord >= coord.max() - tol
                else:
                    layer = coord <= coord.min() + tol
                out["fext"][part][layer] += np.multiply(load.traction, spacing * self.thickness)
            else:
                part = slice(None) if load.body is None else slices[load.body][0]
                out["fext"][part] += out["mass"][part, None] * np.asarray(load.acceleration)
        return out

    def summary(self) -> dict[str, Any]:
        """Small dict for logging: name, plane, cells, h, degree, particles, dt, steps."""
        count = sum(len(p) for body in self.bodies
                    for p in _lattice(body, self.grid, *self._cell_range(body)))
        return {
            "name": self.name,
            "plane": self.plane,
            "cells": self.grid.cells,
            "h": self.grid.h,
            "degree": self.grid.degree,
            "particles": count,
            "dt": self.dt(),
            "steps": self.steps(),
        }

    # -- dict / TOML --------------------------------------------------------

    @classmethod
    def from_dict(cls, d: Mapping, overrides: list[str] | tuple[str, ...] = ()) -> "Scene":
        """Build a scene from a nested dict (as parsed from TOML).

        Parameters
        ----------
        d : Mapping
            The scene tables.
        overrides : sequence of str
            ``"dotted.path=value"`` overrides applied first, see
            :func:`apply_overrides`.

        Raises
        ------
        SceneError
            On unknown or missing keys and any invalid value.
        """
        if overrides:
            d = apply_overrides(d, list(overrides))
        return _build(cls, d, {
            "grid": lambda t: _build(Grid, t),
            "time": lambda t: _build(Time, t),
            "output": lambda t: _build(Output, t),
            "materials": lambda v: _tables(v, lambda t: _build(
                Material, t, {"fracture": lambda f: _build(
                    Fracture, f, {"anisotropy": lambda a: _build(Anisotropy, a)})})),
            "bodies": lambda v: _tables(v, _body_from_dict),
            "loads": lambda v: _tables(v, lambda t: _typed(t, LOADS)),
            "walls": lambda v: _tables(v, lambda t: _build(Wall, t)),
            "cracks": lambda v: _tables(v, lambda t: _build(Crack, t)),
            "phase_field": lambda t: _build(PhaseField, t),
            "contact": lambda t: _build(Contact, t, {
                "pairs": lambda v: _tables(v, lambda p: _build(ContactPair, p))}),
        })

    @classmethod
    def from_toml(cls, path, overrides: list[str] | tuple[str, ...] = ()) -> "Scene":
        """Load a scene from a TOML file; see :meth:`from_dict`.

        Raises
        ------
        SceneError
            On a TOML syntax error (path = the file) or an invalid scene.
        OSError
            If the file cannot be read.
        """
        with open(path, "rb") as f:
            try:
                data = tomllib.load(f)
            except tomllib.TOMLDecodeError as err:
                raise SceneError(str(path), f"invalid TOML: {err}") from None
        return cls.from_dict(data, overrides)

    def to_dict(self) -> dict[str, Any]:
        """Return the scene as a TOML-ready nested dict; ``from_dict`` inverts it."""
        return _plain(self)


# ----------------------------------------------------------------------------
# Dict helpers
# ----------------------------------------------------------------------------


def _reference(path: str, name: str, names: Mapping[str, int], what: str) -> None:
    """Check that ``name`` is one of ``names``."""
    if name not in names:
        have = ", ".join(map(repr, names)) or "none"
        raise SceneError(path, f"no {what} with that name (have: {have})", name)


def _lattice(body: Body, grid: Grid, i_range: tuple[int, int],
             j_range: tuple[int, int]) -> Iterator[np.ndarray]:
    """Yield the body's particles in cells ``[i0, i1) x [j0, j1)``, a batch at a time.

    Candidates are numbered by cell (row-major, y outer) then sub-position
    (row-major) and examined ``_CHUNK`` at a time, so memory stays bounded;
    each yielded (k, 2) array keeps that order.
    """
    (i0, i1), (j0, j1) = i_range, j_range
    cols, n, h, (ox, oy) = i1 - i0, body.particles_per_cell, grid.h, grid.origin
    count = max(cols, 0) * max(j1 - j0, 0) * n * n
    for start in range(0, count, _CHUNK):
        cell, sub = np.divmod(np.arange(start, min(start + _CHUNK, count)), n * n)
        j, i = np.divmod(cell, cols)
        b, a = np.divmod(sub, n)
        x = ox + (i0 + i + (a + 0.5) / n) * h
        y = oy + (j0 + j + (b + 0.5) / n) * h
        keep = body.contains(x, y)
        yield np.column_stack((x[keep], y[keep]))


def _check_keys(table: Any, cls: type, extra: tuple[str, ...] = ()) -> None:
    """Check a table for unknown keys and missing required fields of ``cls``."""
    if not isinstance(table, Mapping):
        raise SceneError("", "must be a table", table)
    fields = dataclasses.fields(cls)
    allowed = [*extra, *(f.name for f in fields)]
    for key in table:
        if key not in allowed:
            raise SceneError(_key(key), f"unknown key (allowed: {', '.join(allowed)})")
    for f in fields:
        no_default = f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
        if no_default and f.name not in table:
            raise SceneError(f.name, "missing required key")


def _build(cls: type, table: Any, convert: Mapping[str, Callable[[Any], Any]] | None = None,
           extra: tuple[str, ...] = ()) -> Any:
    """Construct ``cls`` from a table after checking its keys.

    ``convert`` maps keys to converters for nested tables; ``extra`` are
    allowed keys that are not fields (e.g. ``type``) and are dropped.
    """
    _check_keys(table, cls, extra)
    kwargs = {k: v for k, v in table.items() if k not in extra}
    for key, fn in (convert or {}).items():
        if key in kwargs:
            with _at(key):
                kwargs[key] = fn(kwargs[key])
    return cls(**kwargs)


def _tables(value: Any, build: Callable[[Any], Any]) -> tuple:
    """Build each table of an array of tables."""
    if not isinstance(value, (list, tuple)):
        raise SceneError("", "must be an array of tables", value)
    items = []
    for i, table in enumerate(value):
        with _at(f"[{i}]"):
            items.append(build(table))
    return tuple(items)


def _typed(table: Any, classes: Mapping[str, type]) -> Any:
    """Build a table whose ``type`` key selects the class among ``classes``."""
    if not isinstance(table, Mapping):
        raise SceneError("", "must be a table", table)
    if "type" not in table:
        raise SceneError("type", "missing required key")
    cls = classes.get(table["type"]) if isinstance(table["type"], str) else None
    if cls is None:
        raise SceneError("type", "must be one of " + ", ".join(map(repr, classes)), table["type"])
    return _build(cls, table, extra=("type",))


def _body_from_dict(table: Any) -> Body:
    """Build a :class:`Body`, converting its shape and holes tables."""
    return _build(Body, table, {
        "shape": lambda t: _typed(t, SHAPES),
        "holes": lambda v: _tables(v, lambda t: _typed(t, SHAPES)),
    })


def _plain(value: Any) -> Any:
    """Convert dataclasses and tuples to TOML-ready dicts and lists (None fields omitted)."""
    if dataclasses.is_dataclass(value):
        out = {"type": value.kind} if hasattr(value, "kind") else {}
        for f in dataclasses.fields(value):
            item = getattr(value, f.name)
            if item is not None:
                out[f.name] = _plain(item)
        return out
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def apply_overrides(d: Mapping, overrides: list[str]) -> dict:
    """Apply ``"dotted.path=value"`` overrides to a copy of a scene dict.

    Parameters
    ----------
    d : Mapping
        Scene dict (left unchanged).
    overrides : list of str
        Each ``"a.b.c=value"``.  ``value`` is parsed as a TOML value, or
        taken as a plain string if it does not parse.  A segment into an
        array of tables selects an entry by integer index or by its
        ``name``; a segment naming a missing table creates it.  Keys
        unknown to the schema are reported by validation.

    Returns
    -------
    dict
        The overridden deep copy.

    Raises
    ------
    SceneError
        On a malformed override or a path that cannot be followed.
    """
    if not isinstance(d, Mapping):
        raise SceneError("", "must be a table", d)
    root = copy.deepcopy(dict(d))
    for text in overrides:
        key, sep, raw = text.partition("=")
        key, raw = key.strip(), raw.strip()
        segments = key.split(".")
        if not sep or not all(segments):
            raise SceneError("--set", "expected 'dotted.path=value'", text)
        try:
            parsed = tomllib.loads("v = " + raw)
            value = parsed["v"] if len(parsed) == 1 else raw
        except tomllib.TOMLDecodeError:
            value = raw
        node: Any = root
        for depth, segment in enumerate(segments):
            path = ".".join(map(_key, segments[:depth]))
            last = depth == len(segments) - 1
            if isinstance(node, list):
                index = _entry(node, segment, ".".join(map(_key, segments[: depth + 1])))
                if last:
                    node[index] = value
                else:
                    node = node[index]
            elif isinstance(node, dict):
                if last:
                    node[segment] = value
                else:
                    node = node.setdefault(segment, {})
            else:
                raise SceneError(path, "is not a table, cannot set " + _fmt(key), node)
    return root


def _entry(items: list, segment: str, path: str) -> int:
    """Index of the array entry selected by an integer index or a ``name``."""
    try:
        index = int(segment)
    except ValueError:
        names = [t.get("name") if isinstance(t, Mapping) else None for t in items]
        if segment not in names:
            have = ", ".join(repr(n) for n in names if n is not None) or "none"
            raise SceneError(path, f"no entry with that name (have: {have})") from None
        return names.index(segment)
    if not -len(items) <= index < len(items):
        raise SceneError(path, f"index out of range ({len(items)} entries)")
    return index
