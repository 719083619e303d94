"""The scene's settings tables: the background grid, the time interval, the
output cadence, the phase-field solver and the particle-grid transfer (TOML
``[grid]``, ``[time]``, ``[output]``, ``[phase_field]`` and ``[transfer]``)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from .declared import check_declared, parameter, phase_field_parameters
from .validation import (MAX_COUNT, WHOLE_TOL, SceneError, boolean, choice, integer, real, same_dimension,
                         seq, store, vector)

__all__ = ["DEGREES", "SHAPES", "TRANSFER_SCHEMES", "GridSpec", "Time", "Output", "PhaseFieldSpec",
           "TransferSpec"]

DEGREES = (1, 2, 3)

SHAPES = ("bspline", "cpdi")
"""The shape functions ``[grid] shape`` names: B-splines at the particle centres, or CPDI1
averages over the particle domains (degree 1 only)."""


PRECONDITIONERS = tuple(parameter(phase_field_parameters(), "preconditioner")["choices"])
"""The phase-field CG preconditioners ``[phase_field] preconditioner`` names (declared by the core)."""


def _solver_default(name: str):
    """The core's default of the phase-field solve's parameter ``name``."""
    return parameter(phase_field_parameters(), name)["default"]

TRANSFER_SCHEMES = ("flip", "apic")
"""The particle-grid transfers ``[transfer] scheme`` names: FLIP with the lumped mass
(Kakouris & Triantafyllou 2019, eq. 80), or APIC (Jiang et al. 2015)."""


@dataclass(frozen=True)
class GridSpec:
    """Uniform background grid of square (cubic) cells (``[grid]``); the core
    builds its ``pfmpm._core.Grid`` (``Grid3`` in 3D) from it.

    Parameters
    ----------
    size : (float, float) or (float, float, float)
        Extent in x and y, and in z for a 3D scene: the number of entries is
        the scene's dimension (:attr:`dim`). Each must be a whole number of
        cells of ``h``.
    h : float
        Cell side.
    origin : (float, float) or (float, float, float) or None
        Lower-left (back) corner, one entry per direction; ``None``: the origin.
    degree : int
        B-spline degree of the shape functions, 1, 2 or 3.
    shape : str
        Shape functions of the momentum transfers: ``"bspline"`` (at the particle
        centres) or ``"cpdi"`` (CPDI1 averages over the particle domains, on the
        degree-1 grid, in 2D and 3D; the phase field keeps B-splines).
    scale_failed : bool
        With CPDI: scale the domain of a failed particle (damage D = 1, or phase
        field c below ``failed_c``), each half-diagonal shortened to at most ``h/2``
        (Homel & Herbold §2.6).
    failed_c : float
        With CPDI: a particle with phase field c below this is failed; 0 counts
        damage D = 1 alone.
    """

    size: tuple[float, ...]
    h: float
    origin: tuple[float, ...] | None = None
    degree: int = 2
    shape: str = "bspline"
    scale_failed: bool = True
    failed_c: float = 0.0

    def __post_init__(self):
        store(self, "size", vector("size", self.size, gt=0))
        store(self, "h", real("h", self.h, gt=0))
        if self.origin is None:
            store(self, "origin", (0.0,) * self.dim)
        store(self, "origin", vector("origin", self.origin))
        same_dimension("origin", self.origin, self.dim)
        store(self, "degree", choice("degree", integer("degree", self.degree), DEGREES))
        for s in self.size:
            n = s / self.h
            if n > MAX_COUNT:
                raise SceneError("size", f"{n:.3g} cells of h = {self.h:g} exceed the limit"
                                         f" of {MAX_COUNT}", self.size)
            if round(n) < 1:
                raise SceneError("size", f"smaller than one cell of h = {self.h:g}", self.size)
            if abs(n - round(n)) > WHOLE_TOL * n:
                raise SceneError("size", f"not a whole number of cells of h = {self.h:g}", self.size)
        cells = " x ".join(map(str, self.cells))
        if min(self.cells) < self.degree:
            raise SceneError("size", f"{cells} cells of h = {self.h:g}: degree {self.degree}"
                                     f" B-splines need at least {self.degree} cells a side", self.size)
        if math.prod(self.cells) > MAX_COUNT:
            raise SceneError("size", f"{cells} cells exceed the limit of {MAX_COUNT}", self.size)
        if not all(math.isfinite(o + s) for o, s in zip(self.origin, self.size)):
            raise SceneError("origin", "origin + size is not finite", self.origin)
        store(self, "shape", choice("shape", self.shape, SHAPES))
        store(self, "scale_failed", boolean("scale_failed", self.scale_failed))
        store(self, "failed_c", real("failed_c", self.failed_c, ge=0, lt=1))
        if self.shape == "cpdi":
            if self.degree != 1:
                raise SceneError("degree", "shape \"cpdi\" runs on the degree-1 grid (CPDI1);"
                                           " set degree = 1", self.degree)
            if min(self.cells) < 3:
                raise SceneError("size", f"{cells} cells: shape \"cpdi\" needs at least 3"
                                         " cells a side", self.size)
        elif self.failed_c or not self.scale_failed:
            raise SceneError("failed_c" if self.failed_c else "scale_failed",
                             "applies to shape = \"cpdi\" only", self.failed_c or self.scale_failed)

    @property
    def dim(self) -> int:
        """The scene's dimension: 2, or 3 with three ``size`` entries."""
        return len(self.size)

    @property
    def cells(self) -> tuple[int, ...]:
        """Number of cells per direction, ``(nx, ny)`` or ``(nx, ny, nz)``."""
        return tuple(round(s / self.h) for s in self.size)

    def box(self) -> str:
        """The grid's extent as text, ``[x0, x1] x [y0, y1]`` (``x [z0, z1]`` in 3D)."""
        return " x ".join(f"[{o:g}, {o + s:g}]" for o, s in zip(self.origin, self.size))


@dataclass(frozen=True)
class Time:
    """Simulated time interval and step control (``[time]``).

    Parameters
    ----------
    end : float
        End time.
    dt : float or None
        Fixed time step; ``None`` uses the stable step.  Must not exceed the
        stability limit (checked by :class:`~pfmpm.scene.Scene`).
    cfl : float
        Courant factor ``alpha_c`` in ``(0, 1]``.
    max_steps : int
        The most steps a run may take; a scene needing more is refused
        (:class:`~pfmpm.scene.Scene`), since that usually means moduli or a
        density in the wrong units.
    """

    end: float
    dt: float | None = None
    cfl: float = 0.8
    max_steps: int = 1_000_000

    def __post_init__(self):
        store(self, "end", real("end", self.end, gt=0))
        if self.dt is not None:
            store(self, "dt", real("dt", self.dt, gt=0))
        store(self, "cfl", real("cfl", self.cfl, gt=0, le=1))
        store(self, "max_steps", integer("max_steps", self.max_steps, ge=1))


@dataclass(frozen=True)
class Output:
    """Output cadence (``[output]``).

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
        A point belongs to a crack when its phase field is below this, in
        ``(0, 1)``: it sets where the crack tip is, and every measure of
        :mod:`pfmpm.post` reads its cracks with it.
    crack_speed_samples : int
        ``energies.csv`` rows in the least-squares fit that smooths the
        crack-tip speed, at least 2.
    crack_direction : sequence of float or None
        The direction the crack runs in, one component per direction of the
        scene (need not be of unit length). A 2D crack's tip is the cracked
        point farthest from the end of the first initial crack ahead of it
        along this; ``None``: along that crack's last segment. A 3D scene
        with initial cracks needs it: the crack front is the farthest extent
        of the cracked points along it (:class:`pfmpm.observe.CrackFront`).
    """

    every: int = 100
    energies_every: int = 10
    particles: bool = True
    snapshots: tuple[float, ...] = ()
    crack_threshold: float = 0.2
    crack_speed_samples: int = 9
    crack_direction: tuple[float, ...] | None = None

    def __post_init__(self):
        store(self, "every", integer("every", self.every, ge=1))
        store(self, "energies_every", integer("energies_every", self.energies_every, ge=1))
        store(self, "particles", boolean("particles", self.particles))
        times = seq("snapshots", self.snapshots, "times")
        store(self, "snapshots", tuple(real(f"snapshots[{i}]", t, ge=0) for i, t in enumerate(times)))
        store(self, "crack_threshold", real("crack_threshold", self.crack_threshold, gt=0, lt=1))
        store(self, "crack_speed_samples", integer("crack_speed_samples", self.crack_speed_samples, ge=2))
        if self.crack_direction is not None:
            direction = vector("crack_direction", self.crack_direction)
            if not any(direction):
                raise SceneError("crack_direction", "must not be zero", self.crack_direction)
            store(self, "crack_direction", direction)


@dataclass(frozen=True)
class PhaseFieldSpec:
    """Phase-field solver settings (``[phase_field]``), handed to the core's
    phase-field solve.

    Parameters
    ----------
    tol : float
        Tolerance tol_c of the phase-field solve, relative to ``||F||``
        (K&T eq. 52), in ``(0, 1)``.
    max_iterations : int
        Conjugate-gradient iterations allowed per step; the run stops with
        an error when they do not reach ``tol``.
    preconditioner : str
        Of the conjugate gradients: ``"jacobi"``, ``"ssor"`` (symmetric
        Gauss-Seidel), ``"multigrid"`` (a geometric V-cycle on the B-spline
        grid), or ``"automatic"``: ssor for the second-order model, multigrid
        for the fourth-order one. The bounded second-order solve
        (``fracture.bound``, the default) takes ``"jacobi"`` or ``"ssor"``.
    """

    tol: float = _solver_default("tol")
    max_iterations: int = _solver_default("max_iterations")
    preconditioner: str = _solver_default("preconditioner")

    def __post_init__(self):
        for key in ("tol", "max_iterations", "preconditioner"):
            store(self, key, check_declared(phase_field_parameters(), key, getattr(self, key)))


@dataclass(frozen=True)
class TransferSpec:
    """The particle-grid transfer of the momentum step (``[transfer]``), the
    core's ``pfmpm._core.TransferScheme``.

    Parameters
    ----------
    scheme : str
        ``"flip"``: each particle's velocity takes the step's nodal
        accelerations, ``v_p += dt sum_i N_i a_i`` (Kakouris & Triantafyllou
        2019, eq. 80). ``"apic"``: the affine particle-in-cell transfer (Jiang et
        al. 2015): ``v_p = sum_i N_i v_i`` and an affine matrix per particle
        (the column ``affine``, ``B_p``) that P2G adds to the momentum,
        which keeps the angular momentum of the transfers. Either works with
        every grid degree, ``[grid] shape`` and ``[contact]`` partition. A
        body's ``velocity_gradient`` sets its particles' initial affine
        matrices with APIC.
    """

    scheme: str = "flip"

    def __post_init__(self):
        store(self, "scheme", choice("scheme", self.scheme, TRANSFER_SCHEMES))
