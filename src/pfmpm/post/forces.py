"""Forces of a run: the reactions of the walls and of the prescribed
regions, the net force on each body, and a region's load against its
displacement.

``energies.csv`` keeps impulses and momenta since t = 0 (the columns
``impulse_<side>_x|y`` of :func:`pfmpm.run.wall_columns`,
``impulse_<region>_x|y`` of :func:`pfmpm.run.region_columns`, ``momentum_x|y``
and, with several bodies, ``momentum_x|y_<body>``), exact whatever the
rows' spacing. A force here is their change over one interval between rows
divided by its length: the mean force over that interval, at its midpoint.
A wall's reaction is the force it exerts on the bodies; a body's net force
is the sum of every force on it (loads, walls, contact) by Newton's second
law.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import plots
from ..output import CsvLog
from ..scene import Scene
from ..scene.units import unit_system
from .tip import read_columns

__all__ = ["mean_forces", "run_forces", "load_displacement", "run_load_displacement"]


def mean_forces(scene: Scene, e) -> dict[str, np.ndarray]:
    """The mean forces between the rows of a run's ``energies.csv``.

    Parameters
    ----------
    scene : Scene
        The scene the run ran.
    e : path or mapping of str -> ndarray
        Its ``energies.csv``, or the columns.

    Returns
    -------
    dict of str -> ndarray
        ``t``, the midpoint of each interval; per wall ``wall_<side>_x``
        and ``wall_<side>_y``, its reaction; per prescribed region
        ``region_<name>_x`` and ``region_<name>_y``, its reaction; per body ``body_<name>_x`` and
        ``body_<name>_y``, the net force on it (with one body ``net_x`` and
        ``net_y``); per pair of bodies in contact, each its own field,
        ``contact_<a>_<b>_x|y``, the contact force of b on a.
    """
    e = read_columns(e)
    if missing := [c for c in _needed(scene) if c not in e]:
        raise KeyError(f"energies.csv has no column {missing[0]} (written by a pfmpm before it kept"
                       " the walls' impulses and the bodies' momenta)")
    t = np.asarray(e["t"], dtype=float)
    dt = np.diff(t)
    forces = {"t": 0.5 * (t[1:] + t[:-1])}
    for wall in scene.walls:
        for d in "xy":
            forces[f"wall_{wall.side}_{d}"] = np.diff(e[f"impulse_{wall.side}_{d}"]) / dt
    for region in scene.prescribed:
        for d in "xy":
            forces[f"region_{region.name}_{d}"] = np.diff(e[f"impulse_{region.name}_{d}"]) / dt
    for name, column in _momenta(scene):
        forces[name] = np.diff(e[column]) / dt
    # The contact force of each pair of bodies (with each body its own field).
    for column in (c for c in e if c.startswith("contact_")):
        forces[column] = np.diff(e[column]) / dt
    return forces


def _momenta(scene: Scene) -> list[tuple[str, str]]:
    """(force, momentum column) of each body and direction."""
    if len(scene.bodies) == 1:
        return [(f"net_{d}", f"momentum_{d}") for d in "xy"]
    return [(f"body_{b.name}_{d}", f"momentum_{d}_{b.name}") for b in scene.bodies for d in "xy"]


def _needed(scene: Scene) -> list[str]:
    """The ``energies.csv`` columns that :func:`mean_forces` reads."""
    return (["t"] + [f"impulse_{w.side}_{d}" for w in scene.walls for d in "xy"]
            + [f"impulse_{r.name}_{d}" for r in scene.prescribed for d in "xy"]
            + [column for _, column in _momenta(scene)])


def run_forces(scene: Scene, run_dir: Path | str) -> dict:
    """Write a finished run's ``forces.csv`` (:func:`mean_forces`) and
    ``forces.png`` (the walls' reactions and the bodies' net forces against
    time, in the scene's units) into its folder.

    Returns
    -------
    dict
        ``csv`` and ``png``, the files; ``peaks``, per column the value of
        largest magnitude and its time; ``units``, the force and time units.
    """
    run_dir = Path(run_dir)
    forces = mean_forces(scene, run_dir / "energies.csv")
    csv, png = run_dir / "forces.csv", run_dir / "forces.png"
    _write_columns(csv, forces)
    units = unit_system(scene.units)
    plots.forces(forces, png, units)
    peaks = {}
    for name, values in forces.items():
        if name != "t" and len(values):
            k = int(np.argmax(np.abs(values)))
            peaks[name] = {"value": float(values[k]), "t": float(forces["t"][k])}
    return {"csv": str(csv), "png": str(png), "peaks": peaks,
            "units": {"force": units.unit("force"), "time": units.unit("time")}}



def load_displacement(scene: Scene, e, region: str | None = None) -> dict:
    """A prescribed region's load against its displacement.

    Parameters
    ----------
    scene : Scene
    e : path or mapping of str -> ndarray
        The run's ``energies.csv``, or the columns.
    region : str or None
        The region's name; None: the scene's only one.

    Returns
    -------
    dict
        ``region``, ``component`` (the held component it moved farther
        along), ``displacement`` (at each interval's midpoint, the mean of
        its ends) and ``load`` (the mean force the region exerts on the
        bodies over the interval, along that component); ``t``.

    Raises
    ------
    KeyError
        For a scene without that region (or with several and no name).
    """
    regions = {r.name: r for r in scene.prescribed}
    if region is None:
        if len(regions) != 1:
            raise KeyError(f"the scene has {len(regions)} prescribed regions: name one with --region"
                           + (f" ({', '.join(regions)})" if regions else ""))
        region = next(iter(regions))
    if region not in regions:
        raise KeyError(f"no prescribed region {region!r} (the scene's: {', '.join(regions) or 'none'})")
    e = read_columns(e)
    forces = mean_forces(scene, e)
    d = max(regions[region].components, key=lambda c: abs(e[f"displacement_{region}_{c}"][-1]))
    u = e[f"displacement_{region}_{d}"]
    return {"region": region, "component": d, "t": forces["t"], "displacement": 0.5 * (u[1:] + u[:-1]),
            "load": forces[f"region_{region}_{d}"]}


def run_load_displacement(scene: Scene, run_dir: Path | str, region: str | None = None) -> dict:
    """Write a finished run's ``load_displacement.csv`` and
    ``load_displacement.png`` (:func:`load_displacement`, in the scene's
    units) into its folder.

    Returns
    -------
    dict
        ``csv``, ``png``, ``region``, ``component``, the largest load
        ``peak_load`` (by magnitude) and the ``displacement_at_peak``,
        ``units``.
    """
    run_dir = Path(run_dir)
    curve = load_displacement(scene, run_dir / "energies.csv", region)
    csv, png = run_dir / "load_displacement.csv", run_dir / "load_displacement.png"
    _write_columns(csv, {c: curve[c] for c in ("t", "displacement", "load")})
    units = unit_system(scene.units)
    plots.load_displacement(curve, png, units)
    k = int(np.argmax(np.abs(curve["load"])))
    return {"csv": str(csv), "png": str(png), "region": curve["region"], "component": curve["component"],
            "peak_load": float(curve["load"][k]), "displacement_at_peak": float(curve["displacement"][k]),
            "units": {"force": units.unit("force"), "length": units.unit("length")}}


def _write_columns(path: Path, columns: dict[str, np.ndarray]) -> None:
    """Write equal-length ``columns`` as a CSV file (:class:`~pfmpm.output.CsvLog`'s format)."""
    log = CsvLog(path, list(columns))
    for row in zip(*columns.values()):
        log.write(dict(zip(columns, row)))
    log.close()
