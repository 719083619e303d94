"""Scenes as nested dicts and TOML files: building the scene classes from
tables, writing them back (as dicts and as TOML text), and ``--set`` overrides."""

from __future__ import annotations

import copy
import dataclasses
import json
import math
import tomllib
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from .bodies import Body
from .components import GridSpec, Output, PhaseFieldSpec, Time, TransferSpec
from .contact import Contact, ContactPair
from .loads import AMPLITUDES, LOADS, Crack, Prescribed, WallSpec
from .damage import DamageSpec, InitialDamage, WeibullSpec, damage_class
from .materials import DEFAULT_MODEL, Anisotropy, FractureSpec, MaterialSpec, material_class
from .shapes import SHAPES
from .validation import SceneError, at, fmt, key_text

__all__ = ["build_scene", "read_toml", "plain", "toml_text", "apply_overrides"]


def build_scene(cls: type, d: Any, overrides: list[str] | tuple[str, ...] = ()) -> Any:
    """Build a scene of class ``cls`` from a nested dict (as parsed from TOML).

    Parameters
    ----------
    cls : type
        :class:`~pfmpm.scene.Scene`.
    d : Mapping
        The scene tables.
    overrides : sequence of str
        ``"dotted.path=value"`` overrides applied first, see :func:`apply_overrides`.

    Raises
    ------
    SceneError
        On unknown or missing keys and any invalid value.
    """
    if overrides:
        d = apply_overrides(d, list(overrides))
    return _build(cls, d, {
        "grid": lambda t: _build(GridSpec, t),
        "time": lambda t: _build(Time, t),
        "output": lambda t: _build(Output, t),
        "materials": lambda v: _tables(v, _material),
        "bodies": lambda v: _tables(v, _body),
        "loads": lambda v: _tables(v, lambda t: _typed(t, LOADS, {"amplitude": lambda a: _typed(a, AMPLITUDES)})),
        "walls": lambda v: _tables(v, lambda t: _build(WallSpec, t)),
        "prescribed": lambda v: _tables(v, lambda t: _build(Prescribed, t,
                                                             {"amplitude": lambda a: _typed(a, AMPLITUDES)})),
        "cracks": lambda v: _tables(v, lambda t: _build(Crack, t)),
        "initial_damage": lambda v: _tables(v, lambda t: _build(InitialDamage, t)),
        "phase_field": lambda t: _build(PhaseFieldSpec, t),
        "transfer": lambda t: _build(TransferSpec, t),
        "contact": lambda t: _build(Contact, t, {
            "pairs": lambda v: _tables(v, lambda p: _build(ContactPair, p)),
            "surfaces": lambda v: _tables(v, lambda t: _typed(t, SHAPES))}),
    })


def read_toml(path: Path | str) -> dict:
    """The tables of a TOML scene file, the ``file`` of each mesh or image
    shape made relative to the file's folder.

    Raises
    ------
    SceneError
        On a TOML syntax error, text that is not UTF-8, or a directory
        (path = the file).
    OSError
        If the file cannot be read.
    """
    if Path(path).is_dir():
        raise SceneError(str(path), "is a directory, not a scene file")
    with open(path, "rb") as f:
        try:
            tables = tomllib.load(f)
        except tomllib.TOMLDecodeError as err:
            raise SceneError(str(path), f"invalid TOML: {err}") from None
        except UnicodeDecodeError as err:
            raise SceneError(str(path), f"not UTF-8 text, as TOML must be (byte {err.start})") from None
    _files_from(tables, Path(path).parent)
    return tables


def _files_from(tables: dict, folder: Path) -> None:
    """Make the relative ``file`` of every body's shape and holes (mesh and
    image shapes, also those an extrusion extrudes) relative to ``folder``,
    the scene file's."""
    bodies = tables.get("bodies")
    for body in bodies if isinstance(bodies, list) else ():
        if not isinstance(body, dict):
            continue
        holes = body.get("holes")
        for shape in [body.get("shape"), *(holes if isinstance(holes, list) else ())]:
            while isinstance(shape, dict):
                if isinstance(shape.get("file"), str) and shape["file"]:
                    shape["file"] = str(folder / shape["file"])
                shape = shape.get("shape")  # the 2D shape of an extrusion


def plain(value: Any) -> Any:
    """Convert scene objects and tuples to TOML-ready dicts and lists (None fields omitted).

    Shapes and loads get their ``type`` key, materials and damage tables their ``model`` key.
    """
    if dataclasses.is_dataclass(value):
        if isinstance(value, (MaterialSpec, DamageSpec)):
            out = {"model": value.model}
        else:
            out = {"type": value.kind} if hasattr(value, "kind") else {}
        for f in dataclasses.fields(value):
            item = getattr(value, f.name)
            if item is not None:
                out[f.name] = plain(item)
        return out
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    return value


def toml_text(tables: Mapping[str, Any]) -> str:
    """TOML text of a scene dict (:func:`plain`) that :func:`read_toml` reads
    back as the same dict: every float written with all its digits, the
    settings tables as ``[table]``, arrays of tables as ``[[array]]`` and the
    tables within those (shapes, fracture) inline."""
    lines = [f"{key_text(k)} = {_toml_value(v)}" for k, v in tables.items() if not _is_table(v)]
    for key, value in tables.items():
        if isinstance(value, Mapping):
            lines += ["", f"[{key_text(key)}]"]
            lines += [f"{key_text(k)} = {_toml_value(v)}" for k, v in value.items()]
        elif _is_table(value):
            for entry in value:
                lines += ["", f"[[{key_text(key)}]]"]
                lines += [f"{key_text(k)} = {_toml_value(v)}" for k, v in entry.items()]
    return "\n".join(lines) + "\n"


def _is_table(value: Any) -> bool:
    """Whether a top-level value is written as a table or an array of tables."""
    return isinstance(value, Mapping) or (
        isinstance(value, (list, tuple)) and bool(value) and all(isinstance(v, Mapping) for v in value))


def _toml_value(value: Any) -> str:
    """A TOML value, inline."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(float(value)) if math.isfinite(value) else "nan" if math.isnan(value) else repr(float(value))
    if isinstance(value, str):  # a TOML basic string: JSON's escapes, and DEL escaped too
        return json.dumps(value, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(value, Mapping):
        return "{ " + ", ".join(f"{key_text(k)} = {_toml_value(v)}" for k, v in value.items()) + " }"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"{value!r}: no TOML value for a {type(value).__name__}")


def _check_keys(table: Any, cls: type, extra: tuple[str, ...] = ()) -> None:
    """Check a table for unknown keys and missing required fields of ``cls``."""
    if not isinstance(table, Mapping):
        raise SceneError("", "must be a table", table)
    fields = dataclasses.fields(cls)
    allowed = [*extra, *(f.name for f in fields)]
    for key in table:
        if key not in allowed:
            raise SceneError(key_text(key), f"unknown key (allowed: {', '.join(allowed)})")
    for f in fields:
        no_default = f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
        if no_default and f.name not in table:
            raise SceneError(f.name, "missing required key")


def _build(cls: type, table: Any, convert: Mapping[str, Callable[[Any], Any]] | None = None,
           extra: tuple[str, ...] = ()) -> Any:
    """Construct ``cls`` from a table after checking its keys.

    ``convert`` maps keys to converters for nested tables; ``extra`` are
    allowed keys that are not fields (e.g. ``type``) and are dropped.
    """
    _check_keys(table, cls, extra)
    kwargs = {k: v for k, v in table.items() if k not in extra}
    for key, fn in (convert or {}).items():
        if key in kwargs:
            with at(key):
                kwargs[key] = fn(kwargs[key])
    return cls(**kwargs)


def _tables(value: Any, build: Callable[[Any], Any]) -> tuple:
    """Build each table of an array of tables."""
    if not isinstance(value, (list, tuple)):
        raise SceneError("", "must be an array of tables", value)
    items = []
    for i, table in enumerate(value):
        with at(f"[{i}]"):
            items.append(build(table))
    return tuple(items)


def _typed(table: Any, classes: Mapping[str, type],
           convert: Mapping[str, Callable[[Any], Any]] | None = None) -> Any:
    """Build a table whose ``type`` key selects the class among ``classes``
    (``convert`` as for :func:`_build`)."""
    if not isinstance(table, Mapping):
        raise SceneError("", "must be a table", table)
    if "type" not in table:
        raise SceneError("type", "missing required key")
    cls = classes.get(table["type"]) if isinstance(table["type"], str) else None
    if cls is None:
        raise SceneError("type", "must be one of " + ", ".join(map(repr, classes)), table["type"])
    return _build(cls, table, convert, extra=("type",))


def _material(table: Any) -> MaterialSpec:
    """Build a material: its ``model`` key (default ``linear_elastic``) selects the class."""
    if not isinstance(table, Mapping):
        raise SceneError("", "must be a table", table)
    cls = material_class(table.get("model", DEFAULT_MODEL))
    return _build(cls, table, {
        "fracture": lambda f: _build(FractureSpec, f, {"anisotropy": lambda a: _build(Anisotropy, a)}),
        "damage": _damage,
    }, extra=("model",))


def _damage(table: Any) -> Any:
    """Build a damage table: its ``model`` key selects the class (:data:`DAMAGE_MODELS`)."""
    if not isinstance(table, Mapping):
        raise SceneError("", "must be a table", table)
    if "model" not in table:
        raise SceneError("model", "missing required key")
    return _build(damage_class(table["model"]), table,
                  {"weibull": lambda w: _build(WeibullSpec, w)}, extra=("model",))


def _shape(table: Any) -> Any:
    """Build a shape: its ``type`` key selects the class, and an extrusion's
    ``shape`` is a shape table in turn."""
    return _typed(table, SHAPES, {"shape": _shape})


def _body(table: Any) -> Body:
    """Build a :class:`Body`, converting its shape and holes tables."""
    return _build(Body, table, {
        "shape": _shape,
        "holes": lambda v: _tables(v, _shape),
    })


def apply_overrides(d: Mapping, overrides: list[str]) -> dict:
    """Apply ``"dotted.path=value"`` overrides to a copy of a scene dict.

    Parameters
    ----------
    d : Mapping
        Scene dict (left unchanged).
    overrides : list of str
        Each ``"a.b.c=value"``.  ``value`` is parsed as a TOML value, or
        taken as a plain string if it does not parse.  A segment into an
        array of tables selects an entry by integer index or by its
        ``name``; a segment naming a missing table creates it.  Keys
        unknown to the schema are reported by validation.

    Returns
    -------
    dict
        The overridden deep copy.

    Raises
    ------
    SceneError
        On a malformed override or a path that cannot be followed.
    """
    if not isinstance(d, Mapping):
        raise SceneError("", "must be a table", d)
    root = copy.deepcopy(dict(d))
    for override in overrides:
        key, sep, raw = override.partition("=")
        key, raw = key.strip(), raw.strip()
        segments = key.split(".")
        if not sep or not all(segments):
            raise SceneError("--set", "expected 'dotted.path=value'", override)
        try:
            parsed = tomllib.loads("v = " + raw)
            value = parsed["v"] if len(parsed) == 1 else raw
        except tomllib.TOMLDecodeError:
            value = raw
        node: Any = root
        for depth, segment in enumerate(segments):
            path = ".".join(map(key_text, segments[:depth]))
            last = depth == len(segments) - 1
            if isinstance(node, list):
                index = _entry(node, segment, ".".join(map(key_text, segments[: depth + 1])))
                if last:
                    node[index] = value
                else:
                    node = node[index]
            elif isinstance(node, dict):
                if last:
                    node[segment] = value
                else:
                    node = node.setdefault(segment, {})
            else:
                raise SceneError(path, "is not a table, cannot set " + fmt(key), node)
    return root


def _entry(items: list, segment: str, path: str) -> int:
    """Index of the array entry selected by an integer index or a ``name``."""
    try:
        index = int(segment)
    except ValueError:
        names = [t.get("name") if isinstance(t, Mapping) else None for t in items]
        if segment not in names:
            have = ", ".join(repr(n) for n in names if n is not None) or "none"
            raise SceneError(path, f"no entry with that name (have: {have})") from None
        return names.index(segment)
    if not -len(items) <= index < len(items):
        raise SceneError(path, f"index out of range ({len(items)} entries)")
    return index
