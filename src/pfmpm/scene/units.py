"""Unit systems a scene can declare (its top-level ``units`` key): the labels
of plots and the sanity check of its wave speeds.

The solver itself is unit-free: every number of a scene is read in one
consistent set of units.  Declaring which one lets pfmpm put units on the axes
of its figures and refuse a material whose wave speed no solid has in those
units (Young's modulus given in Pa in an mm-us-MPa scene, a density in the
wrong units), which would otherwise run for hours or fail hundreds of steps
later as a particle leaving the grid.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["UnitSystem", "UNIT_SYSTEMS", "NO_UNITS", "SOLID_WAVE_SPEEDS", "unit_system"]

SOLID_WAVE_SPEEDS = (1.0, 20000.0)
"""P-wave speeds (m/s) a solid can have: from soft gels (about 1 m/s, E of a
few kPa) to diamond (about 18 km/s)."""


@dataclass(frozen=True)
class UnitSystem:
    """A consistent set of units, each written as a plot label shows it.

    Parameters
    ----------
    name : str
        The value of the scene's ``units`` key; ``""`` for undeclared units.
    length, time, mass, force, stress, energy : str
        The unit of each quantity.  Density is mass / length^3, speed
        length / time, fracture energy force / length.
    speed_si : float
        The speed unit in m/s (for the check against :data:`SOLID_WAVE_SPEEDS`).
    """

    name: str
    length: str
    time: str
    mass: str
    force: str
    stress: str
    energy: str
    speed_si: float

    @property
    def declared(self) -> bool:
        """Whether the scene declared its units."""
        return bool(self.name)

    @property
    def speed(self) -> str:
        """The unit of speed."""
        return f"{self.length}/{self.time}" if self.declared else ""

    @property
    def density(self) -> str:
        """The unit of density."""
        return f"{self.mass}/{self.length}^3" if self.declared else ""

    def label(self, text: str, quantity: str) -> str:
        """An axis label: ``text`` and the unit of ``quantity`` in brackets.

        ``quantity`` is one of ``length``, ``time``, ``energy``, ``speed``,
        ``stress``, ``force``, ``mass``, ``density``.  Undeclared units
        read ``[scene units]``.
        """
        return f"{text} [{self.unit(quantity)}]"

    def unit(self, quantity: str) -> str:
        """The unit of ``quantity`` (as for :meth:`label`); ``scene units``
        where the scene declares none."""
        return getattr(self, quantity) if self.declared else "scene units"


NO_UNITS = UnitSystem("", "", "", "", "", "", "", 0.0)
"""The unit system of a scene that declares none: labels say "scene units"."""

UNIT_SYSTEMS: dict[str, UnitSystem] = {s.name: s for s in (
    UnitSystem("m-s-Pa", "m", "s", "kg", "N", "Pa", "J", 1.0),
    UnitSystem("mm-s-MPa", "mm", "s", "t", "N", "MPa", "N mm", 1e-3),
    UnitSystem("mm-ms-MPa", "mm", "ms", "g", "N", "MPa", "N mm", 1.0),
    UnitSystem("mm-us-MPa", "mm", "µs", "µg", "N", "MPa", "N mm", 1e3),
)}
"""The unit systems a scene's ``units`` key can name.  Each is consistent:
force = mass length / time^2 and stress = force / length^2, so mm-us-MPa
has its mass in micrograms (a density of 2450 µg/mm^3 is 2450 kg/m^3)."""


def unit_system(name: str) -> UnitSystem:
    """The :class:`UnitSystem` of a ``units`` value (``""``: :data:`NO_UNITS`)."""
    return UNIT_SYSTEMS[name] if name else NO_UNITS
