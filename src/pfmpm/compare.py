"""PF-MPM against PF-FEM on the Borden plate: agreement, and speed against error.

:func:`compare_borden` runs the Borden plate scene (shipped as
``pfmpm/scenes/borden_plate.toml``; ``demos/borden_plate.toml`` links to it)
with both methods at a list of grid spacings ``h`` and one length scale
``l0``, then writes, into its output directory:

``speed_vs_error.csv``
    One row per run, columns :data:`COLUMNS`.  ``error`` is the relative
    difference of the end fracture energy from that of the finest run (least
    ``h``) of the same method; ``error_vs_other`` from that of the finest run
    of the other method.
``energies_overlay.png``, ``crack_tip_speed_overlay.png``
    Elastic and fracture energy, and crack-tip position and speed, of every
    run (MPM solid, FEM dashed; one colour per ``h``).
``phase_field_side_by_side.png``
    The phase-field snapshots (``phase_field.png``) of the two finest runs.
``speed_vs_error.png``
    Relative error against wall time, log-log.
``comparison.md``
    The table and the :func:`agreement` of the two methods at the finest
    common ``h``.
``agreement.json``
    That agreement with ``h`` and ``l0`` (NaN written as ``null``).

Each run keeps its own output in ``mpm_h<h>/`` and ``fem_h<h>/``.  The MPM
runs use the OpenMP threads the core is given (``OMP_NUM_THREADS``); the
FEM runs are serial, in this process.

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
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import _core, scenes
from .output import read_csv
from .post.tip import branch_time, initiation_time, read_columns
from .scene import Crack, Scene
from .scene.toml import read_toml

__all__ = ["COLUMNS", "Comparison", "agreement", "branch_time", "comparison_overrides",
           "compare_borden", "initiation_time"]

BORDEN_SCENE = scenes.path("borden_plate")
"""The Borden plate scene shipped with the package."""
DEFAULT_H = (0.5, 0.25)
DEFAULT_L0 = 0.5
DEFAULT_END = 80.0
METHODS = ("mpm", "fem")
LABELS = {"mpm": "PF-MPM", "fem": "PF-FEM"}

COLUMNS = ["method", "h", "dofs_or_particles", "steps", "wall_s", "fracture_energy_end",
           "elastic_energy_peak", "crack_tip_x_end", "branch_time_us", "error", "error_vs_other"]
"""Columns of ``speed_vs_error.csv``."""

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
    files : dict of str -> Path
        The files written, by name.
    """

    out_dir: Path
    rows: list[dict]
    agreement: dict
    h_common: float
    files: dict[str, Path] = field(default_factory=dict)


# -- measures on energies.csv -------------------------------------------------


def agreement(mpm_csv, fem_csv) -> dict:
    """How closely a PF-MPM run follows a PF-FEM run of the same scene.

    Differences are MPM minus FEM; relative ones are relative to the FEM run
    (the reference).

    Parameters
    ----------
    mpm_csv, fem_csv : path or mapping of str -> ndarray
        The two runs' ``energies.csv`` (with crack-tip columns), or their
        columns.

    Returns
    -------
    dict
        ``initiation_mpm_us``, ``initiation_fem_us``
            Crack initiation times (:func:`initiation_time`), NaN if none.
        ``initiation_diff_us``
            Their difference.
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
    return {
        "initiation_mpm_us": t_mpm,
        "initiation_fem_us": t_fem,
        "initiation_diff_us": t_mpm - t_fem,
        "elastic_window_us": float(window),
        "elastic_peak": peak,
        "elastic_rms_rel": rms / peak if peak > 0 else math.nan,
        "t_end": float(t_end),
        "fracture_end_mpm": end_mpm,
        "fracture_end_fem": end_fem,
        "fracture_end_rel_diff": (end_mpm - end_fem) / end_fem,
        "fracture_gain_rel_diff": (gain_mpm - gain_fem) / gain_fem if gain_fem > 0 else math.nan,
    }


# -- the runs -----------------------------------------------------------------


def comparison_overrides(scene: dict, h: float, l0: float, end: float,
                         model: str = "AT2") -> list[str]:
    """Scene overrides of one comparison run: grid spacing ``h``, the length
    scale ``l0`` and phase-field ``model`` (AT1 or AT2) of every material that
    can crack, end time ``end``, and no particle output.

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
            + [f"time.end={end!r}", "output.particles=false"])


def _with_snapshots(scene: Scene) -> Scene:
    """The scene with its snapshot times cut at ``time.end``, which is added."""
    end = scene.time.end
    times = sorted({t for t in scene.output.snapshots if t < end} | {end})
    return dataclasses.replace(scene, output=dataclasses.replace(scene.output, snapshots=tuple(times)))


def _run_name(method: str, h: float) -> str:
    return f"{method}_h{h:g}"


def compare_borden(out_dir: Path | str, hs: Sequence[float] = DEFAULT_H, l0: float = DEFAULT_L0,
                   end: float = DEFAULT_END, scene_path: Path | str = BORDEN_SCENE,
                   overrides: Sequence[str] = (), progress: bool = True, log=print,
                   model: str = "AT2") -> Comparison:
    """Run the Borden plate with PF-MPM and PF-FEM at each ``h`` and compare.

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
        The Borden plate scene file.
    overrides : sequence of str
        More ``key=value`` overrides for both methods' scenes, applied after
        those of :func:`comparison_overrides` (the FEM path ignores particle
        counts).
    progress : bool
        Show progress bars.
    log : callable
        Called with one line of text per run started and finished.
    model : str
        The phase-field model of both methods, ``"AT2"`` (the paper's) or
        ``"AT1"`` (:class:`~pfmpm.scene.Fracture`).

    Returns
    -------
    Comparison

    Raises
    ------
    SceneError
        If a scene is invalid (e.g. ``l0 < h``) or the FEM path cannot run
        it; raised before any run.
    pfmpm.SimulationError
        If a run fails.
    KeyboardInterrupt
        If a run is interrupted; the runs finished so far keep their output.
    """
    from mpi4py import MPI

    from .fem import FemSimulation
    from .simulation import Simulation

    if not hs:
        raise ValueError("hs: give at least one grid spacing")
    hs = sorted({float(h) for h in hs}, reverse=True)  # coarse to fine
    out = Path(out_dir)
    tables = read_toml(scene_path)
    by_h = {h: _with_snapshots(Scene.from_dict(tables,
                                               comparison_overrides(tables, h, l0, end, model)
                                               + list(overrides)))
            for h in hs}
    # The FEM set-up is cheap and checks that its path supports the scene.
    fems = {h: FemSimulation(by_h[h], MPI.COMM_SELF) for h in hs}
    out.mkdir(parents=True, exist_ok=True)
    runs = {}
    for h in hs:
        for method in METHODS:
            name = _run_name(method, h)
            sim = Simulation(by_h[h]) if method == "mpm" else fems.pop(h)
            size = len(sim.particles) if method == "mpm" else sim.summary()["dofs"]
            what = "particles" if method == "mpm" else "dofs"
            log(f"{LABELS[method]} h = {h:g}: {size} {what}, {by_h[h].steps()} steps -> {out / name}")
            result = sim.run(out / name, progress=progress)
            if result.status == "interrupted":
                raise KeyboardInterrupt
            if result.status != "completed":
                raise _core.SimulationError(f"{LABELS[method]} at h = {h:g}: {result.error}")
            log(f"  done in {result.wall_s:.1f} s")
            runs[method, h] = {"size": size, "steps": result.steps, "wall_s": result.wall_s,
                               "energies": read_csv(out / name / "energies.csv")}
    scene = by_h[hs[-1]]
    rows = _table(runs, hs, scene.cracks[0])
    fine = hs[-1]
    agree = agreement(runs["mpm", fine]["energies"], runs["fem", fine]["energies"])
    files = _write_outputs(out, rows, agree, runs, hs, scene, l0, end, model)
    return Comparison(out_dir=out, rows=rows, agreement=agree, h_common=fine, files=files)


def _table(runs: dict, hs: list[float], crack: Crack) -> list[dict]:
    """The rows of ``speed_vs_error.csv``."""
    fine = hs[-1]
    finest = {method: runs[method, fine]["energies"]["fracture"][-1] for method in METHODS}
    rows = []
    for method in METHODS:
        other = METHODS[1 - METHODS.index(method)]
        for h in hs:
            run = runs[method, h]
            e = run["energies"]
            f_end = float(e["fracture"][-1])
            rows.append({
                "method": method,
                "h": h,
                "dofs_or_particles": run["size"],
                "steps": run["steps"],
                "wall_s": run["wall_s"],
                "fracture_energy_end": f_end,
                "elastic_energy_peak": float(e["elastic"].max()),
                "crack_tip_x_end": float(e["crack_tip_x"][-1]),
                "branch_time_us": branch_time(e, crack),
                "error": abs(f_end - finest[method]) / finest[method],
                "error_vs_other": abs(f_end - finest[other]) / finest[other],
            })
    return rows


# -- output -------------------------------------------------------------------


def _write_outputs(out: Path, rows: list[dict], agree: dict, runs: dict, hs: list[float],
                   scene: Scene, l0: float, end: float, model: str) -> dict[str, Path]:
    """Write the CSV, the plots and ``comparison.md``; return their paths by name."""
    files = {name: out / name for name in (
        "speed_vs_error.csv", "energies_overlay.png", "crack_tip_speed_overlay.png",
        "phase_field_side_by_side.png", "speed_vs_error.png", "comparison.md")}
    with open(files["speed_vs_error.csv"], "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(COLUMNS)
        for row in rows:
            writer.writerow([v if isinstance(v, (str, int)) else repr(float(v))
                             for v in (row[c] for c in COLUMNS)])
    v_r = scene.crack_rayleigh_speed()
    _plot_overlay(runs, hs, ("elastic", "fracture"), files["energies_overlay.png"])
    _plot_overlay(runs, hs, ("crack_tip_x", "crack_tip_speed"), files["crack_tip_speed_overlay.png"],
                  lines=((v_r, "-.", "v_R"), (0.6 * v_r, ":", "0.6 v_R")))
    fine = _run_name("mpm", hs[-1]), _run_name("fem", hs[-1])
    if not _plot_side_by_side([out / name / "phase_field.png" for name in fine],
                              [f"{LABELS[m]}, h = {hs[-1]:g}" for m in METHODS],
                              files["phase_field_side_by_side.png"]):
        del files["phase_field_side_by_side.png"]
    _plot_speed_vs_error(rows, files["speed_vs_error.png"])
    files["comparison.md"].write_text(_markdown(rows, agree, hs[-1], l0, end, model))
    plain = {k: v if math.isfinite(v) else None for k, v in {"h": hs[-1], "l0": l0, **agree}.items()}
    plain["model"] = model
    (out / "agreement.json").write_text(json.dumps(plain, indent=2) + "\n")  # NaN as null
    files["agreement.json"] = out / "agreement.json"
    return files


def _pyplot():
    """``matplotlib.pyplot`` with the non-interactive backend :mod:`pfmpm.plots` selects."""
    from . import plots

    return plots.plt


def _colours(hs: list[float]) -> dict[float, tuple]:
    cmap = _pyplot().get_cmap("viridis")
    return {h: cmap(0.85 * k / max(len(hs) - 1, 1)) for k, h in enumerate(hs)}


_STYLE = {"mpm": "-", "fem": "--"}


def _plot_overlay(runs: dict, hs: list[float], columns: tuple[str, str], png: Path,
                  lines: tuple[tuple[float, str, str], ...] = ()) -> None:
    """Two ``energies.csv`` columns against t, one panel each, every run overlaid.

    ``lines`` are ``(value, style, label)`` horizontal lines on the lower panel.
    """
    plt = _pyplot()
    colour = _colours(hs)
    fig, axes = plt.subplots(2, 1, figsize=(7, 6.5), sharex=True)
    for (method, h), run in runs.items():
        e = run["energies"]
        for ax, column in zip(axes, columns):
            ax.plot(e["t"], e[column], _STYLE[method], color=colour[h],
                    label=f"{LABELS[method]}, h = {h:g}")
    for value, style, label in lines:
        axes[1].axhline(value, color="k", linestyle=style, label=label)
    for ax, column in zip(axes, columns):
        ax.set_ylabel(column.replace("_", " "))
        ax.legend(fontsize=8)
    axes[1].set_xlabel("t")
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)


def _plot_side_by_side(images: list[Path], titles: list[str], png: Path) -> bool:
    """Put the runs' ``phase_field.png`` side by side; False if one is missing."""
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


def _trim(picture: np.ndarray) -> np.ndarray:
    """An RGB(A) image without its white margins."""
    ink = np.any(picture[..., :3] < 0.99, axis=2)
    rows, cols = np.flatnonzero(ink.any(axis=1)), np.flatnonzero(ink.any(axis=0))
    if not rows.size:
        return picture
    return picture[rows[0]: rows[-1] + 1, cols[0]: cols[-1] + 1]


def _plot_speed_vs_error(rows: list[dict], png: Path) -> None:
    """Error against wall time; zero errors (a method's finest run against itself) left out."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6, 4.5))
    colour = {"mpm": "C0", "fem": "C1"}
    for method in METHODS:
        mine = [r for r in rows if r["method"] == method]
        other = METHODS[1 - METHODS.index(method)]
        for key, fill, what in (("error_vs_other", True, f"vs finest {LABELS[other]}"),
                                ("error", False, f"vs finest {LABELS[method]}")):
            pts = [(r["wall_s"], r[key], r["h"]) for r in mine if r[key] > 0 and math.isfinite(r[key])]
            if not pts:
                continue
            wall, err, h = map(np.array, zip(*pts))
            ax.loglog(wall, err, "o-" if fill else "s--", color=colour[method],
                      markerfacecolor=colour[method] if fill else "none",
                      label=f"{LABELS[method]}, {what}")
            for x, y, hh in zip(wall, err, h):
                ax.annotate(f"h = {hh:g}", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=7)
    ax.set_xlabel("wall time [s]")
    ax.set_ylabel("relative error of the end fracture energy")
    ax.set_title("zero errors (finest run vs itself) not shown", fontsize=9)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)


def _fmt(value, spec: str = ".4g") -> str:
    """A table cell: text and integers as they are, floats with ``spec``, NaN as NaN."""
    if isinstance(value, (str, int)):
        return str(value)
    return "NaN" if not math.isfinite(value) else format(value, spec)


def _markdown(rows: list[dict], agree: dict, h: float, l0: float, end: float, model: str) -> str:
    """``comparison.md``: the table of runs and the agreement at the finest common h."""
    lines = [
        "# PF-MPM against PF-FEM: Borden plate",
        "",
        f"{model} phase field, l0 = {l0:g} mm, end time {end:g} us. Errors: relative difference of the end fracture"
        " energy from the finest run of the same method (`error`) and of the other method"
        " (`error_vs_other`). Branch time: the tip first more than 1 mm off the notch line"
        " while more than 5 mm ahead of the notch tip.",
        "",
        "| " + " | ".join(COLUMNS) + " |",
        "|" + "---|" * len(COLUMNS),
    ]
    lines += ["| " + " | ".join(_fmt(r[c]) for c in COLUMNS) + " |" for r in rows]
    a = agree
    lines += [
        "",
        f"## Agreement at h = {h:g} (MPM minus FEM, relative to FEM)",
        "",
        "| quantity | PF-MPM | PF-FEM | difference |",
        "|---|---|---|---|",
        f"| crack initiation (tip 0.5 mm past its start) [us] | {_fmt(a['initiation_mpm_us'], '.3f')}"
        f" | {_fmt(a['initiation_fem_us'], '.3f')} | {_fmt(a['initiation_diff_us'], '+.3f')} us |",
        f"| elastic energy up to {_fmt(a['elastic_window_us'], '.3f')} us, RMS difference / peak"
        f" {_fmt(a['elastic_peak'])} | | | {_fmt(100 * a['elastic_rms_rel'], '.2f')} % |",
        f"| fracture energy at {_fmt(a['t_end'], '.3f')} us | {_fmt(a['fracture_end_mpm'])}"
        f" | {_fmt(a['fracture_end_fem'])} | {_fmt(100 * a['fracture_end_rel_diff'], '+.2f')} % |",
        f"| fracture energy gained since t = 0 | | | {_fmt(100 * a['fracture_gain_rel_diff'], '+.2f')} % |",
        "",
        "Plots: `energies_overlay.png`, `crack_tip_speed_overlay.png`,"
        " `phase_field_side_by_side.png`, `speed_vs_error.png`. Each run's own output is in"
        " `mpm_h<h>/` and `fem_h<h>/`.",
        "",
    ]
    return "\n".join(lines)
