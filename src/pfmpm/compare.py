"""PF-MPM against PF-FEM on one scene: agreement, and speed against error.

:func:`compare` runs a scene, by default the Borden plate (shipped as
``pfmpm/scenes/borden_plate.toml``; ``demos/borden_plate.toml`` links to it;
:func:`compare_borden` is the same function), with both methods at a list
of grid spacings ``h`` and one length scale ``l0``, then writes, into its
output directory:

``speed_vs_error.csv``
    One row per run, columns :data:`COLUMNS`: its size (``particles`` for
    MPM, ``dofs`` for FEM: displacement and phase field per vertex), wall
    time, crack initiation and branch times, and ``error``: the relative
    difference of its end fracture energy from the one reference both
    methods share (:func:`reference`), a Richardson extrapolation of the FEM
    runs at the two finest ``h`` (the finest FEM run itself when there is one ``h``).
``energies_overlay.png``, ``crack_tip_speed_overlay.png``
    Elastic and fracture energy, and crack-tip position and speed, of every
    run (MPM solid, FEM dashed; one colour per ``h``).
``phase_field_side_by_side.png``, ``crack_path_side_by_side.png``
    The phase-field snapshots (``phase_field.png``) and the crack paths
    (``crack_path.png``) of the two finest runs.
``speed_vs_error.png``
    That error against wall time, log-log.
``comparison.md``
    The table, the reference and the :func:`agreement` of the two methods
    at the finest common ``h``.
``agreement.json``
    That agreement with ``h``, ``l0`` and the reference (NaN written as ``null``).
``study.json``
    The study's settings and each run's wall time, which ``pfmpm compare
    --resume`` continues from.

A new comparison refuses a directory that holds another comparison or run,
unless told to overwrite it (``--overwrite``): then that comparison's files
and its runs' are deleted first (:func:`clear`).

Each run keeps its own output in ``mpm_h<h>/`` and ``fem_h<h>/``, with
``frames`` particle (MPM, VTU) or field (FEM, XDMF) frames evenly spaced in
time.  The MPM runs use the OpenMP threads the core is given
(``OMP_NUM_THREADS``); the FEM runs are serial, in this process.  An
interrupted MPM run leaves a checkpoint; with ``resume`` the completed runs
are kept, an interrupted MPM run continues from its checkpoint and an
unfinished FEM run starts again.

Definitions used on the ``energies.csv`` columns (see
:func:`~pfmpm.post.tip.initiation_time`, :func:`~pfmpm.post.tip.branch_time`
and :func:`agreement`):

- crack initiation: the first time ``crack_tip_x`` exceeds its value at
  t = 0 by :data:`~pfmpm.post.tip.INITIATION_ADVANCE` (0.5 mm);
- branching: the first time the tip lies more than
  :data:`~pfmpm.post.tip.BRANCH_OFFSET` (1 mm) off the line of the notch while
  more than :data:`~pfmpm.post.tip.BRANCH_AFTER`
  (5 mm) ahead of the notch tip.  Until the crack branches, the tip (the
  cracked point farthest from the notch tip) runs on the notch line; once
  two branches diverge, it lies on one of them.

Both are read from ``energies.csv`` rows, every ``output.energies_every``
steps, so they are known to within that record interval
(``record_interval_us`` of the agreement).

A 3D scene (:data:`PROBLEMS`: ``notched_beam3d``) writes the same files.
Its crack has a front rather than a tip: initiation is the first time
``crack_front``, the front's extent along ``output.crack_direction``,
exceeds its value at t = 0 by 0.5 mm; there is no branch time; the table
has the columns :data:`COLUMNS_3D` (the front and the crack area
``int gamma(c) dV`` at the end in place of the branch time and the tip);
``crack_tip_speed_overlay.png`` draws ``crack_front`` and
``crack_front_speed``; and the side-by-side pictures are the phase field
of the last frame of each run on the plane of the initial crack's normal
and ``output.crack_direction`` through the body's middle (an MPM particle
frame and an FEM field frame, so ``frames`` must be at least 1;
``crack_path_side_by_side.png`` is not written).
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import textwrap
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import _core, checkpoint, run_folder, scenes
from .output import check_directory, read_csv
from .post.tip import branch_time, initiation_time, read_columns
from .scene import Crack, Scene
from .scene.toml import read_toml

__all__ = ["COLUMNS", "COLUMNS_3D", "OUTPUTS", "PROBLEMS", "Comparison", "Problem", "agreement", "branch_time",
           "comparison_overrides", "compare", "compare_borden", "check_fresh", "clear", "initiation_time",
           "reference", "read_study"]

BORDEN_SCENE = scenes.path("borden_plate")
"""The Borden plate scene shipped with the package."""
DEFAULT_H = (0.5, 0.25)
DEFAULT_L0 = 0.5
DEFAULT_END = 80.0
DEFAULT_FRAMES = 5
"""Particle or field frames each run writes, evenly spaced from t = 0 to the end."""
METHODS = ("mpm", "fem")
LABELS = {"mpm": "PF-MPM", "fem": "PF-FEM"}
ORDER = 2.0
"""Convergence order in h of the end fracture energy that the Richardson
reference assumes when fewer than three FEM runs show one: the FEM runs of
the l0 = 1 mm study at h = 1, 0.5, 0.25 mm converge at order 1.94
(docs/verification/mpm-fem.md)."""
OBSERVED_ORDERS = (0.5, 4.0)
"""An order the three finest FEM runs show is used when it lies in this range."""
STUDY = "study.json"
"""The file in a comparison's output directory with its settings and wall times."""
OUTPUTS = ("speed_vs_error.csv", "energies_overlay.png", "crack_tip_speed_overlay.png",
           "phase_field_side_by_side.png", "crack_path_side_by_side.png", "speed_vs_error.png",
           "comparison.md", "agreement.json")
"""The files a comparison writes into its output directory besides :data:`STUDY` and its runs."""

COLUMNS = ["method", "h", "particles", "dofs", "steps", "wall_s", "initiation_us", "branch_us",
           "fracture_energy_end", "elastic_energy_peak", "crack_tip_x_end", "error"]
"""Columns of ``speed_vs_error.csv``; ``particles`` is empty for FEM runs and ``dofs`` for MPM runs."""
COLUMNS_3D = ["method", "h", "particles", "dofs", "steps", "wall_s", "initiation_us", "fracture_energy_end",
              "elastic_energy_peak", "crack_front_end", "crack_area_end", "error"]
"""The columns of a 3D scene: no branch time, the crack front (``crack_front``)
in place of the tip and the crack area ``int gamma(c) dV`` (``crack_area``) at
the end; ``dofs`` counts three displacements and the phase field per vertex."""


@dataclass(frozen=True)
class Problem:
    """A scene ``pfmpm compare`` runs by name, with its defaults.

    Attributes
    ----------
    scene : str
        The shipped scene (:func:`pfmpm.scenes.path`).
    title : str
        The title of ``comparison.md``.
    h : tuple of float
        Default grid spacings.
    l0, end : float
        Default length scale and end time.
    """

    scene: str
    title: str
    h: tuple[float, ...]
    l0: float
    end: float

    @property
    def path(self) -> Path:
        return scenes.path(self.scene)


PROBLEMS = {
    "borden": Problem("borden_plate", "Borden plate", DEFAULT_H, DEFAULT_L0, DEFAULT_END),
    # benchmarks/notched_beam3d: the crack has run through the ligament by about 35 us.
    "notched_beam3d": Problem("notched_beam3d", "notched beam struck at mid-span (3D)", (1.0, 0.5), 1.0, 50.0),
}
"""The problems of ``pfmpm compare PROBLEM`` by name."""


@dataclass
class Comparison:
    """What :func:`compare_borden` produced.

    Attributes
    ----------
    out_dir : Path
    rows : list of dict
        The rows of ``speed_vs_error.csv`` (keys :data:`COLUMNS`).
    agreement : dict
        :func:`agreement` of the two methods at ``h_common``.
    h_common : float
        The finest ``h`` both methods ran.
    reference : dict
        :func:`reference`, against which ``error`` is measured.
    files : dict of str -> Path
        The files written, by name.
    """

    out_dir: Path
    rows: list[dict]
    agreement: dict
    h_common: float
    reference: dict
    files: dict[str, Path] = field(default_factory=dict)


# -- measures on energies.csv -------------------------------------------------


def agreement(mpm_csv, fem_csv, crack: Crack | None = None) -> dict:
    """How closely a PF-MPM run follows a PF-FEM run of the same scene.

    Differences are MPM minus FEM; relative ones are relative to the FEM run
    (the reference).

    Parameters
    ----------
    mpm_csv, fem_csv : path or mapping of str -> ndarray
        The two runs' ``energies.csv`` (with crack-tip columns), or their
        columns.
    crack : Crack, optional
        The initial crack, for the branch times (NaN without it).

    Returns
    -------
    dict
        ``initiation_mpm_us``, ``initiation_fem_us``
            Crack initiation times (:func:`initiation_time`), NaN if none.
        ``initiation_diff_us``
            Their difference.
        ``branch_mpm_us``, ``branch_fem_us``, ``branch_diff_us``
            The same for the branch times (:func:`branch_time`).
        ``record_interval_us``
            The longer of the two runs' intervals between ``energies.csv``
            rows: the resolution of every time above.
        ``elastic_window_us``
            End of the window of the elastic comparison: the earlier
            initiation, or the common end time if neither run initiates.
        ``elastic_peak``
            Largest FEM elastic energy in the window.
        ``elastic_rms_rel``
            RMS over the window of the difference of the elastic energies
            (MPM interpolated linearly onto the FEM times), over
            ``elastic_peak``.
        ``t_end``
            The common end time (the earlier of the two last rows).
        ``fracture_end_mpm``, ``fracture_end_fem``
            Fracture energies at ``t_end`` (the initial notch included).
        ``fracture_end_rel_diff``
            Their relative difference.
        ``fracture_gain_rel_diff``
            The same for the fracture energy gained since t = 0 (NaN when the
            FEM run gained none).
    """
    m, f = read_columns(mpm_csv), read_columns(fem_csv)
    t_mpm, t_fem = initiation_time(m), initiation_time(f)
    b_mpm, b_fem = (branch_time(e, crack) if crack is not None else math.nan for e in (m, f))
    t_end = min(m["t"][-1], f["t"][-1])
    started = [t for t in (t_mpm, t_fem) if math.isfinite(t)]
    window = min(started) if started else t_end
    sel = f["t"] <= window + 1e-9 * max(window, 1.0)
    elastic_mpm = np.interp(f["t"][sel], m["t"], m["elastic"])
    peak = float(f["elastic"][sel].max())
    rms = math.sqrt(float(np.mean((elastic_mpm - f["elastic"][sel]) ** 2)))
    end_mpm = float(np.interp(t_end, m["t"], m["fracture"]))
    end_fem = float(np.interp(t_end, f["t"], f["fracture"]))
    gain_mpm, gain_fem = end_mpm - m["fracture"][0], end_fem - f["fracture"][0]
    intervals = [float(np.diff(e["t"]).max()) if len(e["t"]) > 1 else math.nan for e in (m, f)]
    return {
        "initiation_mpm_us": t_mpm,
        "initiation_fem_us": t_fem,
        "initiation_diff_us": t_mpm - t_fem,
        "branch_mpm_us": b_mpm,
        "branch_fem_us": b_fem,
        "branch_diff_us": b_mpm - b_fem,
        "record_interval_us": max(intervals),
        "elastic_window_us": float(window),
        "elastic_peak": peak,
        "elastic_rms_rel": rms / peak if peak > 0 else math.nan,
        "t_end": float(t_end),
        "fracture_end_mpm": end_mpm,
        "fracture_end_fem": end_fem,
        "fracture_end_rel_diff": (end_mpm - end_fem) / end_fem,
        "fracture_gain_rel_diff": (gain_mpm - gain_fem) / gain_fem if gain_fem > 0 else math.nan,
    }


def reference(fem_end: Mapping[float, float], order: float = ORDER) -> dict:
    """The end fracture energy that every run's error is measured against.

    A Richardson extrapolation of the FEM runs at the two finest ``h``,
    ``F_f + (F_f - F_c) / ((h_c / h_f)^p - 1)``, with ``p`` the order the
    three finest FEM runs show if there are three, in a constant ratio of
    ``h``, converging monotonically at an order within
    :data:`OBSERVED_ORDERS`; else the assumed ``order``.  With one ``h``,
    the FEM run there.

    Parameters
    ----------
    fem_end : mapping of float -> float
        End fracture energy of the FEM run at each ``h``.
    order : float
        The assumed convergence order in ``h`` (:data:`ORDER`).

    Returns
    -------
    dict
        ``value``; ``kind`` (``"richardson"`` or ``"finest FEM run"``);
        ``h`` (the FEM runs it comes from); ``order``, the order used;
        ``observed_order``, the one the three finest FEM runs show (NaN
        without three, or without a monotone convergence).
    """
    hs = sorted(fem_end, reverse=True)
    if len(hs) == 1:
        return {"value": fem_end[hs[0]], "kind": "finest FEM run", "h": hs, "order": math.nan,
                "observed_order": math.nan}
    (hc, fc), (hf, ff) = [(h, fem_end[h]) for h in hs[-2:]]
    observed = math.nan
    if len(hs) >= 3:
        h1, h2, h3 = hs[-3:]
        d1, d2 = fem_end[h1] - fem_end[h2], fem_end[h2] - fem_end[h3]
        if math.isclose(h1 / h2, h2 / h3, rel_tol=1e-9) and d1 * d2 > 0:
            observed = math.log(d1 / d2) / math.log(h1 / h2)
    lo, hi = OBSERVED_ORDERS
    p = observed if lo <= observed <= hi else order
    return {"value": ff + (ff - fc) / ((hc / hf) ** p - 1.0), "kind": "richardson",
            "h": [hc, hf], "order": p, "observed_order": observed}


# -- the runs -----------------------------------------------------------------


def comparison_overrides(scene: dict, h: float, l0: float, end: float,
                         model: str = "AT2") -> list[str]:
    """Scene overrides of one comparison run: grid spacing ``h``, the length
    scale ``l0`` and phase-field ``model`` (AT1 or AT2) of every material that
    can crack, and end time ``end``.

    Parameters
    ----------
    scene : dict
        The scene's tables (as read from its TOML file), which say which
        materials have a fracture table.
    """
    materials = scene.get("materials", [])
    crackable = [i for i, m in enumerate(materials) if isinstance(m, Mapping) and "fracture" in m]
    return ([f"grid.h={h!r}"] + [f"materials.{i}.fracture.l0={l0!r}" for i in crackable]
            + [f"materials.{i}.fracture.model={model}" for i in crackable]
            + [f"time.end={end!r}"])


def _for_comparison(scene: Scene, frames: int) -> Scene:
    """The scene with its snapshot times cut at ``time.end``, which is added
    (in 2D: a 3D scene has no snapshots), and ``frames`` output frames evenly
    spaced in time (none for 0)."""
    end = scene.time.end
    times = sorted({t for t in scene.output.snapshots if t < end} | {end}) if scene.dim == 2 else []
    every = max(1, math.ceil(scene.steps() / max(frames - 1, 1)))
    output = dataclasses.replace(scene.output, snapshots=tuple(times), particles=frames > 0, every=every)
    return dataclasses.replace(scene, output=output)


def _run_name(method: str, h: float) -> str:
    return f"{method}_h{h:g}"


def _runs(out: Path) -> list[Path]:
    """The run folders of the comparison in ``out`` (of every ``h`` it ran)."""
    return sorted(p for method in METHODS for p in out.glob(f"{method}_h*") if p.is_dir())


def check_fresh(out_dir: Path | str, overwrite: bool = False) -> Path:
    """``out_dir`` as the output directory of a new comparison.

    Raises
    ------
    NotADirectoryError
        If it or a folder above it is a file.
    pfmpm.run_folder.RunFolderError
        If it holds a comparison or a run, and not ``overwrite``.
    """
    out = check_directory(out_dir)
    held = (STUDY if (out / STUDY).exists() else run_folder.run_mark(out)
            or next((f"{p.name}/" for p in _runs(out) if run_folder.run_mark(p)), None))
    if held is not None and not overwrite:
        raise run_folder.RunFolderError(
            f"output directory {out} holds another comparison or run (its {held}): replace it with"
            f" --overwrite, continue it with --resume, or choose another directory")
    return out


def clear(out: Path) -> None:
    """Delete what a comparison and its runs wrote in ``out`` (:data:`STUDY`,
    :data:`OUTPUTS`, :data:`pfmpm.run_folder.RUN_FILES` of each run, and the
    run folders left empty), and a run there; nothing else."""
    for name in (STUDY, STUDY + ".tmp", *OUTPUTS):
        (out / name).unlink(missing_ok=True)
    for path in _runs(out):
        run_folder.clear(path)
        if not any(path.iterdir()):
            path.rmdir()
    if run_folder.run_mark(out):
        run_folder.clear(out)


def read_study(out_dir: Path | str) -> dict:
    """The settings of the comparison in ``out_dir`` (its :data:`STUDY` file):
    ``h``, ``l0``, ``end``, ``scene``, ``overrides``, ``frames``, ``model``.

    Raises
    ------
    FileNotFoundError
        Naming the file, if there is no comparison in ``out_dir``.
    """
    path = Path(out_dir) / STUDY
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no comparison to resume in {out_dir}")
    return json.loads(path.read_text())["settings"]


def compare(out_dir: Path | str, hs: Sequence[float] = DEFAULT_H, l0: float = DEFAULT_L0,
            end: float = DEFAULT_END, scene_path: Path | str = BORDEN_SCENE,
            overrides: Sequence[str] = (), progress: bool = True, log=print,
            frames: int = DEFAULT_FRAMES, resume: bool = False,
            model: str = "AT2", overwrite: bool = False, title: str = "Borden plate") -> Comparison:
    """Run a scene, by default the Borden plate, with PF-MPM and PF-FEM at
    each ``h`` and compare.

    Parameters
    ----------
    out_dir : path
        Output directory (see the module docstring for what goes in it).
    hs : sequence of float
        Grid spacings (mm); each is the MPM grid spacing and the FEM mesh
        size.
    l0 : float
        Phase-field length scale (mm); at least every ``h``.
    end : float
        End time (us).
    scene_path : path
        The scene file (2D or 3D), one body the FEM path can mesh.
    overrides : sequence of str
        More ``key=value`` overrides for both methods' scenes, applied after
        those of :func:`comparison_overrides` (the FEM path ignores particle
        counts).
    progress : bool
        Show progress bars.
    log : callable
        Called with one line of text per run started and finished.
    frames : int
        Output frames per run, evenly spaced in time (0: none).
    resume : bool
        Continue the comparison in ``out_dir``, which must have been started
        with the same settings: keep its completed runs, resume an
        interrupted MPM run from its checkpoint, run the rest.
    model : str
        The phase-field model of both methods, ``"AT2"`` (the paper's) or
        ``"AT1"`` (:class:`~pfmpm.scene.FractureSpec`).
    overwrite : bool
        Without ``resume``: if ``out_dir`` holds another comparison or run,
        delete it first (:func:`clear`) rather than refuse.
    title : str
        What ``comparison.md`` calls the scene.

    Returns
    -------
    Comparison

    Raises
    ------
    SceneError
        If a scene is invalid (e.g. ``l0 < h``) or the FEM path cannot run
        it; raised before any run.
    ValueError
        With ``resume``, if ``out_dir`` holds a comparison of other settings.
    NotADirectoryError, pfmpm.run_folder.RunFolderError
        From :func:`check_fresh`, without ``resume``.
    pfmpm.SimulationError
        If a run fails.
    KeyboardInterrupt
        If a run is interrupted; the runs finished so far keep their output,
        an interrupted MPM run its checkpoint.
    """
    from mpi4py import MPI

    from .fem import FemSimulation
    from .simulation import Simulation

    if not hs:
        raise ValueError("hs: give at least one grid spacing")
    hs = sorted({float(h) for h in hs}, reverse=True)  # coarse to fine
    out = Path(out_dir) if resume else check_fresh(out_dir, overwrite)
    settings = {"h": hs, "l0": float(l0), "end": float(end), "scene": str(scene_path),
                "overrides": list(overrides), "frames": int(frames), "model": model}
    study = _open_study(out, settings, resume)
    tables = read_toml(scene_path)
    by_h = {h: _for_comparison(Scene.from_dict(tables, comparison_overrides(tables, h, l0, end, model)
                                               + list(overrides)), frames)
            for h in hs}
    # The FEM set-up is cheap and checks that its path supports the scene.
    fems = {h: FemSimulation(by_h[h], MPI.COMM_SELF) for h in hs}
    if not resume and out.is_dir():
        clear(out)
    out.mkdir(parents=True, exist_ok=True)
    _save_study(out, study)
    runs = {}
    for h in hs:
        for method in METHODS:
            name = _run_name(method, h)
            path = out / name
            summary = _summary(path) if resume else None
            if summary is not None and summary["status"] == "completed":
                log(f"{LABELS[method]} h = {h:g}: completed before, in {path}")
                wall = study["wall_s"].get(name, summary["wall_s"])
                size = summary["particles" if method == "mpm" else "dofs"]
                runs[method, h] = {"size": size, "steps": summary["steps"], "wall_s": wall,
                                   "energies": read_csv(path / "energies.csv")}
                continue
            ckpt = _checkpoint(path, by_h[h]) if resume and method == "mpm" else None
            sim = Simulation(by_h[h]) if method == "mpm" else fems.pop(h)
            size = len(sim.particles) if method == "mpm" else sim.summary()["dofs"]
            what = "particles" if method == "mpm" else "dofs"
            where = f" from step {ckpt.step}" if ckpt else ""
            log(f"{LABELS[method]} h = {h:g}: {size} {what}, {by_h[h].steps()} steps{where} -> {path}")
            before = study["wall_s"].get(name, summary["wall_s"] if summary else 0.0) if ckpt else 0.0
            # A resumed comparison starts its unfinished runs again in their own folders.
            result = (sim.run(path, progress=progress, resume=ckpt, overwrite=resume) if method == "mpm"
                      else sim.run(path, progress=progress, overwrite=resume))
            study["wall_s"][name] = before + result.wall_s
            _save_study(out, study)
            if result.status == "interrupted":
                raise KeyboardInterrupt
            if result.status != "completed":
                raise _core.SimulationError(f"{LABELS[method]} at h = {h:g}: {result.error}")
            log(f"  done in {result.wall_s:.1f} s")
            runs[method, h] = {"size": size, "steps": result.steps, "wall_s": study["wall_s"][name],
                               "energies": read_csv(path / "energies.csv")}
    scene = by_h[hs[-1]]
    crack = scene.cracks[0] if scene.dim == 2 else None  # a 3D crack has a front, no tip to branch
    ref = reference({h: float(runs["fem", h]["energies"]["fracture"][-1]) for h in hs})
    rows = _table(runs, hs, crack, ref["value"], scene.dim)
    fine = hs[-1]
    agree = agreement(runs["mpm", fine]["energies"], runs["fem", fine]["energies"], crack)
    files = _write_outputs(out, rows, agree, ref, runs, hs, scene, l0, end, model, title)
    return Comparison(out_dir=out, rows=rows, agreement=agree, h_common=fine, reference=ref, files=files)


compare_borden = compare
"""The same as :func:`compare`, whose defaults are the Borden plate's."""


def _open_study(out: Path, settings: dict, resume: bool) -> dict:
    """The study record: new, or with ``resume`` the one in ``out`` if its settings are these."""
    if not resume:
        return {"settings": settings, "wall_s": {}}
    path = out / STUDY
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no comparison to resume in {out}")
    study = json.loads(path.read_text())
    if study["settings"] != settings:
        differ = ", ".join(k for k in settings if study["settings"].get(k) != settings[k])
        raise ValueError(f"{path}: the comparison in {out} has other settings ({differ})")
    return study


def _save_study(out: Path, study: dict) -> None:
    tmp = out / (STUDY + ".tmp")
    tmp.write_text(json.dumps(study, indent=2) + "\n")
    tmp.replace(out / STUDY)


def _summary(path: Path) -> dict | None:
    """A run's ``summary.json``, or ``None`` if it has none."""
    try:
        return json.loads((path / "summary.json").read_text())
    except (FileNotFoundError, json.JSONDecodeError):
        return None


def _checkpoint(path: Path, scene: Scene):
    """The newest checkpoint of the MPM run in ``path`` (of ``scene``), or ``None``."""
    if not checkpoint.list_checkpoints(path / checkpoint.DIRECTORY):
        return None
    ckpt = checkpoint.find(path)
    if ckpt.scene != scene.to_dict():
        raise ValueError(f"{ckpt.path}: a checkpoint of another scene than this comparison's")
    return ckpt


def _table(runs: dict, hs: list[float], crack: Crack | None, ref: float, dim: int = 2) -> list[dict]:
    """The rows of ``speed_vs_error.csv`` (:data:`COLUMNS`, in 3D
    :data:`COLUMNS_3D`), errors against the reference ``ref``."""
    rows = []
    for method in METHODS:
        for h in hs:
            run = runs[method, h]
            e = run["energies"]
            f_end = float(e["fracture"][-1])
            row = {
                "method": method,
                "h": h,
                "particles": run["size"] if method == "mpm" else None,
                "dofs": run["size"] if method == "fem" else None,
                "steps": run["steps"],
                "wall_s": run["wall_s"],
                "initiation_us": initiation_time(e),
                "fracture_energy_end": f_end,
                "elastic_energy_peak": float(e["elastic"].max()),
                "error": abs(f_end - ref) / ref,
            }
            if dim == 2:
                row |= {"branch_us": branch_time(e, crack), "crack_tip_x_end": float(e["crack_tip_x"][-1])}
            else:
                row |= {"crack_front_end": float(e["crack_front"][-1]), "crack_area_end": float(e["crack_area"][-1])}
            rows.append({c: row[c] for c in (COLUMNS if dim == 2 else COLUMNS_3D)})
    return rows


# -- output -------------------------------------------------------------------


def _write_outputs(out: Path, rows: list[dict], agree: dict, ref: dict, runs: dict, hs: list[float],
                   scene: Scene, l0: float, end: float, model: str, title: str = "Borden plate") -> dict[str, Path]:
    """Write the CSV, the plots and ``comparison.md``; return their paths by name."""
    files = {name: out / name for name in OUTPUTS}
    columns = COLUMNS if scene.dim == 2 else COLUMNS_3D
    with open(files["speed_vs_error.csv"], "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        for row in rows:
            writer.writerow(["" if v is None else v if isinstance(v, (str, int)) else repr(float(v))
                             for v in (row[c] for c in columns)])
    units = scene.unit_system()
    v_r = scene.crack_rayleigh_speed()
    _plot_overlay(runs, hs, (("elastic", "elastic energy", "energy"), ("fracture", "fracture energy", "energy")),
                  files["energies_overlay.png"], units)
    front = (("crack_tip_x", "crack tip x", "length"), ("crack_tip_speed", "crack tip speed", "speed"))
    if scene.dim == 3:
        front = (("crack_front", "crack front", "length"), ("crack_front_speed", "crack front speed", "speed"))
    _plot_overlay(runs, hs, front, files["crack_tip_speed_overlay.png"], units,
                  lines=((v_r, "-.", "v_R"), (0.6 * v_r, ":", "0.6 v_R")))
    fine = _run_name("mpm", hs[-1]), _run_name("fem", hs[-1])
    titles = [f"{LABELS[m]}, h = {hs[-1]:g}" for m in METHODS]
    if scene.dim == 2:
        for key, png in (("phase_field_side_by_side.png", "phase_field.png"),
                         ("crack_path_side_by_side.png", "crack_path.png")):
            if not _plot_side_by_side([out / name / png for name in fine], titles, files[key]):
                del files[key]
    else:
        del files["crack_path_side_by_side.png"]
        if not _plot_slices([out / name for name in fine], titles, scene, files["phase_field_side_by_side.png"]):
            del files["phase_field_side_by_side.png"]
    _plot_speed_vs_error(rows, ref, files["speed_vs_error.png"])
    files["comparison.md"].write_text(_markdown(rows, agree, ref, hs[-1], l0, end, model, title, scene.dim))
    plain = {k: v if math.isfinite(v) else None for k, v in {"h": hs[-1], "l0": l0, **agree}.items()}
    plain["reference"] = {k: (v if not isinstance(v, float) or math.isfinite(v) else None)
                          for k, v in ref.items()}
    plain["model"] = model
    files["agreement.json"].write_text(json.dumps(plain, indent=2) + "\n")  # NaN as null
    return files


def _pyplot():
    """``matplotlib.pyplot`` with the non-interactive backend :mod:`pfmpm.plots` selects."""
    from . import plots

    return plots.plt


def _colours(hs: list[float]) -> dict[float, tuple]:
    cmap = _pyplot().get_cmap("viridis")
    return {h: cmap(0.85 * k / max(len(hs) - 1, 1)) for k, h in enumerate(hs)}


_STYLE = {"mpm": "-", "fem": "--"}


def _plot_overlay(runs: dict, hs: list[float], columns, png: Path, units,
                  lines: tuple[tuple[float, str, str], ...] = ()) -> None:
    """Two ``energies.csv`` columns against t, one panel each, every run overlaid.

    ``columns`` are ``(column, label, quantity)``: the quantity gives the
    unit of the axis (:meth:`~pfmpm.scene.units.UnitSystem.label`).
    ``lines`` are ``(value, style, label)`` horizontal lines on the lower panel.
    """
    plt = _pyplot()
    colour = _colours(hs)
    fig, axes = plt.subplots(2, 1, figsize=(7, 6.5), sharex=True)
    for (method, h), run in runs.items():
        e = run["energies"]
        for ax, (column, _, _) in zip(axes, columns):
            ax.plot(e["t"], e[column], _STYLE[method], color=colour[h],
                    label=f"{LABELS[method]}, h = {h:g}")
    for value, style, label in lines:
        axes[1].axhline(value, color="k", linestyle=style, label=label)
    for ax, (_, label, quantity) in zip(axes, columns):
        ax.set_ylabel(units.label(label, quantity))
        ax.legend(fontsize=8)
    axes[1].set_xlabel(units.label("time t", "time"))
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)


def _plot_side_by_side(images: list[Path], titles: list[str], png: Path) -> bool:
    """Put the runs' images side by side; False if one is missing."""
    import matplotlib.image as mpimg

    plt = _pyplot()
    if not all(p.exists() for p in images):
        return False
    pictures = [_trim(mpimg.imread(p)) for p in images]
    height = max(p.shape[0] / p.shape[1] for p in pictures) * 6.0
    fig, axes = plt.subplots(1, len(pictures), figsize=(6.0 * len(pictures), height + 0.5))
    for ax, picture, title in zip(np.atleast_1d(axes), pictures, titles):
        ax.imshow(picture)
        ax.set_title(title, fontsize=14, fontweight="bold")
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(png, dpi=150)
    plt.close(fig)
    return True


def _slice_axes(scene: Scene) -> tuple[np.ndarray, float]:
    """The plane of a 3D comparison's pictures: its in-plane axes (the first
    crack's unit normal and ``output.crack_direction``), their normal ``m``
    (rows 0, 1, 2 of the returned matrix) and the body's middle along ``m``."""
    points = np.asarray(scene.cracks[0].points, dtype=float)
    n = np.cross(points[1] - points[0], points[2] - points[0])
    n /= np.linalg.norm(n)
    d = np.asarray(scene.output.crack_direction, dtype=float)
    d = d - (d @ n) * n
    d /= np.linalg.norm(d)
    m = np.cross(n, d)
    lo, hi = (np.asarray(b) for b in np.reshape(scene.bodies[0].shape.bounds(), (2, 3)))
    corners = np.array([[(lo, hi)[(k >> j) & 1][j] for j in range(3)] for k in range(8)])
    along = corners @ m
    return np.array([n, d, m]), 0.5 * float(along.min() + along.max())


def _last_phase_field(run: Path) -> tuple[np.ndarray, np.ndarray] | None:
    """Positions (N, 3) and phase field of the last frame of a 3D run (MPM
    particles or FEM vertices); None if it wrote no frame."""
    if (run / "particles.pvd").is_file():
        from .post.frames import read_frame, series

        t, path = series(run)[-1]
        frame = read_frame(t, path, 3)
        return frame.x, np.asarray(frame.data["c"], dtype=float)
    xdmf = run / "fields.xdmf"
    if not xdmf.is_file():
        return None
    import xml.etree.ElementTree as ElementTree

    import h5py

    grids = ElementTree.parse(xdmf).getroot().find("Domain").findall("Grid")

    def dataset(item):
        name, _, where = item.text.strip().partition(":")
        return run / name, where

    h5, geometry = dataset(next(g for g in grids if g.get("GridType") == "Uniform").find("Geometry/DataItem"))
    c = next(g for g in grids if g.get("CollectionType") == "Temporal" and g.get("Name") == "c")
    _, values = dataset(c.findall("Grid")[-1].find("Attribute/DataItem"))
    with h5py.File(h5, "r") as f:
        return f[geometry][()][:, :3], f[values][()].ravel()


def _plot_slices(runs: list[Path], titles: list[str], scene: Scene, png: Path) -> bool:
    """The phase field of the last frame of each 3D run on the plane through
    the body's middle spanned by the crack's normal and its direction
    (:func:`_slice_axes`): the particles or vertices of the layer nearest to
    it (one layer, where two lie as near), side by side; False if a run
    wrote no frame."""
    plt = _pyplot()
    fields = [_last_phase_field(run) for run in runs]
    if any(f is None for f in fields):
        return False
    axes_3d, middle = _slice_axes(scene)
    units = scene.unit_system()
    fig, axes = plt.subplots(1, len(fields), figsize=(6.0 * len(fields), 3.6), squeeze=False)
    for ax, (x, c), title in zip(axes[0], fields, titles):
        local = x @ axes_3d.T
        # The one layer of the point nearest the middle (the lattice's layers lie h / n or h apart).
        layer = local[np.argmin(np.abs(local[:, 2] - middle)), 2]
        near = np.abs(local[:, 2] - layer) <= 0.1 * scene.grid.h
        im = ax.tripcolor(local[near, 0], local[near, 1], c[near], shading="gouraud", cmap="inferno",
                          vmin=0.0, vmax=1.0)
        ax.set_aspect("equal")
        ax.set_title(title, fontsize=12, fontweight="bold")
        ax.set_xlabel(units.label("along the crack's normal", "length"))
        ax.set_ylabel(units.label("along crack_direction", "length"))
    fig.colorbar(im, ax=axes[0].tolist(), label="phase field c", shrink=0.8)
    fig.savefig(png, dpi=150, bbox_inches="tight")
    plt.close(fig)
    return True


def _trim(picture: np.ndarray) -> np.ndarray:
    """An RGB(A) image without its white margins."""
    ink = np.any(picture[..., :3] < 0.99, axis=2)
    rows, cols = np.flatnonzero(ink.any(axis=1)), np.flatnonzero(ink.any(axis=0))
    if not rows.size:
        return picture
    return picture[rows[0]: rows[-1] + 1, cols[0]: cols[-1] + 1]


def _plot_speed_vs_error(rows: list[dict], ref: dict, png: Path) -> None:
    """Error against the shared reference over wall time, log-log; a zero
    error (the reference run itself) is left out."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4.8))
    colour = {"mpm": "C0", "fem": "C1"}
    # Labels of the two methods on opposite sides of their points, so equal h do not overlap.
    offset = {"mpm": ((-7, -12), "right"), "fem": ((7, 5), "left")}
    for method in METHODS:
        pts = [(r["wall_s"], r["error"], r["h"]) for r in rows
               if r["method"] == method and r["error"] > 0 and math.isfinite(r["error"])]
        if not pts:
            continue
        wall, err, h = map(np.array, zip(*pts))
        ax.loglog(wall, err, "o-" if method == "mpm" else "s--", color=colour[method],
                  label=LABELS[method])
        xytext, align = offset[method]
        for x, y, hh in zip(wall, err, h):
            ax.annotate(f"h = {hh:g}", (x, y), textcoords="offset points", xytext=xytext,
                        ha=align, fontsize=8, color=colour[method])
    ax.set_xlabel("wall time [s]")
    ax.set_ylabel("relative error of the end fracture energy")
    ax.set_title("error against " + textwrap.fill(_reference_text(ref), 70), fontsize=9)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8)
    ax.margins(0.15)
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)


def _reference_text(ref: dict) -> str:
    """The reference in words."""
    if ref["kind"] == "richardson":
        (hc, hf) = ref["h"]
        source = "observed" if ref["order"] == ref["observed_order"] else "assumed"
        return (f"the Richardson extrapolation ({source} order {ref['order']:.3g}) of the PF-FEM"
                f" runs at h = {hc:g} and {hf:g}: {ref['value']:.5g}")
    return f"the PF-FEM run at h = {ref['h'][0]:g} (one h: no extrapolation): {ref['value']:.5g}"


def _fmt(value, spec: str = ".4g") -> str:
    """A table cell: text and integers as they are, floats with ``spec``, NaN as NaN, None as -."""
    if value is None:
        return "-"
    if isinstance(value, (str, int)):
        return str(value)
    return "NaN" if not math.isfinite(value) else format(value, spec)


def _markdown(rows: list[dict], agree: dict, ref: dict, h: float, l0: float, end: float,
              model: str, title: str = "Borden plate", dim: int = 2) -> str:
    """``comparison.md``: the table of runs, the reference and the agreement at
    the finest common h; of a 3D scene with the crack front in place of the
    tip and no branching."""
    a = agree
    res = _fmt(a["record_interval_us"], ".3f")
    observed = ("" if not math.isfinite(ref["observed_order"]) else
                f" The three finest PF-FEM runs converge at order {ref['observed_order']:.2f}.")
    columns, crack = (COLUMNS, "tip") if dim == 2 else (COLUMNS_3D, "front")
    if dim == 2:
        measures = (" Initiation: the tip 0.5 mm past its start; branching:"
                    " the tip first more than 1 mm off the notch line while more than 5 mm ahead of the notch"
                    f" tip; both read from `energies.csv` rows, so known to within {res} us.")
        plots = (" `phase_field_side_by_side.png`, `crack_path_side_by_side.png`, `speed_vs_error.png`.")
        tip_plot = "`crack_tip_speed_overlay.png`,"
    else:
        measures = (" `crack_front_end`: the crack front (the farthest extent"
                    " of the cracked points along `output.crack_direction`) at the end; `crack_area_end`: the"
                    " crack area int gamma(c) dV at the end. Initiation: the front 0.5 mm past its start, read"
                    f" from `energies.csv` rows, so known to within {res} us.")
        plots = (" `phase_field_side_by_side.png` (the phase field of each run's last frame on the plane"
                 " through the body's middle spanned by the crack's normal and its direction),"
                 " `speed_vs_error.png`.")
        tip_plot = "`crack_tip_speed_overlay.png` (the crack front and its speed),"
    lines = [
        f"# PF-MPM against PF-FEM: {title}",
        "",
        f"{model} phase field, l0 = {l0:g} mm, end time {end:g} us. `error`: relative difference of"
        f" a run's end fracture energy from {_reference_text(ref)}, one reference for both"
        f" methods.{observed}"
        f" `particles` counts the MPM material points, `dofs` the FEM unknowns ({'two' if dim == 2 else 'three'}"
        " displacements and the phase field per vertex)." + measures,
        "",
        "| " + " | ".join(columns) + " |",
        "|" + "---|" * len(columns),
    ]
    lines += ["| " + " | ".join(_fmt(r[c]) for c in columns) + " |" for r in rows]
    lines += [
        "",
        f"## Agreement at h = {h:g} (MPM minus FEM, relative to FEM)",
        "",
        "| quantity | PF-MPM | PF-FEM | difference |",
        "|---|---|---|---|",
        f"| crack initiation ({crack} 0.5 mm past its start) [us], +- {res} | {_fmt(a['initiation_mpm_us'], '.3f')}"
        f" | {_fmt(a['initiation_fem_us'], '.3f')} | {_fmt(a['initiation_diff_us'], '+.3f')} us |",
    ]
    if dim == 2:
        lines.append(f"| crack branching (tip 1 mm off the notch line) [us], +- {res} | {_fmt(a['branch_mpm_us'], '.3f')}"
                     f" | {_fmt(a['branch_fem_us'], '.3f')} | {_fmt(a['branch_diff_us'], '+.3f')} us |")
    lines += [
        f"| elastic energy up to {_fmt(a['elastic_window_us'], '.3f')} us, RMS difference / peak"
        f" {_fmt(a['elastic_peak'])} | | | {_fmt(100 * a['elastic_rms_rel'], '.2f')} % |",
        f"| fracture energy at {_fmt(a['t_end'], '.3f')} us | {_fmt(a['fracture_end_mpm'])}"
        f" | {_fmt(a['fracture_end_fem'])} | {_fmt(100 * a['fracture_end_rel_diff'], '+.2f')} % |",
        f"| fracture energy gained since t = 0 | | | {_fmt(100 * a['fracture_gain_rel_diff'], '+.2f')} % |",
        "",
        f"Plots: `energies_overlay.png`, {tip_plot}" + plots +
        " Each run's own output is in `mpm_h<h>/` (particles.pvd) and `fem_h<h>/` (fields.xdmf).",
        "",
    ]
    return "\n".join(lines)
