"""The parameters the core declares once, in C++ (``ParameterSpec``): the
material models' (``pfmpm._core.material_models()``), the phase field's
(``pfmpm._core.fracture_parameters()``), the phase-field solve's
(``pfmpm._core.phase_field_parameters()``) and the damage-gradient partition's
(``pfmpm._core.damage_gradient_parameters()``), and the check of a scene value
against its declaration, with the one-line messages of
:mod:`pfmpm.scene.validation`."""

from __future__ import annotations

import functools
from typing import Any

from .. import _core
from .validation import SceneError, choice, integer, real

__all__ = ["core_models", "declaration", "fracture_parameters", "phase_field_parameters",
           "damage_gradient_parameters",
           "parameter", "check_parameter", "check_declared", "parameter_table"]


@functools.cache
def core_models() -> dict[str, dict]:
    """The core's material models with their declarations."""
    return _core.material_models()


def declaration(model: str) -> dict:
    """The core's declaration of the material model ``model``: ``doc``,
    ``phase_field`` and ``parameters`` (see ``pfmpm._core.material_models``).

    Raises
    ------
    KeyError
        If the core has no such model.
    """
    return core_models()[model]


@functools.cache
def fracture_parameters() -> tuple[dict, ...]:
    """The declared parameters of a material's ``fracture`` table (the phase field's)."""
    return tuple(_core.fracture_parameters())


@functools.cache
def phase_field_parameters() -> tuple[dict, ...]:
    """The declared parameters of the phase-field solve (``[phase_field]``)."""
    return tuple(_core.phase_field_parameters())


@functools.cache
def damage_gradient_parameters() -> tuple[dict, ...]:
    """The declared parameters of the damage-gradient partition (``[contact]``
    keys with ``partition = "damage_gradient"``)."""
    return tuple(_core.damage_gradient_parameters())


def check_parameter(p: dict, value: Any) -> Any:
    """``value`` checked against the declared parameter ``p`` (its bounds
    or its words), normalised; a :class:`SceneError` names it."""
    name = p["name"]
    if p["kind"] == "word":
        return choice(name, value, tuple(p["choices"]))
    bounds = {("gt" if p["lower_open"] else "ge"): p["lower"], ("lt" if p["upper_open"] else "le"): p["upper"]}
    bounds = {k: v for k, v in bounds.items() if v is not None}
    if p["kind"] == "number":
        return real(name, value, **bounds)
    value = integer(name, value)
    if p["lower"] is not None:
        value = integer(name, value, ge=int(p["lower"]))
    if p["upper"] is not None and value > p["upper"]:
        raise SceneError(name, f"must be <= {int(p['upper'])}", value)
    return value


def parameter(parameters, name: str) -> dict:
    """The declared parameter called ``name`` among ``parameters``."""
    for p in parameters:
        if p["name"] == name:
            return p
    raise KeyError(f"no parameter {name} is declared")


def check_declared(parameters, name: str, value: Any) -> Any:
    """``value`` checked against the parameter called ``name`` among ``parameters``
    (declared dicts)."""
    return check_parameter(parameter(parameters, name), value)


def parameter_table(parameters) -> str:
    """The Markdown reference table of declared ``parameters``: key, what it
    is, unit, rule and default (docs/scenes.md)."""
    rows = ["| key | meaning | unit | rule | default |", "|---|---|---|---|---|"]
    for p in parameters:
        if p["kind"] == "word":
            rule = " or ".join(f"`{c}`" for c in p["choices"])
        else:
            parts = [f"{'>' if p['lower_open'] else '>='} {p['lower']:g}" if p["lower"] is not None else "",
                     f"{'<' if p['upper_open'] else '<='} {p['upper']:g}" if p["upper"] is not None else ""]
            rule = ("whole, " if p["kind"] == "integer" else "") + ", ".join(x for x in parts if x)
        key = f"`{p['name']}`" if not p["set_by"] else f"`{p['name']}` (from `{p['set_by']}`)"
        default = ("required" if p["default"] is None and not p["optional"]
                   else "as needed" if p["default"] is None else f"`{p['default']}`")
        rows.append(f"| {key} | {p['doc']} | {p['unit'] or '-'} | {rule or '-'} | {default} |")
    return "\n".join(rows)
