"""Damage models of a material (its ``damage`` table): the scalar damage of
Homel & Herbold (2017, §2.7), D = 0 intact to 1 failed, which degrades the
tensile principal stresses (eqs. 26-27).

``model`` selects the class in :data:`DAMAGE_MODELS`:

``"rankine"`` (:class:`RankineSpec`)
    Rankine damage with linear strain softening (eq. 23).
``"time_to_failure"`` (:class:`TimeToFailureSpec`)
    D grows at 1 / tau, tau = l / c_f, while the strength is exceeded (eq. 24).

Either takes an optional ``weibull`` table (:class:`WeibullSpec`): a strength
drawn per particle (eq. 25).
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .validation import SceneError, integer, real, store

__all__ = ["DAMAGE_MODELS", "damage_class", "DamageSpec", "RankineSpec", "TimeToFailureSpec",
           "WeibullSpec", "cell_diagonal"]

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


def cell_diagonal(h: float) -> float:
    """The cell diagonal sqrt(2) h of the 2D grid: the default l_ch (H&H §2.7)."""
    return math.sqrt(2.0) * h


@dataclass(frozen=True)
class WeibullSpec:
    """Weibull strength per particle (eq. 25):
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
        """One strength per particle of ``volume`` (eq. 25), in particle order.

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
        Characteristic length; ``None``: the cell diagonal.
    weibull : WeibullSpec or None
        A strength per particle (eq. 25); ``None``: ``sigma_f`` everywhere.
    """

    model: ClassVar[str]
    sigma_f: float
    l_ch: float | None
    weibull: WeibullSpec | None

    def length(self, h: float) -> float:
        """l_ch, or the cell diagonal of a grid of spacing ``h``."""
        return self.l_ch if self.l_ch is not None else cell_diagonal(h)

    @abc.abstractmethod
    def core_parameters(self, h: float) -> dict[str, float | str]:
        """The damage parameters of the core's ``neo_hookean`` model."""

    def check(self, E: float, h: float, strongest: float | None = None) -> None:
        """Check the parameters against the grid (and the strongest particle's
        strength of a Weibull field); nothing to check by default."""

    def _check_common(self) -> None:
        store(self, "sigma_f", real("sigma_f", self.sigma_f, gt=0))
        if self.l_ch is not None:
            store(self, "l_ch", real("l_ch", self.l_ch, gt=0))
        if self.weibull is not None and not isinstance(self.weibull, WeibullSpec):
            raise SceneError("weibull", "must be a weibull table", self.weibull)

    def strengths(self, volume: np.ndarray) -> np.ndarray:
        """The strength of each particle of initial ``volume``: the Weibull
        draws (eq. 25), or ``sigma_f``."""
        if self.weibull is None:
            return np.full(len(volume), self.sigma_f)
        return self.weibull.draw(self.sigma_f, volume)


@_register
@dataclass(frozen=True)
class RankineSpec(DamageSpec):
    """Rankine damage with linear strain softening (eq. 23, Cervera's form):
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
        Characteristic length, > 0 and < 2 E Gf / sigma_f^2; default the cell
        diagonal.
    weibull : WeibullSpec or None
    """

    model: ClassVar[str] = "rankine"
    sigma_f: float
    Gf: float
    l_ch: float | None = None
    weibull: WeibullSpec | None = None

    def __post_init__(self):
        self._check_common()
        store(self, "Gf", real("Gf", self.Gf, gt=0))

    def core_parameters(self, h: float) -> dict[str, float | str]:
        return {"damage": self.model, "sigma_f": self.sigma_f, "Gf": self.Gf, "l_ch": self.length(h)}

    def check(self, E: float, h: float, strongest: float | None = None) -> None:
        """l_ch < 2 E Gf / sigma_f^2 for the strongest particle, or the softening snaps back."""
        sigma = self.sigma_f if strongest is None else strongest
        limit = 2.0 * E * self.Gf / sigma / sigma  # sigma**2 would overflow
        length = self.length(h)
        if not length < limit:
            what = "" if strongest is None else f" of the strongest particle (sigma_f = {sigma:.6g})"
            default = " (the default, the cell diagonal)" if self.l_ch is None else ""
            raise SceneError("l_ch", f"must be < 2 E Gf / sigma_f^2 = {limit:.6g}{what}, or the"
                             f" softening of eq. 23 snaps back{default}", length)


@_register
@dataclass(frozen=True)
class TimeToFailureSpec(DamageSpec):
    """Time-to-failure damage (eq. 24): ``D += dt / tau``, ``tau = l_ch / c_f``,
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
        store(self, "c_f", real("c_f", self.c_f, gt=0))

    def core_parameters(self, h: float) -> dict[str, float | str]:
        return {"damage": self.model, "sigma_f": self.sigma_f, "c_f": self.c_f, "l_ch": self.length(h)}
