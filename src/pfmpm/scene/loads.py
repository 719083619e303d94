"""What acts on the bodies: tractions and body forces (``[[loads]]``), grid
walls (``[[walls]]``) and initial cracks (``[[cracks]]``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from .validation import SceneError, choice, polyline, real, store, text, vec2

__all__ = ["EDGES", "SIDES", "WALL_TYPES", "Traction", "BodyForce", "LOADS", "WallSpec", "Crack"]

EDGES = ("top", "bottom", "left", "right")
SIDES = ("left", "right", "bottom", "top")
WALL_TYPES = ("fixed", "slip")


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
        store(self, "body", text("body", self.body))
        store(self, "edge", choice("edge", self.edge, EDGES))
        store(self, "traction", vec2("traction", self.traction))


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
        store(self, "acceleration", vec2("acceleration", self.acceleration))
        if self.body is not None:
            store(self, "body", text("body", self.body))


LOADS: dict[str, type] = {cls.kind: cls for cls in (Traction, BodyForce)}
"""Load classes by their TOML ``type``."""


@dataclass(frozen=True)
class WallSpec:
    """Velocity boundary condition on one side of the grid (``[[walls]]``); the
    core's ``Grid.set_wall`` applies it.

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
        store(self, "side", choice("side", self.side, SIDES))
        store(self, "type", choice("type", self.type, WALL_TYPES))


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
        store(self, "points", polyline("points", self.points))
        if self.body is not None:
            store(self, "body", text("body", self.body))
        store(self, "B", real("B", self.B, gt=0))
        if self.half_width is not None:
            store(self, "half_width", real("half_width", self.half_width, gt=0))

    def tip(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """The tip at the crack's last point and the direction it points in,
        along its last segment (not of unit length)."""
        (ax, ay), (bx, by) = self.points[-2], self.points[-1]
        return (bx, by), (bx - ax, by - ay)
