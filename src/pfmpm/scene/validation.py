"""Validation helpers of the scene classes: :class:`SceneError` and the field checkers.

Each checker takes the key path of one value and the value, and returns the
value normalised (tuples for sequences, floats for reals) or raises a
:class:`SceneError` whose one-line message names the path.  The scene classes
call them from ``__post_init__``, so a scene built in Python and one read from
TOML are checked by the same code.
"""

from __future__ import annotations

import math
import numbers
import re
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from typing import Any

import numpy as np

__all__ = ["SceneError", "MAX_COUNT", "WHOLE_TOL", "DIMENSIONS", "at", "fmt", "key_text", "real", "integer",
           "vec2", "vector", "same_dimension", "planar", "text", "choice", "seq", "polyline",
           "planar_polygon", "store", "reference"]

MAX_COUNT = 2**31 - 1
"""Cells, particles and iteration limits are indexed with int32 in the core."""
WHOLE_TOL = 1e-9
"""Relative tolerance of "a whole number" (of cells, of steps)."""
DIMENSIONS = (2, 3)
"""The directions a scene may have: its grid's ``size`` gives 2 or 3."""

_NO_VALUE = object()
_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


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
            message = f"{where}: {reason}"
        else:
            message = f"{where} = {fmt(value)}: {reason}"
        super().__init__(message)

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
def at(prefix: str) -> Iterator[None]:
    """Prefix the path of any :class:`SceneError` raised in the block."""
    try:
        yield
    except SceneError as err:
        raise err.within(prefix) from None


def key_text(key: Any) -> str:
    """A table key as a path segment: bare if TOML allows it bare, else quoted."""
    name = str(key)
    return name if _BARE_KEY.fullmatch(name) else fmt(name)


def fmt(value: Any, limit: int = 80) -> str:
    """Format a value TOML-like on one line, shortened to ``limit`` characters
    by leaving out its middle, so that a long file path keeps its file name."""
    if isinstance(value, np.ndarray):
        return fmt(value.tolist(), limit)  # one line, as a list
    if isinstance(value, (bool, np.bool_)):
        out = "true" if value else "false"
    elif isinstance(value, (list, tuple)):
        out = "[" + ", ".join(fmt(v, limit) for v in value) + "]"
    else:
        out = repr(value)
    if len(out) <= limit:
        return out
    head = (limit - 3) // 2
    return out[:head] + "..." + out[len(out) - (limit - 3 - head):]


def real(path: str, value: Any, *, gt=None, ge=None, lt=None, le=None) -> float:
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


def integer(path: str, value: Any, *, ge: int | None = None) -> int:
    """Check an integer (bools rejected), optionally ``>= ge``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise SceneError(path, "must be an integer", value)
    if ge is not None and value < ge:
        raise SceneError(path, f"must be >= {ge}", value)
    return int(value)


def boolean(path: str, value: Any) -> bool:
    """Check a true or false (numbers rejected)."""
    if not isinstance(value, bool):
        raise SceneError(path, "must be true or false", value)
    return value


def vec2(path: str, value: Any, **bounds: float) -> tuple[float, float]:
    """Check a 2-vector of finite numbers, each within ``bounds``."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise SceneError(path, "must be a list of 2 numbers", value)
    return (real(f"{path}[0]", value[0], **bounds), real(f"{path}[1]", value[1], **bounds))


def vector(path: str, value: Any, **bounds: float) -> tuple[float, ...]:
    """Check a vector of one finite number per direction, 2 or 3 of them
    (:data:`DIMENSIONS`), each within ``bounds``; whether their count is the
    scene's is checked against the whole scene (:func:`same_dimension`)."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) not in DIMENSIONS:
        raise SceneError(path, "must be a list of 2 or 3 numbers (one per direction)", value)
    return tuple(real(f"{path}[{i}]", v, **bounds) for i, v in enumerate(value))


def same_dimension(path: str, value: Any, dim: int) -> None:
    """Check that a vector (or a square matrix, by its rows) has one entry
    per direction of a ``dim``-dimensional scene."""
    if len(value) != dim:
        raise SceneError(path, f"has {len(value)} components, but the scene is {dim}D"
                               f" (grid.size has {dim} entries)", value)


def planar(path: str, what: str, value: Any = _NO_VALUE) -> SceneError:
    """The error of a two-dimensional feature, ``what``, used in a 3D scene."""
    return SceneError(path, f"{what} is two-dimensional yet, and the scene is 3D"
                            " (grid.size has 3 entries)", value)


def text(path: str, value: Any, *, empty: bool = False) -> str:
    """Check a string, non-empty unless ``empty``."""
    if not isinstance(value, str):
        raise SceneError(path, "must be a string", value)
    if not empty and not value:
        raise SceneError(path, "must not be empty", value)
    return value


def choice(path: str, value: Any, choices: tuple) -> Any:
    """Check that a value is one of ``choices`` (and of the same type)."""
    if not any(type(value) is type(c) and value == c for c in choices):
        raise SceneError(path, "must be one of " + ", ".join(fmt(c) for c in choices), value)
    return value


def seq(path: str, value: Any, what: str) -> tuple:
    """Check a list, tuple or array and return it as a tuple."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)):
        raise SceneError(path, f"must be a list of {what}", value)
    return tuple(value)


def polyline(path: str, value: Any) -> tuple[tuple[float, float], ...]:
    """Check a polyline: two or more [x, y] points, each segment of positive
    finite length; return its points as tuples."""
    points = seq(path, value, "[x, y] points")
    if len(points) < 2:
        raise SceneError(path, "needs at least two points", value)
    points = tuple(vec2(f"{path}[{i}]", p) for i, p in enumerate(points))
    for i in range(1, len(points)):
        (ax, ay), (bx, by) = points[i - 1], points[i]
        if not 0 < math.hypot(bx - ax, by - ay) < math.inf:
            raise SceneError(f"{path}[{i}]", f"segment from {path}[{i - 1}] = {fmt(points[i - 1])}"
                                             " must have a positive finite length", points[i])
    return points


def planar_polygon(path: str, value: Any) -> tuple[tuple[float, float, float], ...]:
    """Check a convex planar polygon in 3D: three or more [x, y, z] points in
    order around it, on one plane (within 1e-9 of its size), each turn
    the same way and once around; return its points as tuples."""
    points = seq(path, value, "[x, y, z] points")
    if len(points) < 3:
        raise SceneError(path, "a planar patch needs at least three [x, y, z] points", value)
    for i, p in enumerate(points):
        if isinstance(p, np.ndarray):
            p = p.tolist()
        if not isinstance(p, (list, tuple)) or len(p) != 3:
            raise SceneError(f"{path}[{i}]", "must be a list of 3 numbers (a 3D point)", p)
    points = tuple(tuple(real(f"{path}[{i}][{k}]", v) for k, v in enumerate(p)) for i, p in enumerate(points))
    p = np.array(points)
    size = float(np.max(np.ptp(p, axis=0)))
    edges = np.roll(p, -1, axis=0) - p
    normal = np.cross(p, np.roll(p, -1, axis=0)).sum(axis=0)  # Newell: twice the vector area
    area2 = float(np.sqrt(normal @ normal))
    if not (size < math.inf and area2 > 1e-12 * size * size):
        raise SceneError(path, "the points enclose no area (they lie on one line, or its sides cross)",
                         value)
    normal /= area2
    off = np.abs((p - p[0]) @ normal)
    if off.max() > 1e-9 * size:
        raise SceneError(path, f"the points are not on one plane (up to {off.max():.3g} off it)", value)
    lengths = np.sqrt(np.einsum("ij,ij->i", edges, edges))
    if lengths.min() <= 1e-12 * size:
        i = int(lengths.argmin())
        raise SceneError(path, f"corners {i} and {(i + 1) % len(points)} coincide", value)
    turns = np.cross(edges, np.roll(edges, -1, axis=0)) @ normal  # at each point after the first
    angles = np.arctan2(turns, np.einsum("ij,ij->i", edges, np.roll(edges, -1, axis=0)))
    if turns.min() <= 1e-12 * size * size or abs(angles.sum() - 2 * math.pi) > 1e-6:
        raise SceneError(path, "the polygon is not convex (give its corners in order around it,"
                               " none on a straight side)", value)
    return points


def store(obj: Any, name: str, value: Any) -> None:
    """Store a normalised field value on a frozen dataclass."""
    object.__setattr__(obj, name, value)


def reference(path: str, name: str, names: Mapping[str, int], what: str) -> None:
    """Check that ``name`` is one of ``names``."""
    if name not in names:
        have = ", ".join(map(repr, names)) or "none"
        raise SceneError(path, f"no {what} with that name (have: {have})", name)
