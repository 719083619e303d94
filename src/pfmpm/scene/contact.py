"""Multi-body frictional contact (``[contact]``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .validation import SceneError, real, seq, store, text

__all__ = ["ContactPair", "Contact"]


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


@dataclass(frozen=True)
class Contact:
    """Multi-body frictional contact: every body its own discrete field.

    With a ``[contact]`` table each body has its own velocity field (and its
    own phase field) on the shared grid, and bodies interact only through
    Coulomb frictional contact at the grid nodes they share (Kakouris &
    Triantafyllou 2019, eqs. 63-77). Without it, all bodies move as one
    continuum.

    Parameters
    ----------
    friction : float
        Coulomb coefficient mu_f between any two bodies, >= 0.
    pairs : sequence of ContactPair
        Per-pair coefficients replacing ``friction``.
    """

    friction: float = 0.0
    pairs: tuple[ContactPair, ...] = ()

    def __post_init__(self):
        store(self, "friction", real("friction", self.friction, ge=0))
        pairs = seq("pairs", self.pairs, "ContactPair")
        for i, pair in enumerate(pairs):
            if not isinstance(pair, ContactPair):
                raise SceneError(f"pairs[{i}]", "must be a ContactPair", pair)
        store(self, "pairs", pairs)

    def friction_matrix(self, bodies: tuple[str, ...]) -> np.ndarray:
        """Coefficients between every two bodies, shape (n, n), in the order of ``bodies``."""
        index = {name: i for i, name in enumerate(bodies)}
        mu = np.full((len(bodies), len(bodies)), self.friction)
        for pair in self.pairs:
            a, b = index[pair.bodies[0]], index[pair.bodies[1]]
            mu[a, b] = mu[b, a] = pair.friction
        return mu
