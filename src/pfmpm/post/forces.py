"""Forces of a run: the walls' reactions and the net force on each body.

``energies.csv`` keeps impulses and momenta since t = 0 (the columns
``impulse_<side>_x|y`` of :func:`pfmpm.run.wall_columns`, ``momentum_x|y``
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

__all__ = ["mean_forces", "run_forces"]


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
        and ``wall_<side>_y``, its reaction; per body ``body_<name>_x`` and
        ``body_<name>_y``, the net force on it (with one body ``net_x`` and
        ``net_y``).
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
    for name, column in _momenta(scene):
        forces[name] = np.diff(e[column]) / dt
    return forces


def _momenta(scene: Scene) -> list[tuple[str, str]]:
    """(force, momentum column) of each body and direction."""
    if len(scene.bodies) == 1:
        return [(f"net_{d}", f"momentum_{d}") for d in "xy"]
    return [(f"body_{b.name}_{d}", f"momentum_{d}_{b.name}") for b in scene.bodies for d in "xy"]


def _needed(scene: Scene) -> list[str]:
    """The ``energies.csv`` columns that :func:`mean_forces` reads."""
    return (["t"] + [f"impulse_{w.side}_{d}" for w in scene.walls for d in "xy"]
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
    log = CsvLog(csv, list(forces))
    for row in zip(*forces.values()):
        log.write(dict(zip(forces, row)))
    log.close()
    units = unit_system(scene.units)
    plots.forces(forces, png, units)
    peaks = {}
    for name, values in forces.items():
        if name != "t" and len(values):
            k = int(np.argmax(np.abs(values)))
            peaks[name] = {"value": float(values[k]), "t": float(forces["t"][k])}
    return {"csv": str(csv), "png": str(png), "peaks": peaks,
            "units": {"force": units.force if units.declared else "scene units",
                      "time": units.time if units.declared else "scene units"}}

