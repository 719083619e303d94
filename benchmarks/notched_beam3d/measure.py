"""PF-MPM against PF-FEM on the 3D notched beam (issue 51, "MPM against FEM
in 3D"): the agreement of the two methods' runs at each resolution of a
``pfmpm compare notched_beam3d`` comparison.

At every ``h`` the comparison ran, :func:`checks` reads ``mpm_h<h>`` and
``fem_h<h>`` (their ``energies.csv``) and measures, with
:func:`pfmpm.compare.agreement`:

- **initiation**: the first time the crack front (``crack_front``, the
  cracked points' farthest extent along ``output.crack_direction``, +y)
  is 0.5 mm past its start, in each method; they must lie within one output
  row (``record_interval_us``, the longer of the two runs' intervals
  between ``energies.csv`` rows) of each other;
- **end fracture energy**: the fracture energies at the common end time,
  the initial notch's included; MPM within :data:`FRACTURE` (5 %) of FEM;
  also the energy gained since t = 0, reported, not checked.

The crack front is the farthest cracked lattice point: an FEM vertex (h
apart along y) or an MPM particle (h/2 apart, a quarter cell off the grid
lines), so each method's front moves in its own steps, and "0.5 mm past its
start" is a different height in each (docs/verification/notched-beam3d.md).
:func:`area_initiation` is a measure without those steps, reported beside
it: the first time the crack area ``int gamma(c) dV`` has grown by 0.5 mm
times the width of the front (the beam's thickness).

Reported beside the checks: how far from the notch's plane either method
has cracked (:func:`cracked_reach`); where the end fracture energy lies, the
FEM's crack area near the notch and elsewhere (:func:`fem_crack_area`) and
the local part ``int (1 - c)^2 / (4 l0) dV`` of either method's in the
crack's band, its flanks and the beam's ends (:func:`local_crack_area`,
:data:`ZONES`), with the median history field there (:func:`history`); and
that the free beam's momentum is the impulse of the traction on its top
face, the same in both methods (:func:`load_impulse`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from pfmpm.compare import agreement
from pfmpm.output import read_csv
from pfmpm.post.tip import INITIATION_ADVANCE
from pfmpm.scene import Scene

__all__ = ["FRACTURE", "MOMENTUM", "ROWS", "ZONES", "area_initiation", "checks", "cracked_reach", "fem_crack_area",
           "front_width", "history", "load_force", "load_impulse", "local_crack_area", "momentum_error", "pair"]

FRACTURE = 0.05
"""The end fracture energies of the two methods agree to this, relative to FEM."""
ROWS = 1.0
"""Their initiation times lie within this many output rows."""
MOMENTUM = 1e-12
"""The free beam's momentum is the load's impulse to this, relative to the
impulse at the end (round-off): :func:`momentum_error`."""


def pair(out: Path | str, h: float) -> dict:
    """The agreement (:func:`pfmpm.compare.agreement`) of the comparison's
    two runs at ``h`` in ``out``, MPM against FEM, with the verdicts
    ``initiation_ok`` and ``fracture_ok`` and ``initiation_rows``, the
    difference of the initiation times in output rows (NaN if one never
    initiates)."""
    out = Path(out)
    a = agreement(read_csv(out / f"mpm_h{h:g}" / "energies.csv"), read_csv(out / f"fem_h{h:g}" / "energies.csv"))
    rows = abs(a["initiation_diff_us"]) / a["record_interval_us"]
    return a | {"h": h, "initiation_rows": rows,
                "initiation_ok": math.isfinite(rows) and rows <= ROWS + 1e-9,
                "fracture_ok": abs(a["fracture_end_rel_diff"]) <= FRACTURE}


def checks(out: Path | str, hs) -> list[dict]:
    """:func:`pair` at each ``h``, coarse to fine."""
    return [pair(out, h) for h in sorted(hs, reverse=True)]


def front_width(scene: Scene) -> float:
    """The width of the crack's front: the body's extent along the normal of
    the plane of the crack's normal and ``output.crack_direction`` (for the
    beam its thickness, along z)."""
    points = np.asarray(scene.cracks[0].points, dtype=float)
    n = np.cross(points[1] - points[0], points[2] - points[0])
    m = np.cross(n, np.asarray(scene.output.crack_direction, dtype=float))
    m /= np.linalg.norm(m)
    lo, hi = np.reshape(scene.bodies[0].shape.bounds(), (2, 3))
    return float(np.abs(m) @ (hi - lo))


def area_initiation(energies: Path | str, width: float | None = None, advance: float = INITIATION_ADVANCE) -> float:
    """The first time the crack area (``crack_area`` of ``energies.csv``)
    exceeds its value at t = 0 by ``advance * width``: a crack front of that
    width has advanced by ``advance`` (NaN if it never does).

    Parameters
    ----------
    energies : path
        A run's ``energies.csv``; its ``scene.toml`` beside it gives the
        width when ``width`` is None (:func:`front_width`).
    """
    energies = Path(energies)
    if width is None:
        width = front_width(Scene.from_toml(energies.parent / "scene.toml"))
    e = read_csv(energies)
    grown = e["crack_area"] > e["crack_area"][0] + advance * width
    return float(e["t"][np.argmax(grown)]) if grown.any() else math.nan


def _mpm_last_frame(run: Path):
    """The last particle frame of a 3D MPM run (:class:`pfmpm.post.frames.Frame`)."""
    from pfmpm.post.frames import read_frame, series

    t, path = series(run)[-1]
    return read_frame(t, path, 3)


def _fem_last_frame(run: Path, name: str = "c") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices (N, 3), tetrahedra (M, 4) and the field ``name`` (the phase
    field at the vertices, the history field on the cells) of the last field
    frame of a 3D FEM run."""
    import xml.etree.ElementTree as ElementTree

    import h5py

    grids = ElementTree.parse(run / "fields.xdmf").getroot().find("Domain").findall("Grid")

    def where(item):
        return item.text.strip().partition(":")[2]

    mesh = next(g for g in grids if g.get("GridType") == "Uniform")
    field = next(g for g in grids if g.get("CollectionType") == "Temporal" and g.get("Name") == name)
    with h5py.File(run / "fields.h5", "r") as f:
        x = f[where(mesh.find("Geometry/DataItem"))][()]
        cells = f[where(mesh.find("Topology/DataItem"))][()]
        c = f[where(field.findall("Grid")[-1].find("Attribute/DataItem"))][()].ravel()
    return x, cells, c


def _fem_cells(run: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Of each tetrahedron of the last frame of a 3D FEM run: its centroid
    (M, 3), volume, the exact mean of ``(1 - c)^2`` over it (c linear) and
    ``|grad c|^2``."""
    x, cells, c = _fem_last_frame(run)
    corners = x[cells]
    edges = corners[:, 1:] - corners[:, :1]
    volume = np.abs(np.linalg.det(edges)) / 6.0
    grad = np.linalg.solve(edges, (c[cells][:, 1:] - c[cells][:, :1])[..., None])[..., 0]
    d = 1.0 - c[cells]
    mean_square = (d.sum(axis=1) ** 2 + (d ** 2).sum(axis=1)) / 20.0  # exact on a P1 tetrahedron
    return corners.mean(axis=1), volume, mean_square, (grad ** 2).sum(axis=1)


def fem_crack_area(run: Path | str, centre: float = 20.0, half: float = 8.0) -> dict:
    """The crack area ``int gamma(c) dV`` of the last field frame of a 3D FEM
    run, near the notch's plane (cells whose centroid's x is within ``half``
    of ``centre``) and elsewhere (the beam's ends):
    ``gamma = (1 - c)^2 / (4 l0) + l0 |grad c|^2`` (AT2) on each P1
    tetrahedron, the mean of ``(1 - c)^2`` exact; the two add up to the
    run's last ``crack_area`` when the last frame is the run's end."""
    run = Path(run)
    l0 = Scene.from_toml(run / "scene.toml").materials[0].fracture.l0
    centroid, volume, mean_square, grad_square = _fem_cells(run)
    gamma = volume * (mean_square / (4.0 * l0) + l0 * grad_square)
    near = np.abs(centroid[:, 0] - centre) < half
    return {"near": float(gamma[near].sum()), "elsewhere": float(gamma[~near].sum())}


ZONES = (2.0, 8.0)
"""The zones of :func:`local_crack_area`, by the distance from the notch's
plane in units of l0: the crack's band (within 2 l0, where the 1D AT2
profile ``1 - c = exp(-|d| / (2 l0))`` of a crack in that plane holds
1 - exp(-2) = 86 % of its ``(1 - c)^2``), its flanks (2 to 8 l0, the rest
but exp(-8) = 0.03 %) and the beam's ends beyond (|x - 20| > 8 mm, where
``fem_crack_area`` counts "elsewhere")."""


def _zones(at: np.ndarray, centre: float, l0: float, zones: tuple[float, float]) -> dict:
    """Which points, at x = ``at``, lie in each zone of :data:`ZONES` about
    the notch's plane x = ``centre``: ``band``, ``flanks`` and ``ends``."""
    d = np.abs(at - centre) / l0
    return {"band": d < zones[0], "flanks": (d >= zones[0]) & (d < zones[1]), "ends": d >= zones[1]}


def local_crack_area(run: Path | str, centre: float = 20.0, zones: tuple[float, float] = ZONES) -> dict:
    """The local part of the crack area, ``int (1 - c)^2 / (4 l0) dV``, of
    the last frame of a 3D run of either method, in the zones
    :data:`ZONES` about the notch's plane x = ``centre``: ``band``,
    ``flanks`` and ``ends``.

    Of the two terms of the AT2 crack density this is the one both runs'
    frames hold (an MPM frame has no ``grad c``); for a straight AT2 crack
    it is half of its area. The MPM integrates it with its particles (their
    volumes and phase field), the FEM exactly on each P1 tetrahedron (by
    its centroid's zone).
    """
    run = Path(run)
    l0 = Scene.from_toml(run / "scene.toml").materials[0].fracture.l0
    if (run / "particles.pvd").is_file():
        frame = _mpm_last_frame(run)
        at = frame.x[:, 0]
        density = np.asarray(frame.data["volume"]) * (1.0 - np.asarray(frame.data["c"])) ** 2 / (4.0 * l0)
    else:
        centroid, volume, mean_square, _ = _fem_cells(run)
        at = centroid[:, 0]
        density = volume * mean_square / (4.0 * l0)
    return {k: float(density[inside].sum()) for k, inside in _zones(at, centre, l0, zones).items()}


def history(run: Path | str, centre: float = 20.0, zones: tuple[float, float] = ZONES) -> dict:
    """The median of the history field (the largest tensile elastic energy
    density since t = 0, which drives the phase field) at the end of a 3D
    run of either method, over its MPM particles or FEM cells in each zone of
    :data:`ZONES` (``band``, ``flanks``, ``ends``): what the damage beside
    the crack follows."""
    run = Path(run)
    l0 = Scene.from_toml(run / "scene.toml").materials[0].fracture.l0
    if (run / "particles.pvd").is_file():
        frame = _mpm_last_frame(run)
        at, value = frame.x[:, 0], np.asarray(frame.data["history"], dtype=float)
    else:
        x, cells, value = _fem_last_frame(run, "history")
        if len(value) != len(cells):
            raise ValueError(f"{run}: the history field is not one value a cell")
        at = x[cells].mean(axis=1)[:, 0]
    return {k: float(np.median(value[inside])) for k, inside in _zones(at, centre, l0, zones).items()}


def load_force(scene: Scene) -> np.ndarray:
    """The total force (N) of the scene's one load, a traction with a
    ``span``, at amplitude 1: the traction times its patch's area, which
    both methods apply exactly when the patch's edges lie on grid lines
    (tests/test_loads.py)."""
    load, = scene.loads
    return np.asarray(load.traction) * math.prod(b - a for _, a, b in load.patch())


def load_impulse(run: Path | str) -> np.ndarray:
    """The impulse (N us) of the scene's traction by each row of a run's
    ``energies.csv``, (rows, 3): :func:`load_force` times the integral of
    its amplitude as the run takes it, by the midpoint rule over its steps
    (each step, or FEM sub-step, takes the load at its midpoint time; ``dt``
    and ``substeps`` from the run's ``summary.json``)."""
    run = Path(run)
    scene = Scene.from_toml(run / "scene.toml")
    summary = json.loads((run / "summary.json").read_text())
    substeps = summary.get("substeps", 1)
    h = summary["dt"] / substeps
    steps = read_csv(run / "energies.csv")["step"].astype(int) * substeps
    amplitude = scene.loads[0].amplitude
    a = np.ones(steps[-1]) if amplitude is None else np.array([amplitude((k + 0.5) * h) for k in range(steps[-1])])
    integral = np.concatenate([[0.0], np.cumsum(a * h)])
    return integral[steps][:, None] * load_force(scene)


def momentum_error(run: Path | str) -> np.ndarray:
    """The largest difference over the rows of a run's ``energies.csv``
    between the free beam's momentum (``momentum_x|y|z``) and the load's
    impulse (:func:`load_impulse`), per direction, relative to the
    impulse's size at the end: nothing but the load acts on the beam, so
    round-off."""
    run = Path(run)
    e = read_csv(run / "energies.csv")
    impulse = load_impulse(run)
    momentum = np.column_stack([e[f"momentum_{d}"] for d in "xyz"])
    return np.abs(momentum - impulse).max(axis=0) / np.linalg.norm(impulse[-1])


def cracked_reach(run: Path | str, centre: float = 20.0) -> float:
    """The farthest distance from the notch's plane x = ``centre`` of a
    cracked point (phase field below ``output.crack_threshold``: an MPM
    particle or an FEM vertex) in the last frame of a 3D run: where a crack
    away from the notch would show (0 if none is cracked)."""
    run = Path(run)
    threshold = Scene.from_toml(run / "scene.toml").output.crack_threshold
    if (run / "particles.pvd").is_file():
        frame = _mpm_last_frame(run)
        x, c = frame.x, np.asarray(frame.data["c"], dtype=float)
    else:
        x, _, c = _fem_last_frame(run)
    cracked = c < threshold
    return float(np.abs(x[cracked, 0] - centre).max()) if cracked.any() else 0.0
