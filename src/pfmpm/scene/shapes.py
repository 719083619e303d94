"""The 2D shapes bodies and their holes are made of (TOML ``type`` of a
``shape`` or ``holes`` table)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .validation import SceneError, fmt, real, seq, store, vec2

__all__ = ["Shape", "Rectangle", "Disk", "Ring", "Polygon", "SHAPES"]


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


SHAPES: dict[str, type[Shape]] = {cls.kind: cls for cls in (Rectangle, Disk, Ring, Polygon)}
"""Shape classes by their TOML ``type``."""
