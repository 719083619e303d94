"""Damage models of a material (its ``damage`` table): the scalar damage of
Homel & Herbold (2017, §2.7), D = 0 intact to 1 failed, which degrades the
tensile principal stresses (H&H eqs. 26-27).

``model`` selects the class in :data:`DAMAGE_MODELS`:

``"rankine"`` (:class:`RankineSpec`)
    Rankine damage with linear strain softening (H&H eq. 23).
``"time_to_failure"`` (:class:`TimeToFailureSpec`)
    D grows at 1 / tau, tau = l / c_f, while the strength is exceeded (H&H eq. 24).

Either takes an optional ``weibull`` table (:class:`WeibullSpec`): a strength
drawn per particle (H&H eq. 25).

The scene's ``[[initial_damage]]`` tables (:class:`InitialDamage`) give
particles of such materials a damage D at t = 0: pre-failed surfaces and
pre-broken parts (a box, a band along a polyline or in 3D a patch over a
planar polygon, or a set of particles).
"""

from __future__ import annotations

import abc
import math
import numbers
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .declared import check_declared, declaration
from .shapes import distance_to_polyline
from .validation import (MAX_COUNT, SceneError, fmt, integer, polyline, real, same_dimension, seq, store,
                         text, vector)

__all__ = ["DAMAGE_MODELS", "damage_class", "DamageSpec", "RankineSpec", "TimeToFailureSpec",
           "WeibullSpec", "cell_diagonal", "localisation_width", "InitialDamage"]


def _declared(name: str, value):
    """``value`` checked against the core's ``neo_hookean`` declaration of
    the damage parameter ``name`` (its bounds live there, once)."""
    return check_declared(declaration("neo_hookean")["parameters"], name, value)


DAMAGE_MODELS: dict[str, type["DamageSpec"]] = {}
"""Damage classes by the ``model`` name of a ``damage`` table."""


def _register(cls: type["DamageSpec"]) -> type["DamageSpec"]:
    DAMAGE_MODELS[cls.model] = cls
    return cls


def damage_class(model) -> type["DamageSpec"]:
    """The class of a damage ``model`` name.

    Raises
    ------
    SceneError
        Naming the key ``model`` and the known names, if none has that name.
    """
    cls = DAMAGE_MODELS.get(model) if isinstance(model, str) else None
    if cls is None:
        raise SceneError("model", "must be one of " + ", ".join(map(repr, DAMAGE_MODELS)), model)
    return cls


def cell_diagonal(h: float, dim: int = 2) -> float:
    """The cell diagonal sqrt(dim) h of the grid (sqrt(2) h in 2D, sqrt(3) h in
    3D): H&H's l_ch (§2.7, Table III) and the default length of time-to-failure
    damage (H&H eq. 24)."""
    return math.sqrt(dim) * h


def localisation_width(grid) -> float:
    """The width of the band in which the grid's shape functions localise a
    crack: the default l_ch of Rankine softening, so that a crack dissipates
    G_f per unit area (docs/method.md, "The crack band").

    A displacement jump across a line of nodes is, on the grid, a sum of
    whole shape functions, which ramps over the support of one: the strain
    of the particles within that support carries the jump, and they soften
    together. So the band is ``degree`` cells wide for quadratic and cubic
    B-splines (between knot lines), and 2 cells for linear B-splines and
    CPDI1 when the crack lies on a node line (one cell when it runs through
    the middle of a cell: it then dissipates G_f / 2). A band of width w
    dissipates G_f w / l_ch per unit crack area (H&H eq. 23 in one dimension).
    """
    return max(grid.degree, 2) * grid.h


@dataclass(frozen=True)
class WeibullSpec:
    """Weibull strength per particle (H&H eq. 25):
    ``sigma_f = sigma_ref [(V_ref / V) ln(R) / ln(1/2)]^(1/m)``, R uniform in (0, 1).

    ``sigma_ref`` is the damage table's ``sigma_f``, the median strength of a
    sample of volume ``V_ref``; a particle of volume V (its initial volume,
    area times the scene's thickness) has the median ``sigma_ref (V_ref /
    V)^(1/m)``, and P(sigma_f < s) = 1 - exp(-ln 2 (V / V_ref) (s / sigma_ref)^m).

    Parameters
    ----------
    m : float
        Weibull modulus, > 0.
    V_ref : float
        Reference volume, > 0.
    seed : int
        Seed of the draws (numpy's ``default_rng``), >= 0: the same seed
        gives bitwise the same field.
    """

    m: float
    V_ref: float
    seed: int = 0

    def __post_init__(self):
        store(self, "m", real("m", self.m, gt=0))
        store(self, "V_ref", real("V_ref", self.V_ref, gt=0))
        store(self, "seed", integer("seed", self.seed, ge=0))

    def draw(self, sigma_ref: float, volume: np.ndarray) -> np.ndarray:
        """One strength per particle of ``volume`` (H&H eq. 25), in particle order.

        R = u + 2^-54 with u from ``default_rng(seed).random``, so that R lies
        in the open interval (0, 1).

        Raises
        ------
        SceneError
            Naming ``m``, if a draw leaves the floating-point range (0, inf),
            as a tiny modulus makes it do: 1/m is the power of the draw.
        """
        R = np.random.default_rng(self.seed).random(len(volume)) + 2.0**-54
        with np.errstate(over="ignore", under="ignore"):
            strength = sigma_ref * ((self.V_ref / volume) * (np.log(R) / math.log(0.5))) ** (1.0 / self.m)
        if not np.all((strength > 0) & np.isfinite(strength)):
            raise SceneError("weibull.m", f"draws strengths from {strength.min():g} to {strength.max():g}"
                             " for these particle volumes, beyond the floating-point range", self.m)
        return strength

    def cdf(self, s, sigma_ref: float, volume: float):
        """P(sigma_f < s) for a particle of ``volume``."""
        return 1.0 - np.exp(-math.log(2.0) * (volume / self.V_ref) * (np.asarray(s) / sigma_ref) ** self.m)

    def median(self, sigma_ref: float, volume: float) -> float:
        """The median strength ``sigma_ref (V_ref / volume)^(1/m)``."""
        return sigma_ref * (self.V_ref / volume) ** (1.0 / self.m)


class DamageSpec(abc.ABC):
    """What every damage model declares.

    Attributes
    ----------
    model : str
        The name in ``damage`` tables (a class attribute).
    sigma_f : float
        Tensile strength, > 0 (the reference strength with ``weibull``).
    l_ch : float or None
        Characteristic length; ``None``: the model's default for the grid
        (:meth:`default_length`).
    weibull : WeibullSpec or None
        A strength per particle (H&H eq. 25); ``None``: ``sigma_f`` everywhere.
    """

    model: ClassVar[str]
    sigma_f: float
    l_ch: float | None
    weibull: WeibullSpec | None

    def length(self, grid) -> float:
        """l_ch, or the model's default for ``grid`` (a GridSpec)."""
        return self.l_ch if self.l_ch is not None else self.default_length(grid)

    @staticmethod
    @abc.abstractmethod
    def default_length(grid) -> float:
        """l_ch when the table does not give it."""

    @abc.abstractmethod
    def core_parameters(self, grid) -> dict[str, float | str]:
        """The damage parameters of the core's ``neo_hookean`` model on ``grid``."""

    def check(self, E: float, grid, strongest: float | None = None) -> None:
        """Check the parameters against the grid (and the strongest particle's
        strength of a Weibull field); nothing to check by default."""

    def _check_common(self) -> None:
        store(self, "sigma_f", _declared("sigma_f", self.sigma_f))
        if self.l_ch is not None:
            store(self, "l_ch", _declared("l_ch", self.l_ch))
        if self.weibull is not None and not isinstance(self.weibull, WeibullSpec):
            raise SceneError("weibull", "must be a weibull table", self.weibull)

    def strengths(self, volume: np.ndarray) -> np.ndarray:
        """The strength of each particle of initial ``volume``: the Weibull
        draws (H&H eq. 25), or ``sigma_f``."""
        if self.weibull is None:
            return np.full(len(volume), self.sigma_f)
        return self.weibull.draw(self.sigma_f, volume)


@_register
@dataclass(frozen=True)
class RankineSpec(DamageSpec):
    """Rankine damage with linear strain softening (H&H eq. 23, Cervera's form):
    ``D = (1 + H_s)(1 - sigma_f / r)``, r the largest trial principal stress so
    far, ``H_s = Hbar l_ch / (1 - Hbar l_ch)``, ``Hbar = sigma_f^2 / (2 E Gf)``.
    A band of width l_ch dissipates Gf per unit crack area.

    Parameters
    ----------
    sigma_f : float
        Tensile strength, > 0.
    Gf : float
        Fracture energy, > 0.
    l_ch : float or None
        Characteristic length, > 0 and < 2 E Gf / sigma_f^2; default the
        width of the band the grid's shape functions localise a crack in
        (:func:`localisation_width`: 2 h for quadratic B-splines and CPDI,
        3 h for cubic ones). H&H take the cell diagonal (1.414 mm at h = 1
        mm, their Table III); give ``l_ch`` to run theirs.
    weibull : WeibullSpec or None
    """

    model: ClassVar[str] = "rankine"
    sigma_f: float
    Gf: float
    l_ch: float | None = None
    weibull: WeibullSpec | None = None

    def __post_init__(self):
        self._check_common()
        store(self, "Gf", _declared("Gf", self.Gf))

    @staticmethod
    def default_length(grid) -> float:
        return localisation_width(grid)

    def core_parameters(self, grid) -> dict[str, float | str]:
        return {"damage": self.model, "sigma_f": self.sigma_f, "Gf": self.Gf, "l_ch": self.length(grid)}

    def check(self, E: float, grid, strongest: float | None = None) -> None:
        """l_ch < 2 E Gf / sigma_f^2 for the strongest particle, or the softening snaps back."""
        sigma = self.sigma_f if strongest is None else strongest
        limit = 2.0 * E * self.Gf / sigma / sigma  # sigma**2 would overflow
        length = self.length(grid)
        if not length < limit:
            what = "" if strongest is None else f" of the strongest particle (sigma_f = {sigma:.6g})"
            default = " (the default, the grid's localisation width)" if self.l_ch is None else ""
            raise SceneError("l_ch", f"must be < 2 E Gf / sigma_f^2 = {limit:.6g}{what}, or the"
                             f" softening of H&H eq. 23 snaps back{default}", length)


@_register
@dataclass(frozen=True)
class TimeToFailureSpec(DamageSpec):
    """Time-to-failure damage (H&H eq. 24): ``D += dt / tau``, ``tau = l_ch / c_f``,
    in each step whose largest trial principal stress exceeds sigma_f.

    Parameters
    ----------
    sigma_f : float
        Tensile strength, > 0 (the reference strength with ``weibull``).
    c_f : float
        Crack speed, > 0.
    l_ch : float or None
        The length l a crack crosses in tau, > 0; default the cell diagonal.
    weibull : WeibullSpec or None
    """

    model: ClassVar[str] = "time_to_failure"
    sigma_f: float
    c_f: float
    l_ch: float | None = None
    weibull: WeibullSpec | None = None

    def __post_init__(self):
        self._check_common()
        store(self, "c_f", _declared("c_f", self.c_f))

    @staticmethod
    def default_length(grid) -> float:
        return cell_diagonal(grid.h, grid.dim)

    def core_parameters(self, grid) -> dict[str, float | str]:
        return {"damage": self.model, "sigma_f": self.sigma_f, "c_f": self.c_f, "l_ch": self.length(grid)}


# -- initial damage (the scene's [[initial_damage]]) -------------------------------

def _plane_frame(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A planar polygon's unit normal (Newell's method) and two unit in-plane
    axes, the first along its first edge."""
    n = np.cross(corners, np.roll(corners, -1, axis=0)).sum(axis=0)
    n = n / np.linalg.norm(n)
    e1 = corners[1] - corners[0]
    e1 = e1 / np.linalg.norm(e1)
    return n, e1, np.cross(n, e1)


def planar_polygon(path: str, value) -> tuple[tuple[float, float, float], ...]:
    """Check the corners of a simple planar polygon in 3D: three or more
    [x, y, z] points, in order around it, with an area and all within 1e-9 of
    its size of its plane (through the first corner, normal by Newell's
    method); return them as tuples."""
    points = seq(path, value, "[x, y, z] points")
    if len(points) < 3:
        raise SceneError(path, "a patch needs at least three corners", value)
    corners = []
    for i, p in enumerate(points):
        v = vector(f"{path}[{i}]", p)
        if len(v) != 3:
            raise SceneError(f"{path}[{i}]", "must be an [x, y, z] point, as the first corner is", p)
        corners.append(v)
    c = np.asarray(corners)
    size = float(np.ptp(c, axis=0).max())
    area2 = float(np.linalg.norm(np.cross(c, np.roll(c, -1, axis=0)).sum(axis=0)))
    if not (size > 0 and area2 > 1e-12 * size * size and np.isfinite(area2)):
        raise SceneError(path, "the corners enclose no area (a patch is a planar polygon)", value)
    n, _, _ = _plane_frame(c)
    off = np.abs((c - c[0]) @ n)
    if off.max() > 1e-9 * size:
        k = int(np.argmax(off))
        raise SceneError(f"{path}[{k}]", f"is {off[k]:.3g} off the patch's plane (a patch is"
                                         " a planar polygon)", points[k])
    return tuple(tuple(map(float, p)) for p in corners)


def distance_to_polygon(x: np.ndarray, corners) -> np.ndarray:
    """Distance of each point of ``x`` (N, 3) to the closed planar polygon with
    ``corners``: to its plane where the point's projection falls inside it,
    else to its boundary (the patch of :class:`InitialDamage`)."""
    from matplotlib.path import Path

    c = np.asarray(corners, dtype=float)
    n, e1, e2 = _plane_frame(c)
    d = np.asarray(x, dtype=float).reshape(-1, 3) - c[0]
    normal = d @ n
    flat = np.stack([d @ e1, d @ e2], axis=1)
    outline = np.stack([(c - c[0]) @ e1, (c - c[0]) @ e2], axis=1)
    inside = Path(outline).contains_points(flat)
    rim = distance_to_polyline(flat, np.vstack([outline, outline[:1]]))
    return np.where(inside, np.abs(normal), np.hypot(normal, rim))


_REGIONS = {"box": ("min", "max"), "band": ("points", "half_width"), "particles": ("particles",)}
"""The regions of an :class:`InitialDamage` by name, each with its keys."""


@dataclass(frozen=True)
class InitialDamage:
    """Damage D at t = 0 on a region of the particles of bodies whose material
    has a damage model (``[[initial_damage]]``): pre-failed surfaces and
    pre-broken parts (Homel & Herbold 2017: the billet's, the bars').

    One region per entry, given by its keys:

    - a box, ``min`` and ``max``: the particles whose position at t = 0 lies
      in the closed box ``min <= (x, y) <= max`` (``(x, y, z)`` in 3D);
    - a band, ``points`` and ``half_width``: those within ``half_width``
      (closed) of the polyline through ``points`` in 2D; in 3D, a patch:
      those within ``half_width`` of the planar polygon whose corners are
      ``points`` (the region between them and on it, a failed plane of finite
      extent, the 3D form of the band);
    - ``particles``: indices into the body's particles (0 to n - 1, in the
      order of the seeding: the body's rows of ``Scene.particles()`` and of
      ``Simulation.particles``), or a boolean mask over them, one entry per
      particle.  A mask is built from a scene without the entry, e.g.
      ``x = scene.particles()["x"][scene.particles()["body"] == 0]``, then
      ``dataclasses.replace(scene, initial_damage=(InitialDamage(body="bar",
      particles=x[:, 0] > 5.0),))``.

    The selected particles start with damage ``max(D, ...)`` over the entries
    that select them; the damage model grows it from there (it never
    decreases), and it dissipates nothing at t = 0.  A particle with D = 1 is
    failed from the first step on: its tensile stresses are zero (H&H eqs.
    26-27), the damage-gradient partition splits the velocity field at it,
    and with CPDI (``grid.scale_failed``) its domain is scaled, as for a
    particle that fails during the run.

    Parameters
    ----------
    body : str or None
        The body whose particles are damaged; ``None``: every body whose
        material has a damage model (with ``particles``, there must be one).
    D : float
        The damage, in ``(0, 1]``; 1 is failed.
    min, max : sequence of float or None
        A box: its lower-left and upper-right corners, ``min < max``
        componentwise, one component per direction.
    points : sequence of (float, float), or of (float, float, float), or None
        A band: its polyline, at least two points, each segment of positive
        length; or a patch: the corners of a simple planar polygon, at least
        three 3D points, in order around it.
    half_width : float or None
        The band's (patch's) half width, > 0.
    particles : sequence of int, or of bool, or None
        Indices into the body's particles (each once), or a boolean mask
        over them.

    Raises
    ------
    SceneError
        On a missing, second or invalid region, or a bad ``D``.  That the
        body exists, that its material has a damage model, and that the
        region selects a particle within the body's range are checked by
        :class:`~pfmpm.scene.Scene`.
    """

    body: str | None = None
    D: float = 1.0
    min: tuple[float, ...] | None = None
    max: tuple[float, ...] | None = None
    points: tuple[tuple[float, float], ...] | None = None
    half_width: float | None = None
    particles: tuple[int, ...] | tuple[bool, ...] | None = None

    def __post_init__(self):
        if self.body is not None:
            store(self, "body", text("body", self.body))
        store(self, "D", real("D", self.D, gt=0, le=1))
        given = [name for name, keys in _REGIONS.items() if any(getattr(self, k) is not None for k in keys)]
        if not given:
            raise SceneError("", "needs a region: min and max (a box), points and half_width"
                                 " (a band along a polyline, in 3D a patch over a planar polygon), or particles")
        if len(given) > 1:
            first, second = given[0], given[1]
            key = next(k for k in _REGIONS[second] if getattr(self, k) is not None)
            raise SceneError(key, f"a second region: the entry has a {first} already"
                                  f" ({' and '.join(_REGIONS[first])}); give one region per entry",
                             getattr(self, key))
        region = given[0]
        for key in _REGIONS[region]:
            if getattr(self, key) is None:
                raise SceneError(key, f"missing required key (a {region} needs"
                                      f" {' and '.join(_REGIONS[region])})")
        if region == "box":
            store(self, "min", vector("min", self.min))
            store(self, "max", vector("max", self.max))
            if len(self.max) != len(self.min):
                raise SceneError("max", f"must have {len(self.min)} components, as min has", self.max)
            if not all(a < b for a, b in zip(self.min, self.max)):
                raise SceneError("max", f"must exceed min = {fmt(self.min)} componentwise", self.max)
        elif region == "band":
            points = seq("points", self.points, "points")
            three = bool(points) and isinstance(points[0], (list, tuple, np.ndarray)) and len(points[0]) == 3
            store(self, "points", planar_polygon("points", points) if three else polyline("points", points))
            store(self, "half_width", real("half_width", self.half_width, gt=0))
        else:
            self._check_particles()

    def _check_particles(self) -> None:
        """Normalise ``particles`` to a tuple of ints or of bools, kept also as an array."""
        value = self.particles
        what = "particle indices or a boolean mask"
        if isinstance(value, np.ndarray):
            if value.ndim != 1 or not (value.dtype == bool or np.issubdtype(value.dtype, np.integer)):
                raise SceneError("particles", f"must be a list of {what}", value)
            items = tuple(value.tolist())
        else:
            items = seq("particles", value, what)
            mask = bool(items) and isinstance(items[0], (bool, np.bool_))
            for k, item in enumerate(items):
                is_bool = isinstance(item, (bool, np.bool_))
                if is_bool != mask or not (is_bool or isinstance(item, numbers.Integral)):
                    raise SceneError(f"particles[{k}]", "must be " + ("true or false, as the mask's"
                                     " other entries" if mask else "an integer index"), item)
            items = tuple(bool(v) for v in items) if mask else tuple(int(v) for v in items)
        store(self, "particles", items)
        if not self.is_mask and items and max(items) > MAX_COUNT:
            k = items.index(max(items))
            raise SceneError(f"particles[{k}]", f"must be <= {MAX_COUNT}", items[k])
        array = np.asarray(items, dtype=bool if self.is_mask else np.int64)
        if not (array.any() if self.is_mask else len(array)):
            raise SceneError("particles", "selects no particle", self.particles)
        if not self.is_mask:
            if array.min() < 0:
                k = int(np.argmax(array < 0))
                raise SceneError(f"particles[{k}]", "must be >= 0", items[k])
            order = np.argsort(array, kind="stable")
            same = np.flatnonzero(array[order][1:] == array[order][:-1])
            if len(same):
                k, first = int(order[same[0] + 1]), int(order[same[0]])
                raise SceneError(f"particles[{k}]", f"duplicate index (also particles[{first}])", items[k])
        object.__setattr__(self, "_array", array)

    def check_dimension(self, dim: int) -> None:
        """Check the region against a ``dim``-dimensional scene."""
        if self.region == "box":
            same_dimension("min", self.min, dim)
        elif self.region == "band" and len(self.points[0]) != dim:
            what = "a patch's 3D polygon" if dim == 2 else "a band's 2D polyline"
            raise SceneError("points", f"{what} in a {dim}D scene (grid.size has {dim} entries): a band"
                                       " takes [x, y] points in 2D, a patch [x, y, z] corners in 3D",
                             self.points)

    @property
    def region(self) -> str:
        """``"box"``, ``"band"`` or ``"particles"``."""
        return next(name for name, keys in _REGIONS.items() if getattr(self, keys[0]) is not None)

    @property
    def is_mask(self) -> bool:
        """Whether ``particles`` is a boolean mask (not indices)."""
        return bool(self.particles) and isinstance(self.particles[0], bool)

    def describe(self) -> str:
        """The region in words, for messages."""
        if self.region == "box":
            return f"the box min = {fmt(self.min)}, max = {fmt(self.max)}"
        if self.region == "band":
            what = "patch" if len(self.points[0]) == 3 else "band"
            return f"the {what} of half_width = {self.half_width:g} along points = {fmt(self.points)}"
        return f"particles = {fmt(self.particles)}"

    def select(self, x: np.ndarray, first: int = 0) -> np.ndarray:
        """Which of a body's particles ``first`` to ``first + len(x)``, at
        positions ``x`` (k, dim) at t = 0, the region holds (a boolean array)."""
        x = np.asarray(x, dtype=float)
        x = x.reshape(-1, x.shape[-1])
        if self.region == "box":
            return np.all((x >= self.min) & (x <= self.max), axis=1)
        if self.region == "band":
            if len(self.points[0]) == 3:
                return distance_to_polygon(x, self.points) <= self.half_width
            return distance_to_polyline(x, self.points) <= self.half_width
        out = np.zeros(len(x), dtype=bool)
        if self.is_mask:
            part = self._array[first:first + len(x)]
            out[:len(part)] = part
        else:
            index = self._array[(self._array >= first) & (self._array < first + len(x))]
            out[index - first] = True
        return out
