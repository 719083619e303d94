"""Checkpoints: the complete state of a run in one HDF5 file, and resuming from it.

A checkpoint holds everything a :class:`~pfmpm.simulation.Simulation` carries
from one step to the next, so that a resumed run takes bitwise the same steps
as an uninterrupted one:

- ``/particles/<name>``: every particle column, as
  ``pfmpm._core.Particles.columns()`` lists them (the core arrays ``x``, ``v``,
  ``mass``, ``volume``, ``stress``, ``fext``, ``body``, ``material``, ``id``
  (the particles' global ids, from version 6: :func:`restore` checks them
  against the scene's seeding), then what
  the scene's models keep: ``strain``, and with a phase field ``c``,
  ``history``, ``fracture_energy`` and, with its fourth-order term, ``phi``;
  files written before 2026-12-02 have ``phi`` with every phase field, which
  an isotropic run ignores);
- ``/solver/<name>``: every array of the solver state
  (``pfmpm._core.Solver.state()``): each phase field's warm start, the nodal
  solutions of its last two solves (``phase_field/<k>/c``,
  ``phase_field/<k>/c_previous``; one phase field, ``k = 0``, or with
  multi-body contact one per crackable body in body order), and the grid
  update's works and impulses per slab of 8 node columns along x
  (``grid/slab_sums``, from version 8; before, the meta's totals go into the
  first slab);
- ``/output``: ``energies.csv`` so far (its bytes, ``energies_csv``) and
  the state of each observer of the run (:meth:`pfmpm.observe.Observer.state`),
  an array under each name it gives; those of the standard observers are
  the crack-tip records behind the smoothed tip speeds (``crack_tip``), the
  time each crackable particle cracked and where, by particle id
  (``crack_id``, ``crack_time``, ``crack_xy``, from version 7; for the crack
  path and its arms), the phase-field images
  taken so far (``snapshot_<k>``, at ``snapshot_image_times``) with the
  times still due (``snapshot_times``), and the particle series so far
  (``series_time``, ``series_file``).

The root attributes are ``format``, ``version``, ``sha256`` and ``meta``, a
JSON object with the scene, the run's id and the scene's SHA-256
(:mod:`pfmpm.run_folder`; files written before they were kept have
neither), the step and time, the rest of the solver state
(external and wall work, light-node count, CG statistics; with contact, each body's CG
statistics and the contact record: contact nodes, node-pairs, violations of
C.1-C.4 and the friction work so far), the checkpoint cadence and a status (``"ok"``, or
``"failed"`` for the state left by a run that stopped on an error, kept for
inspection and never resumed from). The SHA-256 checksum covers ``meta`` and
every dataset and is checked on reading.

Files are written to a temporary name in the same directory, flushed to disk
and renamed, so a checkpoint either exists complete or not at all.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import _core
from .scene import Scene
from .scene.loads import MAX_REGIONS
from .scene.stability import grid_dt

FORMAT = "pfmpm-checkpoint"
VERSION = 8
# Version 8 keeps the grid update's sums per slab of nodes (solver/grid/slab_sums):
# the works and impulses are their totals in slab order, so that ranks owning
# whole slabs add them as one process does; the core's restore puts an older
# file's totals into the first slab. Version 7 keeps the crack path by particle id: output/crack_id, with
# crack_time and crack_xy of the cracked particles only, where version 6 had
# a row per crackable particle, in row order (CrackObserver.restore reads
# both). Version 6 keeps the particles' global ids (particles/id); the rows of an
# older file are in the seeding order of its scene, so the seeding gives
# their ids (restore). Version 5 keeps the state of the run's observers as
# arrays under /output; versions 2-4 kept the particle series and the times
# of the phase-field images in meta (``series``, ``snapshot_image_times``),
# which reading turns into those arrays. Version 4 stores the particle columns and the solver
# state by the names the core gives them. Versions 2 and 3 had fixed lists of
# both (_from_version_3);
# version 3 turned the frame in which an anisotropic material's gamma is read
# (docs/method.md), so a version-2 file is read unless one of its materials
# has the fourth-order term.
DIRECTORY = "checkpoints"
"""Subdirectory of a run's output directory that holds its checkpoints."""


class CheckpointError(Exception):
    """A checkpoint that cannot be used; the message names the file and why."""


@dataclass
class Checkpoint:
    """The contents of one checkpoint file.

    Attributes
    ----------
    path : Path
        Where it was read from.
    scene : dict
        The scene as :meth:`~pfmpm.scene.Scene.to_dict` gives it.
    step, time : int, float
        Where the run stood.
    status : str
        ``"ok"`` or ``"failed"``.
    error : str or None
        The error that stopped a failed run.
    checkpoint_every, keep : int
        The cadence the run was started with.
    particles : dict of str to ndarray
        Particle arrays, (N,) or (N, k).
    solver : dict
        The dict of :meth:`pfmpm._core.Solver.state`.
    energies_csv : bytes
        ``energies.csv`` as it was.
    observed : dict of str to ndarray
        The state of the run's observers (:meth:`pfmpm.observe.Observer.state`),
        by name, which :func:`pfmpm.run.run_to_end` hands back to them
        (:meth:`~pfmpm.observe.Observer.restore`). Files from before the
        observers have the same names (``crack_tip``, ``crack_id``,
        ``crack_time``, ``crack_xy``, ``snapshot_*``, ``series_*``), some of
        them missing or older: ``crack_tip`` is (M, 2), time and the one tip's
        distance, in files from before the branch tips were tracked;
        ``crack_id`` is missing before version 7, where ``crack_time`` and
        ``crack_xy`` have a row per crackable particle; and those two are
        missing in files from before they were kept.
    run_id : str or None
        The id of the run that wrote it (:mod:`pfmpm.run_folder`); ``None``
        in files from before runs had ids.
    scene_sha256 : str or None
        :func:`pfmpm.run_folder.scene_digest` of its scene as the run wrote
        it; ``None`` in files from before it was kept.
    version : int
        The format version of the file.
    """

    path: Path
    scene: dict
    step: int
    time: float
    status: str
    error: str | None
    checkpoint_every: int
    keep: int
    particles: dict
    solver: dict
    energies_csv: bytes = b""
    observed: dict = field(default_factory=dict)
    run_id: str | None = None
    scene_sha256: str | None = None
    version: int = VERSION


def file_name(step: int, failed: bool = False) -> str:
    """``step_NNNNNNNNN.h5``, or ``failed_step_NNNNNNNNN.h5`` for a failed run's last state."""
    return f"{'failed_' if failed else ''}step_{step:09d}.h5"


def list_checkpoints(directory: Path | str) -> list[Path]:
    """The resumable checkpoints (not the failed ones) in ``directory``, oldest first."""
    d = Path(directory)
    found = d.glob("step_*.h5") if d.is_dir() else []
    return sorted(found, key=lambda p: int(p.stem.removeprefix("step_")))


def _digest(attrs: dict, arrays: dict[str, np.ndarray]) -> str:
    """SHA-256 over the attributes (as sorted JSON) and every array's name, dtype, shape and bytes."""
    h = hashlib.sha256(json.dumps(attrs, sort_keys=True).encode())
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}:{a.dtype.str}:{a.shape}".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def _state_of(columns: dict[str, np.ndarray], state: dict, run) -> tuple[dict, dict[str, np.ndarray]]:
    """Split the particle ``columns`` and solver ``state`` of a simulation
    (``Simulation.checkpoint_state``) and its output ``run`` into scalar
    attributes and arrays."""
    arrays = {f"particles/{name}": np.asarray(values) for name, values in columns.items()}
    arrays.update({f"solver/{name}": a for name, a in state["arrays"].items()})
    attrs = {"solver": state["scalars"]}
    arrays["output/energies_csv"] = np.frombuffer(run.energies_csv(), dtype=np.uint8)
    arrays.update({f"output/{name}": a for name, a in run.observed().items()})
    return attrs, arrays


def write(directory: Path | str, sim, run, *, every: int, keep: int, status: str = "ok",
          error: str | None = None) -> Path:
    """Write a checkpoint of ``sim`` and its output state ``run`` to ``directory``.

    Parameters
    ----------
    directory : path
        The checkpoint directory (created if missing).
    sim : Simulation
    run : object
        The run's output state, with ``energies_csv()``, ``observed()`` (the
        observers' state by name), ``run_id`` and ``scene_sha256`` (see
        :func:`pfmpm.run.run_to_end`).
    every, keep : int
        The cadence and how many ``"ok"`` checkpoints to keep; older ones are
        deleted after this one is in place (``keep`` is ignored for a failed state).
    status, error : str
        ``"ok"``, or ``"failed"`` with the error message.

    Returns
    -------
    Path
        The file written (by rank 0 of a distributed run, whose other ranks
        give their particles and return the same path).
    """
    import h5py

    directory = Path(directory)
    path = directory / file_name(sim.step, failed=status != "ok")
    whole = sim.checkpoint_state()
    if whole is None:
        return path
    directory.mkdir(parents=True, exist_ok=True)
    attrs, arrays = _state_of(*whole, run)
    attrs.update(format=FORMAT, version=VERSION, scene=sim.scene.to_dict(), run_id=run.run_id,
                 scene_sha256=run.scene_sha256, step=int(sim.step), time=float(sim.time),
                 dt=float(sim.dt), status=status, error=error, checkpoint_every=int(every),
                 keep=int(keep))
    digest = _digest(attrs, arrays)
    tmp = directory / f".{path.name}.tmp"
    with h5py.File(tmp, "w") as f:
        f.attrs["format"] = FORMAT
        f.attrs["version"] = VERSION
        f.attrs["meta"] = json.dumps(attrs, sort_keys=True)
        f.attrs["sha256"] = digest
        for name, a in arrays.items():
            f.create_dataset(name, data=a)
        f.flush()
        os.fsync(f.id.get_vfd_handle())
    os.replace(tmp, path)
    fd = os.open(directory, os.O_RDONLY)  # make the rename itself durable
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
    if status == "ok":
        for old in list_checkpoints(directory)[:-keep]:
            old.unlink()
    return path


def _anisotropic(scene: dict) -> bool:
    """Whether a saved scene has a material with the fourth-order term."""
    from .scene import Scene

    return any(m.fracture is not None and m.fracture.gamma().any() for m in Scene.from_dict(scene).materials)


def read(path: Path | str) -> Checkpoint:
    """Read and verify a checkpoint file.

    Raises
    ------
    CheckpointError
        If the file is missing, not HDF5 or truncated, of another format or
        version, or its checksum does not match its contents.
    """
    import h5py

    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"checkpoint {path}: no such file")
    try:
        with h5py.File(path, "r") as f:
            fmt, version = f.attrs.get("format"), f.attrs.get("version")
            if fmt != FORMAT:
                raise CheckpointError(f"checkpoint {path}: not a pfmpm checkpoint (format {fmt!r})")
            if version not in (VERSION, 7, 6, 5, 4, 3, 2):
                raise CheckpointError(f"checkpoint {path}: format version {version}, this pfmpm reads {VERSION}")
            meta = json.loads(f.attrs["meta"])
            if version == 2 and _anisotropic(meta["scene"]):
                raise CheckpointError(
                    f"checkpoint {path}: format version {version} holds an anisotropic run from before "
                    f"the orientation frame of version 3 (docs/method.md); start the run again")
            digest = f.attrs["sha256"]
            arrays: dict[str, np.ndarray] = {}
            f.visititems(lambda name, obj: arrays.__setitem__(name, obj[()])
                         if isinstance(obj, h5py.Dataset) else None)
    except CheckpointError:
        raise
    except (OSError, KeyError, ValueError, TypeError) as err:
        # h5py raises OSError for a truncated or non-HDF5 file and KeyError or
        # ValueError for missing or damaged objects inside one.
        raise CheckpointError(f"checkpoint {path}: cannot be read ({err})") from None
    if _digest(meta, arrays) != digest:
        raise CheckpointError(f"checkpoint {path}: checksum mismatch, the file is corrupt")
    if version >= 4:
        particles = {name.removeprefix("particles/"): a for name, a in arrays.items()
                     if name.startswith("particles/")}
        solver = {"scalars": meta["solver"],
                  "arrays": {name.removeprefix("solver/"): a for name, a in arrays.items()
                             if name.startswith("solver/")}}
    else:
        particles, solver = _from_version_3(meta, arrays)
    if "wall_work" not in solver["scalars"]:
        # Files from before the wall work was kept: none was done without walls.
        if meta["scene"].get("walls"):
            raise CheckpointError(f"checkpoint {path}: written before the work of the walls was"
                                  " recorded, which this scene's energy balance needs; start the run again")
        solver["scalars"]["wall_work"] = 0.0
    if "wall_impulse/left/x" not in solver["scalars"]:
        # Files from before the walls' impulses were kept: none without walls.
        if meta["scene"].get("walls"):
            raise CheckpointError(f"checkpoint {path}: written before the walls' impulses were"
                                  " recorded, which this scene's energies.csv reports; start the run again")
        for side in ("left", "right", "bottom", "top"):
            for d in "xy":
                solver["scalars"][f"wall_impulse/{side}/{d}"] = 0.0
    if "contact/nodes" in solver["scalars"] and "contact/pair_impulse" not in solver["arrays"]:
        # Files from before the contact impulses per pair were kept: they count
        # from the resume, and the run's energies.csv, whose header the file
        # keeps, has no column for them.
        solver["arrays"]["contact/pair_impulse"] = np.zeros(2 * _core.max_field_pairs)
    for k in range(MAX_REGIONS):
        # Files from before prescribed regions: there were none.
        for name in ("work", "impulse/x", "impulse/y", "displacement/x", "displacement/y"):
            solver["scalars"].setdefault(f"region/{k}/{name}", 0.0)
    if "dt" not in meta and meta["scene"].get("time", {}).get("dt") is None:
        # Files from before the default step kept below a lone particle's
        # limit (issue 49): the run goes on with the step it ran with, the
        # grid's limit, as a fixed time.dt.
        meta["scene"].setdefault("time", {})["dt"] = grid_dt(Scene.from_dict(meta["scene"]))
    for key in [k for k in solver["scalars"] if k.startswith("phase_field/") and k.endswith("/passes")]:
        # Files from before the bounded solve could hand over to MPRGP: none did.
        solver["scalars"].setdefault(key.removesuffix("passes") + "handovers", 0)
    observed = {name.removeprefix("output/"): a for name, a in arrays.items()
                if name.startswith("output/") and name != "output/energies_csv"}
    if version < 5:
        # Before version 5 the particle series and the times of the images
        # taken were kept in meta.
        observed["series_time"] = np.array([t for t, _ in meta["series"]], dtype=float)
        observed["series_file"] = np.array([name for _, name in meta["series"]], dtype="S")
        observed["snapshot_image_times"] = np.asarray(meta["snapshot_image_times"], dtype=float)
    return Checkpoint(
        path=path, scene=meta["scene"], step=meta["step"], time=meta["time"], status=meta["status"],
        error=meta["error"], checkpoint_every=meta["checkpoint_every"], keep=meta["keep"],
        particles=particles, solver=solver,
        energies_csv=arrays["output/energies_csv"].tobytes(), observed=observed,
        run_id=meta.get("run_id"), scene_sha256=meta.get("scene_sha256"), version=int(version))


def _from_version_3(meta: dict, arrays: dict[str, np.ndarray]) -> tuple[dict, dict]:
    """The particle columns and solver state of a version-2 or -3 file, by the
    names of version 4.

    Those versions kept the particle arrays x, v, mass, volume, strain,
    stress, fext, body, material, c, history, phi (the last three also where
    nothing cracks), and the fracture energy and the phase-field warm start
    with the solver (one, or per crackable body under ``solver/fields/<k>``).
    Their runs solved the phase field without the bound 0 <= c <= 1, so every
    fracture table of the saved scene gets ``bound = false``: the run resumes
    as it was run.
    """
    for material in meta["scene"].get("materials", []):
        if isinstance(material.get("fracture"), dict):
            material["fracture"]["bound"] = False
    old = meta["solver"]
    stats_keys = ("solves", "iterations", "last_iterations", "start_residual", "last_residual",
                  "unknowns")
    scalars = {key: old[key] for key in ("time", "step", "external_work", "light_nodes")}
    solver_arrays: dict[str, np.ndarray] = {}
    energies = []

    def phase_field(k: int, c, c_previous, stats) -> None:
        solver_arrays[f"phase_field/{k}/c"] = c
        solver_arrays[f"phase_field/{k}/c_previous"] = c_previous
        scalars.update({f"phase_field/{k}/{key}": stats[key] for key in stats_keys})
        scalars.update({f"phase_field/{k}/{key}": 0 for key in ("passes", "last_passes", "at_bound")})

    if (fields := old["fields"]) is not None:
        for k, stats in enumerate(fields["phase_field_stats"]):
            phase_field(k, arrays[f"solver/fields/{k}/c"], arrays[f"solver/fields/{k}/c_previous"], stats)
            energies.append(arrays[f"solver/fields/{k}/fracture_energy"])
        scalars.update({f"contact/{key}": value for key, value in fields["contact"].items()})
    elif len(arrays["solver/phase_field_c"]):
        phase_field(0, arrays["solver/phase_field_c"], arrays["solver/phase_field_c_previous"],
                    old["phase_field_stats"])
        energies.append(arrays["solver/fracture_energy"])
    names = ["x", "v", "mass", "volume", "strain", "stress", "fext", "body", "material"]
    particles = {name: arrays[f"particles/{name}"] for name in names}
    if solver_arrays:  # only a run with a phase field has its columns
        particles.update({name: arrays[f"particles/{name}"] for name in ("c", "history", "phi")})
        # Each crackable body's solve wrote its own particles' entries, zero elsewhere.
        particles["fracture_energy"] = np.sum(energies, axis=0)
    return particles, {"scalars": scalars, "arrays": solver_arrays}


def find(where: Path | str) -> Checkpoint:
    """The checkpoint to resume from: ``where`` itself if it is a file, else
    the newest checkpoint of the run directory ``where``.

    Raises
    ------
    CheckpointError
        If there is none, if it cannot be read (an older one may be passed
        explicitly), or if it is the state of a failed run.
    """
    where = Path(where)
    if where.is_dir():
        found = list_checkpoints(where / DIRECTORY)
        if not found:
            raise CheckpointError(f"--resume {where}: no checkpoints in {where / DIRECTORY}")
        try:
            ckpt = read(found[-1])
        except CheckpointError as err:
            older = f"; older: {found[-2]}" if len(found) > 1 else ""
            raise CheckpointError(f"{err}{older}") from None
    else:
        ckpt = read(where)
    if ckpt.status != "ok":
        raise CheckpointError(f"checkpoint {ckpt.path}: the state of a failed run ({ckpt.error}),"
                              " kept for inspection; resume from an earlier checkpoint")
    return ckpt


def restore(sim, ckpt: Checkpoint) -> None:
    """Put the particle and solver state of ``ckpt`` into ``sim``, built on the
    checkpoint's scene (the run's observers take ``ckpt.observed``:
    :func:`pfmpm.run.run_to_end`).

    The particles' ids are not written but checked: ``sim`` seeded its
    particles from the same scene, and a run neither adds nor removes nor
    reorders particles, so the checkpoint's ids must be those of the seeding,
    row by row. Files before version 6 kept no ids; their rows are in the
    seeding order of their scene (the order the whole run kept), so the
    seeding's ids are theirs.

    Raises
    ------
    CheckpointError
        If an array does not fit the simulation, or the ids are not the
        seeding's (naming the first row that differs).
    """
    columns = [c["name"] for c in sim.particles.columns()]
    seeded = sim.seeded_ids()
    stored = dict(ckpt.particles)
    if ckpt.version < 6:
        stored.setdefault("id", seeded)
    if "phi" not in columns:
        # Files before 2026-12-02 kept the orientation of every phase-field
        # run; only the fourth-order term has it, and nothing else reads it.
        stored.pop("phi", None)
    if extra := sorted(stored.keys() - set(columns)):
        raise CheckpointError(f"checkpoint {ckpt.path}: particles/{extra[0]} is not a column of this scene")
    for name in columns:
        if name not in stored:
            raise CheckpointError(f"checkpoint {ckpt.path}: particles/{name} is missing")
        local, value = getattr(sim.particles, name), stored[name]
        shape = (len(seeded),) + local.shape[1:]  # every particle's row
        if shape != value.shape or local.dtype != value.dtype:
            raise CheckpointError(f"checkpoint {ckpt.path}: particles/{name} has shape {value.shape},"
                                  f" the scene gives {shape}")
        if name == "id" and len(differ := np.flatnonzero(value != seeded)):
            p = int(differ[0])
            raise CheckpointError(f"checkpoint {ckpt.path}: particles/id of particle {p} is {value[p]},"
                                  f" the scene seeds id {seeded[p]} there")
    try:
        sim.restore_state({name: stored[name] for name in columns}, ckpt.solver)
    except ValueError as err:
        raise CheckpointError(f"checkpoint {ckpt.path}: {err}") from None
