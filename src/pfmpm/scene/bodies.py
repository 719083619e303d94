"""A body: a shape minus holes, filled with particles of one material (``[[bodies]]``)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .shapes import SHAPES, Shape
from .validation import SceneError, integer, real, seq, store, text, vec2

__all__ = ["Body"]


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
        (radians) before the first step; only a material with the
        fourth-order term reads it, and only its runs have the column.
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
        store(self, "name", text("name", self.name))
        store(self, "material", text("material", self.material))
        if not isinstance(self.shape, Shape):
            raise SceneError("shape", "must be a shape (" + ", ".join(SHAPES) + ")", self.shape)
        holes = seq("holes", self.holes, "shapes")
        for i, hole in enumerate(holes):
            if not isinstance(hole, Shape):
                raise SceneError(f"holes[{i}]", "must be a shape (" + ", ".join(SHAPES) + ")", hole)
        store(self, "holes", holes)
        store(self, "particles_per_cell", integer("particles_per_cell", self.particles_per_cell, ge=1))
        store(self, "velocity", vec2("velocity", self.velocity))
        rows = seq("velocity_gradient", self.velocity_gradient, "2 rows of 2 numbers")
        if len(rows) != 2:
            raise SceneError("velocity_gradient", "must have 2 rows of 2 numbers", self.velocity_gradient)
        store(self, "velocity_gradient",
              tuple(vec2(f"velocity_gradient[{i}]", row) for i, row in enumerate(rows)))
        store(self, "orientation", real("orientation", self.orientation))

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

    def spacing(self, h: float) -> float:
        """Particle spacing ``h / particles_per_cell`` on a grid of cell side ``h``."""
        return h / self.particles_per_cell
