"""A body: a shape minus holes, filled with particles of one material (``[[bodies]]``)."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from .shapes import SHAPES, Shape
from .validation import SceneError, at, integer, planar, real, same_dimension, seq, store, text, vector

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
        Region filled with particles: a 2D shape in a 2D scene, a 3D one
        (a box, sphere, cylinder, volume mesh or extrusion) in a 3D scene.
    holes : sequence of Shape
        Regions removed from ``shape`` (notches, holes), of its dimension.
    particles_per_cell : int
        ``n``: particles are placed on an ``n x n`` (``n x n x n`` in 3D)
        lattice of sub-cell centres in every grid cell.
    velocity : sequence of float or None
        Initial velocity, one component per direction; ``None``: at rest.
    velocity_gradient : sequence of sequence of float or None
        Initial velocity gradient ``G``, a row per direction: a particle at
        ``x`` starts with ``velocity + G x`` (``G[i][j] = d v_i / d x_j``),
        e.g. a uniform stretching rate; ``None``: zero.
    orientation : float
        Principal material direction phi (the fibres) in degrees, clockwise
        from x (the paper's convention): turns the anisotropy tensor of the
        body's material, so that a crack along phi has ``gamma_n = gamma_1111``.
        Per-particle orientations can be set on ``Simulation.particles.phi``
        (radians) before the first step; only a material with the
        fourth-order term reads it, and only its runs have the column (2D only).
    """

    name: str
    material: str
    shape: Shape
    holes: tuple[Shape, ...] = ()
    particles_per_cell: int = 2
    velocity: tuple[float, ...] | None = None
    velocity_gradient: tuple[tuple[float, ...], ...] | None = None
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
            if hole.dim != self.dim:
                raise SceneError(f"holes[{i}]", f"a {hole.dim}D shape ({hole.kind}) in a body of the"
                                                f" {self.dim}D shape {self.shape.kind}", hole.kind)
        store(self, "holes", holes)
        store(self, "particles_per_cell", integer("particles_per_cell", self.particles_per_cell, ge=1))
        dim = self.dim
        store(self, "velocity", (0.0,) * dim if self.velocity is None else vector("velocity", self.velocity))
        if self.velocity_gradient is None:
            store(self, "velocity_gradient", ((0.0,) * dim,) * dim)
        rows = seq("velocity_gradient", self.velocity_gradient, "rows of numbers, one per direction")
        if len(rows) not in (2, 3):
            raise SceneError("velocity_gradient", "must have 2 or 3 rows of as many numbers (one per direction)",
                             self.velocity_gradient)
        rows = tuple(vector(f"velocity_gradient[{i}]", row) for i, row in enumerate(rows))
        for i, row in enumerate(rows):
            if len(row) != len(rows):
                raise SceneError(f"velocity_gradient[{i}]", f"must have {len(rows)} numbers, as"
                                                            " there are rows", row)
        store(self, "velocity_gradient", rows)
        store(self, "orientation", real("orientation", self.orientation))

    @property
    def dim(self) -> int:
        """The directions of the body's shape: 2 or 3."""
        return self.shape.dim

    def check_dimension(self, dim: int) -> None:
        """Check that the body fits a ``dim``-dimensional scene: its shape,
        velocity and velocity gradient; in 3D no material orientation."""
        with at("shape"):
            self.shape.check_dimension(dim)
        same_dimension("velocity", self.velocity, dim)
        same_dimension("velocity_gradient", self.velocity_gradient, dim)
        if dim == 3 and self.orientation:
            raise planar("orientation", "the material orientation", self.orientation)

    def contains(self, *coords: np.ndarray) -> np.ndarray:
        """Return True where the point of ``coords`` (``x, y`` or ``x, y, z``)
        lies in the shape and in no hole."""
        inside = self.shape.contains(*coords)
        for hole in self.holes:
            inside &= ~hole.contains(*coords)
        return inside

    def max_speed(self) -> float:
        """Largest initial particle speed: the velocity plus the gradient over the bounding box."""
        bounds = self.shape.bounds()
        lo, hi = bounds[:self.dim], bounds[self.dim:]
        speeds = []
        for corner in itertools.product(*zip(lo, hi)):
            v = []
            for v0, row in zip(self.velocity, self.velocity_gradient):
                for g, c in zip(row, corner):
                    v0 += g * c
                v.append(v0)
            speeds.append(math.hypot(*v))
        return max(speeds) if all(map(math.isfinite, speeds)) else math.inf

    def spacing(self, h: float) -> float:
        """Particle spacing ``h / particles_per_cell`` on a grid of cell side ``h``."""
        return h / self.particles_per_cell
