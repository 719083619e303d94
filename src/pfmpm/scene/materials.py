"""Materials (``[[materials]]``): a registry of constitutive models by name,
each with an optional phase-field fracture table (or, for the neo-Hookean
model, a damage table: :mod:`pfmpm.scene.damage`).

A material table's ``model`` key names its class in :data:`MATERIALS`
(default ``"linear_elastic"``).  The core's models declare their parameters
once, in C++ (name, kind, bounds, default, unit, meaning:
``pfmpm._core.material_models()``), and every class here checks its table
against that declaration (:class:`DeclaredMaterial`), takes its wave speeds
from the core object and writes its reference table into docs/scenes.md
(:func:`parameter_table`).  A core model with no class of its own here gets
one made from its declaration (:func:`declared_class`), so a new
constitutive model is one C++ file and one CMake line: scene files then
accept ``model = "<its name>"`` with its declared keys.  The classes written
out here add what a declaration cannot say: the phase-field coupling of
``linear_elastic`` and the damage table of ``neo_hookean``.  A model the
core does not have can still be registered (:func:`register_material`),
for scene checks alone.  The core object of a material is built from its
entry in one place, :func:`pfmpm.simulation.core_materials`.
"""

from __future__ import annotations

import abc
import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from .. import _core
from ..anisotropy import check_gamma
from . import declared
from .damage import DamageSpec
from .declared import check_declared, check_parameter, declaration, parameter
from .validation import SceneError, at, boolean, choice, integer, real, seq, store, text

if TYPE_CHECKING:
    from .scene import Scene

__all__ = ["PLANES", "SPLITS", "FRACTURE_MODELS", "SYMMETRIES", "MATERIALS",
           "DEFAULT_MODEL", "register_material", "material_class", "MaterialSpec", "DeclaredMaterial",
           "declaration", "declared_class", "parameter_table", "LinearElasticSpec", "NeoHookeanSpec",
           "FractureSpec", "Anisotropy", "wave_speed", "rayleigh_speed"]

PLANES = ("strain", "stress")
SPLITS = tuple(parameter(declaration("linear_elastic")["parameters"], "split")["choices"])
"""The energy splits (declared by the core's ``linear_elastic``)."""
FRACTURE_MODELS = tuple(parameter(declared.fracture_parameters(), "model")["choices"])
"""The phase-field models (declared by the core's fracture parameters)."""
SYMMETRIES = ("isotropic2", "isotropic4", "cubic", "orthotropic", "general")

MATERIALS: dict[str, type["MaterialSpec"]] = {}
"""Material classes by the ``model`` name scene files give them."""
DEFAULT_MODEL = "linear_elastic"
"""The model of a material table without a ``model`` key."""


def register_material(cls: type["MaterialSpec"]) -> type["MaterialSpec"]:
    """Class decorator: make ``cls`` the material model ``cls.model`` of scene files."""
    MATERIALS[cls.model] = cls
    return cls


def material_class(model: Any) -> type["MaterialSpec"]:
    """The registered class of a ``model`` name: its class here, or for a
    core model without one, the class made from its declaration.

    Raises
    ------
    SceneError
        Naming the key ``model`` and the registered names, if none has that name.
    """
    cls = MATERIALS.get(model) if isinstance(model, str) else None
    if cls is None:
        raise SceneError("model", "must be one of " + ", ".join(map(repr, MATERIALS)), model)
    return cls


@dataclass(frozen=True)
class Anisotropy:
    """Anisotropic surface energy: the tensor gamma of K&T eq. 6 in the material frame.

    gamma acts on the curvature ``kappa = (c_11, c_22, c_12)`` (the fourth-order
    term of K&T eq. 4 is ``l0^3 kappa^T gamma kappa``); the body's ``orientation``
    turns the material axes, and ``gamma_1111`` is the coefficient of a crack
    running along it. :mod:`pfmpm.anisotropy` gives the resulting ``G_c(theta)``.

    Parameters
    ----------
    symmetry : str
        ``"isotropic2"``: gamma = 0, the second-order functional (no keys).
        ``"isotropic4"``: ``g1111`` (default 1) with g2222 = g1111, g1122 = 0,
        g1212 = 2 g1111, so that ``G_c = G-bar_c sqrt(1 + sqrt(g1111))`` in
        every direction. ``"cubic"``: ``g1111`` (= g2222), ``g1212``,
        optional ``g1122``. ``"orthotropic"``: ``g1111``, ``g2222``,
        ``g1212``, optional ``g1122``. ``"general"``: ``gamma``, the full
        symmetric 3 x 3 Voigt matrix.
    g1111, g2222, g1122, g1212 : float
        Components of gamma, >= 0 (g1122 may be negative as long as gamma
        stays positive semi-definite).
    gamma : 3 x 3 nested sequence
        The whole matrix, for ``symmetry = "general"``.
    """

    symmetry: str
    g1111: float | None = None
    g2222: float | None = None
    g1122: float | None = None
    g1212: float | None = None
    gamma: tuple[tuple[float, ...], ...] | None = None

    _KEYS: ClassVar[dict[str, tuple[tuple[str, ...], tuple[str, ...]]]] = {
        # symmetry: (required keys, optional keys)
        "isotropic2": ((), ()),
        "isotropic4": ((), ("g1111",)),
        "cubic": (("g1111", "g1212"), ("g1122",)),
        "orthotropic": (("g1111", "g2222", "g1212"), ("g1122",)),
        "general": (("gamma",), ()),
    }

    def __post_init__(self):
        store(self, "symmetry", choice("symmetry", self.symmetry, SYMMETRIES))
        required, optional = self._KEYS[self.symmetry]
        for key in ("g1111", "g2222", "g1122", "g1212", "gamma"):
            value = getattr(self, key)
            if value is None and key in required:
                raise SceneError(key, f"required for symmetry {self.symmetry!r}")
            if value is not None and key not in required + optional:
                raise SceneError(key, f"not used by symmetry {self.symmetry!r} (it takes "
                                 + (", ".join(required + optional) or "no components") + ")")
        for key in ("g1111", "g2222", "g1212"):
            if getattr(self, key) is not None:
                store(self, key, real(key, getattr(self, key), ge=0))
        if self.g1122 is not None:
            store(self, "g1122", real("g1122", self.g1122))
        if self.gamma is not None:
            rows = seq("gamma", self.gamma, "3 rows of 3 numbers")
            if len(rows) != 3:
                raise SceneError("gamma", "must have 3 rows of 3 numbers", self.gamma)
            matrix = []
            for i, row in enumerate(rows):
                row = seq(f"gamma[{i}]", row, "3 numbers")
                if len(row) != 3:
                    raise SceneError(f"gamma[{i}]", "must have 3 numbers", row)
                matrix.append(tuple(real(f"gamma[{i}][{j}]", v) for j, v in enumerate(row)))
            store(self, "gamma", tuple(matrix))
        try:
            check_gamma(self.matrix())
        except ValueError as e:
            raise SceneError("gamma" if self.symmetry == "general" else "symmetry",
                             f"gamma {e}", self.matrix().tolist()) from None

    def matrix(self) -> np.ndarray:
        """gamma as a 3 x 3 array (material frame)."""
        if self.symmetry == "general":
            return np.array(self.gamma, dtype=float)
        if self.symmetry == "isotropic2":
            return np.zeros((3, 3))
        if self.symmetry == "isotropic4":
            g = 1.0 if self.g1111 is None else self.g1111
            return np.diag([g, g, 2.0 * g])
        g2222 = self.g1111 if self.symmetry == "cubic" else self.g2222
        g1122 = self.g1122 or 0.0
        return np.array([[self.g1111, g1122, 0.0], [g1122, g2222, 0.0], [0.0, 0.0, self.g1212]])

    @property
    def fourth_order(self) -> bool:
        """Whether gamma != 0."""
        return bool(np.any(self.matrix() != 0.0))


@dataclass(frozen=True)
class FractureSpec:
    """Phase-field fracture parameters of a material (its ``fracture`` table;
    K&T eqs. 4, 14-15); the core's ``Fracture`` is built from it.

    Parameters
    ----------
    model : str
        ``"AT2"`` (K&T eq. 4, the default) or ``"AT1"``: the local term
        of the crack density is ``w(d) = d^2`` or ``d`` with ``d = 1 - c``.  In
        the standard form ``(G_c / c_w) (w(d) / l + l |grad d|^2)`` both use
        ``l = 2 l0`` (docs/method.md); AT1 has an elastic threshold and a
        damage band of finite width, and needs the bound ``0 <= c <= 1``.
    bound : bool
        Solve the phase field with the bound ``0 <= c <= 1`` on its nodal
        values (the default, and AT1's only choice).  ``False`` gives AT2's
        unbounded solve of before, whose values undershoot below 0 next to a
        band of huge history.  The fourth-order functional is solved without
        it either way (docs/method.md).
    Gc : float
        Critical energy release rate, > 0; with a fourth-order ``anisotropy``
        it is the reference value G-bar_c of K&T eq. 8.
    l0 : float
        Length scale, > 0; the scene requires at least the grid spacing.
    k_f : float
        Residual stiffness in ``[0, 1)``: ``g(c) = (1 - k_f) c^2 + k_f``.
    split : str
        Which energy cracking degrades: ``"spectral"`` (Miehe, K&T eq. 14),
        ``"volumetric_deviatoric"`` (Amor) or ``"none"``.
    anisotropy : Anisotropy or None
        The tensor gamma of the fourth-order functional (K&T eqs. 4, 6); ``None``:
        the second-order isotropic functional.  AT2 only.
    """

    Gc: float
    l0: float
    k_f: float = 0.0
    split: str = "spectral"
    anisotropy: Anisotropy | None = None
    model: str = "AT2"
    bound: bool = True

    def __post_init__(self):
        for key in ("Gc", "l0", "k_f", "model"):
            store(self, key, check_declared(declared.fracture_parameters(), key, getattr(self, key)))
        store(self, "split", check_declared(declaration("linear_elastic")["parameters"], "split", self.split))
        if self.anisotropy is not None and not isinstance(self.anisotropy, Anisotropy):
            raise SceneError("anisotropy", "must be an anisotropy table", self.anisotropy)
        store(self, "bound", boolean("bound", self.bound))
        if self.model == "AT1" and not self.bound:
            raise SceneError("bound", "AT1 needs the bound 0 <= c <= 1", self.bound)
        if self.model == "AT1" and self.anisotropy is not None and self.anisotropy.fourth_order:
            raise SceneError("model", "AT1 is second order only: it cannot take a fourth-order"
                             f" anisotropy (symmetry {self.anisotropy.symmetry!r})", self.model)

    def gamma(self) -> np.ndarray:
        """gamma of K&T eq. 6 in the material frame (zero without anisotropy)."""
        return np.zeros((3, 3)) if self.anisotropy is None else self.anisotropy.matrix()


class MaterialSpec(abc.ABC):
    """What every material model of :data:`MATERIALS` declares.

    A model is a frozen dataclass deriving from this class, registered with
    :func:`register_material`, with at least these fields; the rest are its
    own parameters.

    Attributes
    ----------
    model : str
        The model's name in scene files (a class attribute).
    name : str
        Unique name, referenced by bodies.
    density : float
        Mass density, > 0.
    fracture : FractureSpec or None
        Phase-field parameters; ``None``: the material cannot crack, and its
        particles take no part in the phase-field solve.
    """

    model: ClassVar[str]
    name: str
    density: float
    fracture: FractureSpec | None

    @abc.abstractmethod
    def wave_speed(self, plane: str) -> float:
        """Largest (P-)wave speed in 2D, for the stable time step."""

    @abc.abstractmethod
    def rayleigh_speed(self) -> float:
        """Rayleigh wave speed, the limit of a running crack's speed."""

    @abc.abstractmethod
    def core_parameters(self, scene: "Scene") -> dict[str, float | str]:
        """The parameters of the core's model ``model`` (:func:`pfmpm._core.material`)
        in ``scene`` (its plane, its grid)."""

    def check_scene(self, scene: "Scene") -> None:
        """Check the material against the rest of the scene (the plane, the
        grid); a :class:`SceneError` names a key of the material's table.
        Nothing to check by default."""

    def solid(self) -> bool:
        """Whether the model runs in 3D too (else in plane strain or stress
        alone); not by default."""
        return False

    def initial_columns(self, scene: "Scene", volume: np.ndarray) -> dict[str, np.ndarray]:
        """Initial values of the core model's particle columns for this
        material's particles, by column name, given their initial volumes
        (in particle order); none by default."""
        return {}

    def _check_fracture(self) -> None:
        """Check the ``fracture`` field (for ``__post_init__``)."""
        if self.fracture is not None and not isinstance(self.fracture, FractureSpec):
            raise SceneError("fracture", "must be a fracture table", self.fracture)


class DeclaredMaterial(MaterialSpec):
    """A material whose parameters the core model ``model`` declares.

    The parameters a declaration sets from the material's own table
    (``set_by`` empty) are fields of the class, checked against their
    declared bounds or words; one set by the scene's ``plane`` takes its
    value; those set by a ``fracture`` or ``damage`` table are the class's
    own business (:meth:`core_parameters`).  The wave speeds are the core
    object's.
    """

    def _check_declared(self) -> None:
        """Check the name and the declared parameters of the table (for ``__post_init__``)."""
        store(self, "name", text("name", self.name))
        for p in _table_parameters(self.model):
            value = getattr(self, p["name"])
            if value is not None or p["default"] is not None:
                store(self, p["name"], check_parameter(p, value))

    def _values(self, plane: str) -> dict[str, float | str]:
        """The given values of the table's declared parameters, with ``plane``
        where the model declares one (a scene sets it)."""
        values = {p["name"]: getattr(self, p["name"]) for p in _table_parameters(self.model)
                  if getattr(self, p["name"]) is not None}
        if self._plane() is not None:
            values["plane"] = plane
        return values

    def _plane(self) -> dict | None:
        """The model's declared parameter set by the scene's ``plane``, or None."""
        return next((p for p in declaration(self.model)["parameters"] if p["set_by"] == "plane"), None)

    def _planes(self) -> tuple[str, ...]:
        """The planes the model takes (all, unless it declares ``plane`` with fewer)."""
        plane = self._plane()
        return PLANES if plane is None else tuple(plane["choices"])

    def wave_speed(self, plane: str) -> float:
        """P-wave speed of the undeformed material in ``plane``, the core model's."""
        return _core.material(self.model, self._values(plane)).wave_speed

    def rayleigh_speed(self) -> float:
        """Rayleigh wave speed of the undeformed material, the core model's."""
        return _core.material(self.model, self._values(self._planes()[0])).rayleigh_speed

    def solid(self) -> bool:
        """Whether the core's model runs in 3D too."""
        return _core.material(self.model, self._values(self._planes()[0])).solid

    def check_scene(self, scene: "Scene") -> None:
        """The scene's plane is one the model takes."""
        if scene.plane not in self._planes():
            raise SceneError("model", f"is plane {' or '.join(self._planes())} only"
                             f" (the scene has plane = {scene.plane!r})", self.model)

    def core_parameters(self, scene: "Scene") -> dict[str, float | str]:
        """The table's declared parameters, with the scene's plane where declared."""
        return self._values(scene.plane)


def _table_parameters(model: str) -> list[dict]:
    """The declared parameters of ``model`` that are keys of its material table."""
    return [p for p in declaration(model)["parameters"] if not p["set_by"]]


def declared_class(model: str) -> type[DeclaredMaterial]:
    """A frozen dataclass for the core model ``model`` made from its
    declaration: ``name``, each parameter of its table (the required ones
    first), and ``fracture``, which only a model that declares a phase-field
    coupling accepts."""
    d = declaration(model)
    table = _table_parameters(model)
    fields: list = [("name", str)]
    fields += [(p["name"], str if p["kind"] == "word" else float) for p in table
               if p["default"] is None and not p["optional"]]
    fields += [(p["name"], Any, dataclasses.field(default=p["default"])) for p in table
               if p["default"] is not None or p["optional"]]
    fields.append(("fracture", FractureSpec | None, dataclasses.field(default=None)))

    def __post_init__(self):
        self._check_declared()
        self._check_fracture()
        if self.fracture is not None and not d["phase_field"]:
            raise SceneError("fracture", f"the {model} model has no phase-field coupling")

    name = "".join(part.title() for part in model.split("_")) + "Spec"
    cls = dataclasses.make_dataclass(name, fields, bases=(DeclaredMaterial,), frozen=True,
                                     namespace={"model": model, "__post_init__": __post_init__,
                                                "__doc__": d["doc"], "__module__": __name__})
    return cls


def parameter_table(model: str) -> str:
    """The Markdown reference table of the core model ``model``'s parameters,
    from its declaration (docs/scenes.md)."""
    return declared.parameter_table(declaration(model)["parameters"])


@register_material
@dataclass(frozen=True)
class LinearElasticSpec(DeclaredMaterial):
    """Isotropic linear elasticity, small strain (``model = "linear_elastic"``).

    Parameters
    ----------
    name : str
        Unique name, referenced by bodies.
    E : float
        Young's modulus, > 0.
    nu : float
        Poisson's ratio, in ``(-1, 0.5)``.
    density : float
        Mass density, > 0.
    fracture : FractureSpec or None
        Phase-field parameters; ``None``: the material cannot crack.
    """

    model: ClassVar[str] = "linear_elastic"
    name: str
    E: float
    nu: float
    density: float
    fracture: FractureSpec | None = None

    def __post_init__(self):
        self._check_declared()
        self._check_fracture()

    def core_parameters(self, scene: "Scene") -> dict[str, float | str]:
        """E, nu, density, the plane and the energy split of the fracture table."""
        return {**self._values(scene.plane), "split": self.fracture.split if self.fracture else "none"}


@register_material
@dataclass(frozen=True)
class NeoHookeanSpec(DeclaredMaterial):
    """Compressible neo-Hookean elasticity in plane strain (``model =
    "neo_hookean"``; Homel & Herbold 2017, eq. 22) on the deformation gradient
    (H&H eq. 8), with an optional damage model.

    Parameters
    ----------
    name : str
        Unique name, referenced by bodies.
    E : float
        Young's modulus of the small-strain limit, > 0.
    nu : float
        Poisson's ratio, in ``(-1, 0.5)``.
    density : float
        Reference mass density, > 0.
    damage : DamageSpec or None
        :class:`~pfmpm.scene.damage.RankineSpec` or
        :class:`~pfmpm.scene.damage.TimeToFailureSpec`; ``None``: elastic.
    integration : str
        How F follows the velocity gradient: ``"euler"``, H&H eq. 8
        ``F <- (I + dt L) F`` (in ``substeps``), or ``"exponential"``,
        ``F <- exp(dt L) F``, exact for the step's L and so objective.
    substeps : int
        Sub-steps of H&H eq. 8 per step, >= 1 (1 with ``"exponential"``).
    fracture : None
        The model has no phase-field coupling yet: a fracture table is refused.
    """

    model: ClassVar[str] = "neo_hookean"
    name: str
    E: float
    nu: float
    density: float
    damage: DamageSpec | None = None
    integration: str = "euler"
    substeps: int = 1
    fracture: FractureSpec | None = None

    def __post_init__(self):
        self._check_declared()
        if self.damage is not None and not isinstance(self.damage, DamageSpec):
            raise SceneError("damage", "must be a damage table", self.damage)
        if self.integration == "exponential" and self.substeps != 1:
            raise SceneError("substeps", "must be 1 with integration = 'exponential'"
                             " (exact for the step's velocity gradient)", self.substeps)
        if self.fracture is not None:
            raise SceneError("fracture", "the neo_hookean model has no phase-field coupling yet;"
                             " give it a damage table instead")

    def check_scene(self, scene: "Scene") -> None:
        """Plane strain only (its declaration's); the damage parameters against the grid (l_ch)."""
        super().check_scene(scene)
        if self.damage is not None:
            with at("damage"):
                self.damage.check(self.E, scene.grid)

    def core_parameters(self, scene: "Scene") -> dict[str, float | str]:
        """E, nu, density, the integration of F, the plane and the damage parameters."""
        out = self._values(scene.plane)
        if self.damage is not None:
            out.update(self.damage.core_parameters(scene.grid))
        return out

    def initial_columns(self, scene: "Scene", volume: np.ndarray) -> dict[str, np.ndarray]:
        """With damage, the strength ``sigma_f`` of each particle (a Weibull
        field, H&H eq. 25, or the table's ``sigma_f``).

        Raises
        ------
        SceneError
            Naming ``damage.l_ch`` if the strongest particle's strength puts
            l_ch beyond its limit, or ``damage.weibull.m`` if the draws leave
            the floating-point range.
        """
        if self.damage is None:
            return {}
        with at("damage"):
            strength = self.damage.strengths(volume)
            if self.damage.weibull is not None and len(strength):
                self.damage.check(self.E, scene.grid, strongest=float(strength.max()))
        return {"sigma_f": strength}


def rayleigh_speed(E: float, nu: float, rho: float) -> float:
    """Rayleigh wave speed of an isotropic elastic solid: the core's (Viktorov's
    approximation ``c_s (0.862 + 1.14 nu) / (1 + nu)``)."""
    return _core.material("linear_elastic", {"E": E, "nu": nu, "density": rho}).rayleigh_speed


def wave_speed(E: float, nu: float, rho: float, plane: str) -> float:
    """P-wave speed of a linear elastic material in 2D: the core's
    ``linear_elastic`` model's, ``sqrt(E (1 - nu) / (rho (1 + nu) (1 - 2 nu)))``
    in plane strain and ``sqrt(E / (rho (1 - nu^2)))`` in plane stress.

    Raises
    ------
    SceneError
        Naming ``plane`` if it is neither ``"strain"`` nor ``"stress"``.
    """
    plane = choice("plane", plane, PLANES)
    return _core.material("linear_elastic", {"E": E, "nu": nu, "density": rho, "plane": plane}).wave_speed


for _model in declared.core_models():
    if _model not in MATERIALS:
        register_material(declared_class(_model))
