"""Frictional contact (``[contact]``): discrete fields per body, or fields
split by the damage-field gradient."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .declared import check_declared, damage_gradient_parameters, parameter
from .shapes import SHAPES, Shape
from .validation import SceneError, choice, real, seq, store, text

__all__ = ["ContactPair", "Contact", "PARTITIONS", "SURFACE_DETECTION"]

PARTITIONS = ("bodies", "damage_gradient")
"""Velocity-field partitions: every body its own field (Kakouris & Triantafyllou 2019),
or two fields per contact group split by the damage gradient (Homel & Herbold 2017)."""
SURFACE_DETECTION = ("none", "kernel_sum")
"""How surface particles are found at t = 0 (Homel & Herbold 2017, section 2.4)."""


def _default(name: str):
    """The core's default of the damage-gradient parameter ``name``."""
    return parameter(damage_gradient_parameters(), name)["default"]


PARTING = tuple(parameter(damage_gradient_parameters(), "parting")["choices"])
"""When a group's fields may part at a node: once its band has stopped softening, or by H&H eq. 21
alone (declared by the core, as the partition's other parameters)."""


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
        bodies = seq("bodies", self.bodies, "2 body names")
        if len(bodies) != 2:
            raise SceneError("bodies", "must be a list of 2 body names", self.bodies)
        store(self, "bodies", (text("bodies[0]", bodies[0]), text("bodies[1]", bodies[1])))
        if bodies[0] == bodies[1]:
            raise SceneError("bodies", "must name two different bodies", self.bodies)
        store(self, "friction", real("friction", self.friction, ge=0))


# The keys of the damage-gradient partition and their defaults: with
# partition = "bodies" each must keep its default.
_DAMAGE_KEYS = {"groups": (), "separability": _default("separability"), "kernel_radius": None,
                "skin": _default("skin"), "surface_detection": "none", "surface_threshold": 0.99,
                "surfaces": (), "phase_field_threshold": _default("phase_field_threshold"),
                "parting": _default("parting")}


@dataclass(frozen=True)
class Contact:
    """Frictional contact between velocity fields.

    With ``partition = "bodies"`` each body has its own velocity field (and
    its own phase field) on the shared grid, and bodies interact only through
    Coulomb frictional contact at the grid nodes they share (Kakouris &
    Triantafyllou 2019, eqs. 63-77). With ``partition = "damage_gradient"``
    each contact group (a body, or the bodies of an entry of ``groups``) has
    two fields, chosen per (particle, node) by the sign of the damage-field
    gradient (Homel & Herbold 2017, Algorithms 1-3): cracks and surfaces open,
    slide with friction and close again within one body. Without a
    ``[contact]`` table, all bodies move as one continuum.

    Parameters
    ----------
    friction : float
        Coulomb coefficient mu_f between any two bodies (groups), and on
        crack faces and surfaces within a group, >= 0.
    pairs : sequence of ContactPair
        Per-pair coefficients replacing ``friction`` (between the pair's
        groups with the damage gradient).
    partition : str
        ``"bodies"`` or ``"damage_gradient"``.
    touch_fill : float
        Two fields touch at a node, and may push or rub there, where their
        volumes at the node fill at least this fraction of its volume, in
        [0, 1]; 0 is the paper's contact, acting wherever the fields
        approach (docs/contact.md, "Touching").
    groups : sequence of sequences of str
        Damage gradient only: bodies that share a contact group (and meet
        through its two fields, surfaces and cracks); a body in no entry is
        its own group.
    separability : float
        Damage gradient only: D-bar_min of the separability test (H&H eq. 21),
        in (0, 1).
    kernel_radius : float or None
        Damage gradient only: kernel radius r_p of H&H eqs. 17-19, > 0; ``None``
        is the cell diagonal (the paper's choice).
    skin : float
        Damage gradient only: the neighbour lists' Verlet skin over r_p, > 0.
    surface_detection : str
        Damage gradient only: ``"kernel_sum"`` flags the particles whose
        kernel sum over their own body is below ``surface_threshold`` times
        the lattice interior's at t = 0 (section 2.4); ``"none"`` flags none
        but those in ``surfaces``.
    surface_threshold : float
        Damage gradient only: in (0, 1).
    surfaces : sequence of Shape
        Damage gradient only: particles inside any of these shapes at t = 0
        are surface particles.
    phase_field_threshold : float
        Damage gradient only: a particle of a phase-field material is fully
        damaged at c <= this, in [0, 1) (a damage model's at D >= 1 - 1e-4).
    parting : str
        Damage gradient only: when a group's fields may part at a node.
        ``"softened"`` (the default): by H&H eq. 21 once no particle of a damage
        model mapping there is still softening, so that the band dissipates
        G_f before its faces part (docs/contact.md, "Parting"); ``"failed"``:
        by H&H eq. 21 alone, as the paper, once a fully damaged particle maps
        there.
    """

    friction: float = 0.0
    pairs: tuple[ContactPair, ...] = ()
    partition: str = "bodies"
    touch_fill: float = 0.9
    groups: tuple[tuple[str, ...], ...] = ()
    separability: float = _default("separability")
    kernel_radius: float | None = None
    skin: float = _default("skin")
    surface_detection: str = "none"
    surface_threshold: float = 0.99
    surfaces: tuple[Shape, ...] = ()
    phase_field_threshold: float = _default("phase_field_threshold")
    parting: str = _default("parting")

    def __post_init__(self):
        store(self, "friction", real("friction", self.friction, ge=0))
        pairs = seq("pairs", self.pairs, "ContactPair")
        for i, pair in enumerate(pairs):
            if not isinstance(pair, ContactPair):
                raise SceneError(f"pairs[{i}]", "must be a ContactPair", pair)
        store(self, "pairs", pairs)
        store(self, "partition", choice("partition", self.partition, PARTITIONS))
        store(self, "touch_fill", real("touch_fill", self.touch_fill, ge=0, le=1))
        groups = seq("groups", self.groups, "lists of body names")
        checked = []
        for i, group in enumerate(groups):
            names = seq(f"groups[{i}]", group, "body names")
            if not names:
                raise SceneError(f"groups[{i}]", "must name at least one body", group)
            checked.append(tuple(text(f"groups[{i}][{k}]", n) for k, n in enumerate(names)))
        store(self, "groups", tuple(checked))
        declared = damage_gradient_parameters()
        for key in ("separability", "skin", "phase_field_threshold", "parting"):
            store(self, key, check_declared(declared, key, getattr(self, key)))
        if self.kernel_radius is not None:
            store(self, "kernel_radius", real("kernel_radius", self.kernel_radius, gt=0))
        store(self, "surface_detection",
              choice("surface_detection", self.surface_detection, SURFACE_DETECTION))
        store(self, "surface_threshold",
              real("surface_threshold", self.surface_threshold, gt=0, lt=1))
        surfaces = seq("surfaces", self.surfaces, "shapes")
        for i, shape in enumerate(surfaces):
            if not isinstance(shape, Shape):
                raise SceneError(f"surfaces[{i}]", "must be a shape (" + ", ".join(SHAPES) + ")",
                                 shape)
        store(self, "surfaces", surfaces)
        if self.partition != "damage_gradient":
            for key, default in _DAMAGE_KEYS.items():
                if getattr(self, key) != default:
                    raise SceneError(key, 'needs partition = "damage_gradient"', getattr(self, key))

    @property
    def damage_gradient(self) -> bool:
        """Whether the fields are split by the damage gradient."""
        return self.partition == "damage_gradient"

    def group_indices(self, bodies: tuple[str, ...]) -> list[int]:
        """Contact group of each body, in the order of ``bodies``: the groups of
        ``groups`` first, in their order, then each remaining body its own."""
        group: dict[str, int] = {}
        for i, names in enumerate(self.groups):
            for name in names:
                group[name] = i
        count = len(self.groups)
        out = []
        for name in bodies:
            if name not in group:
                group[name] = count
                count += 1
            out.append(group[name])
        return out

    def friction_matrix(self, bodies: tuple[str, ...]) -> np.ndarray:
        """Coefficients between every two fields, shape (n, n): between bodies in the
        order of ``bodies``, or with the damage gradient between contact groups."""
        if not self.damage_gradient:
            index = {name: i for i, name in enumerate(bodies)}
            mu = np.full((len(bodies), len(bodies)), self.friction)
        else:
            index = dict(zip(bodies, self.group_indices(bodies)))
            n = max(index.values()) + 1
            mu = np.full((n, n), self.friction)
        for pair in self.pairs:
            a, b = index[pair.bodies[0]], index[pair.bodies[1]]
            mu[a, b] = mu[b, a] = pair.friction
        return mu

    def resolved_radius(self, h: float, dim: int) -> float:
        """The kernel radius r_p on a ``dim``-dimensional grid of cell side ``h``:
        ``kernel_radius``, or the cell diagonal sqrt(dim) h."""
        return self.kernel_radius if self.kernel_radius is not None else math.sqrt(dim) * h
