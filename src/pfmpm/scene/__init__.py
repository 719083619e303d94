"""Scene declaration for pfmpm: what a run is made of, validated.

A scene describes one explicit MPM run, in 2D or 3D: the background grid, the time
interval, the output cadence, the materials, the bodies (shapes filled with
particles), the loads and the grid walls.  Scenes are written in TOML (see
``docs/scenes.md``) or built directly from the classes below; both routes run
the same validation and report the first problem as a :class:`SceneError`
whose one-line message names the offending key path, e.g.::

    materials[0].E = -5.0: must be > 0
    grid.hx: unknown key (allowed: size, h, origin, degree)

Units are any consistent set (typically mm, µs, µg, N, MPa); the scene's
``units`` key declares which (:mod:`~pfmpm.scene.units`).

The modules, one concern each:

``scene``
    :class:`Scene`: the parts put together and the checks across them.
``components``
    The settings tables: :class:`GridSpec`, :class:`Time`, :class:`Output`,
    :class:`PhaseFieldSpec`, :class:`TransferSpec`.
``shapes``, ``bodies``
    :class:`Rectangle`, :class:`Disk`, :class:`Ring`, :class:`Polygon`,
    :class:`MeshShape` (the cells of a mesh file), :class:`ImageShape` (the
    pixels of one colour of a PNG mask); in 3D :class:`Box`, :class:`Sphere`,
    :class:`Cylinder`, :class:`MeshShape` (of a file with tetrahedra or
    hexahedra) and :class:`Extrusion` (of a 2D shape along z); :class:`Body`.
``loads``
    :class:`Traction`, :class:`BodyForce` and their amplitudes over time,
    :class:`Ramp` and :class:`Table`; :class:`WallSpec`; :class:`Prescribed`
    (motion of a box of grid nodes); :class:`Crack`.
``contact``
    :class:`Contact`, :class:`ContactPair`.
``materials``
    The registry :data:`MATERIALS` of constitutive models by name
    (:func:`register_material`), :class:`LinearElasticSpec`,
    :class:`NeoHookeanSpec`, and the fracture table :class:`FractureSpec`
    with its :class:`Anisotropy`.
``damage``
    The damage tables of the neo-Hookean model: :class:`RankineSpec`,
    :class:`TimeToFailureSpec`, with a :class:`WeibullSpec` strength field;
    and the scene's damage at t = 0, :class:`InitialDamage`
    (``[[initial_damage]]``: a box, a band along a polyline (in 3D a patch over a planar polygon), or particles).
``validation``
    :class:`SceneError` and the value checkers.
``seeding``, ``stability``
    The particle lattices; wave speeds, the stable step and the critical length.
``toml``
    Dicts and TOML files, and ``--set`` overrides (:func:`apply_overrides`).

Classes that declare something the C++ core also has a class for end in
``Spec`` (``GridSpec`` for ``pfmpm._core.Grid``, ...); the TOML keys are the
same as before.  The README, the docs and the notebooks use these names; the
names they had before (``Grid``, ``Wall``, ``Fracture``, ``PhaseField``, and
``Material`` for the linear elastic model) are kept for scripts written
against them.
"""

from .bodies import Body
from .components import DEGREES, TRANSFER_SCHEMES, GridSpec, Output, PhaseFieldSpec, Time, TransferSpec
from .contact import Contact, ContactPair
from .loads import (AMPLITUDES, EDGES, LOADS, SIDES, SIDES_3D, WALL_TYPES, BodyForce, Crack, Prescribed, Ramp,
                    Table, Traction, WallSpec)
from .damage import (DAMAGE_MODELS, DamageSpec, InitialDamage, RankineSpec, TimeToFailureSpec,
                     WeibullSpec)
from .materials import (DEFAULT_MODEL, MATERIALS, PLANES, SPLITS, SYMMETRIES, Anisotropy,
                        FractureSpec, LinearElasticSpec, MaterialSpec, NeoHookeanSpec,
                        material_class, rayleigh_speed, register_material, wave_speed)
from .scene import Scene
from .shapes import (SHAPES, Box, Cylinder, Disk, Extrusion, ImageShape, MeshShape, Polygon, Rectangle, Ring, Shape,
                     Sphere, image_colors)
from .stability import CRITICAL_FACTOR, CRITICAL_FACTOR_3D, LONE_PARTICLE_FACTOR, LONE_PARTICLE_FACTOR_3D
from .toml import apply_overrides
from .validation import SceneError

# The names before the split into Spec classes, for scripts written against them.
Grid = GridSpec
Wall = WallSpec
Fracture = FractureSpec
PhaseField = PhaseFieldSpec
Material = LinearElasticSpec

__all__ = [
    "SceneError",
    "Scene",
    "GridSpec",
    "Time",
    "Output",
    "PhaseFieldSpec",
    "TransferSpec",
    "TRANSFER_SCHEMES",
    "MATERIALS",
    "DEFAULT_MODEL",
    "register_material",
    "material_class",
    "MaterialSpec",
    "LinearElasticSpec",
    "NeoHookeanSpec",
    "DAMAGE_MODELS",
    "DamageSpec",
    "RankineSpec",
    "TimeToFailureSpec",
    "WeibullSpec",
    "InitialDamage",
    "FractureSpec",
    "Anisotropy",
    "Shape",
    "Rectangle",
    "Disk",
    "Ring",
    "Polygon",
    "MeshShape",
    "ImageShape",
    "Box",
    "Sphere",
    "Cylinder",
    "Extrusion",
    "image_colors",
    "SHAPES",
    "Body",
    "Traction",
    "BodyForce",
    "LOADS",
    "Ramp",
    "Table",
    "AMPLITUDES",
    "Prescribed",
    "WallSpec",
    "Crack",
    "ContactPair",
    "Contact",
    "apply_overrides",
    "wave_speed",
    "rayleigh_speed",
    "CRITICAL_FACTOR",
    "CRITICAL_FACTOR_3D",
    "LONE_PARTICLE_FACTOR",
    "LONE_PARTICLE_FACTOR_3D",
    "PLANES",
    "DEGREES",
    "SPLITS",
    "SYMMETRIES",
    "EDGES",
    "SIDES",
    "SIDES_3D",
    "WALL_TYPES",
    "Grid",
    "Wall",
    "Fracture",
    "PhaseField",
    "Material",
]
