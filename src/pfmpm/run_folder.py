"""Run folders: which folder holds a run, the scene it keeps and the identity
its checkpoints carry.

A run writes its output folder's ``scene.toml`` first: the scene as it ran,
with its ``--set`` values applied, which ``pfmpm post`` reads back
(:func:`read_scene`). Its ``summary.json``, written at the start with status
``"running"`` and again at the end, holds the run's id, a random hex string;
every checkpoint holds that id and the SHA-256 of the scene
(:func:`scene_digest`), so that a checkpoint resumes only into the folder of
its own run (:func:`check_resume`).

A run refuses a folder that holds another run (:func:`check_fresh`) unless
told to overwrite it, and then first deletes what that run wrote
(:data:`RUN_FILES`), nothing else.
"""

from __future__ import annotations

import hashlib
import json
import secrets
import shutil
from pathlib import Path

from .output import check_directory
from .scene import Scene
from .scene.toml import read_toml, toml_text

__all__ = ["SCENE_FILE", "RUN_FILES", "RunFolderError", "run_mark", "check_fresh", "check_resume", "start",
           "clear", "read_scene", "scene_digest", "run_id"]

SCENE_FILE = "scene.toml"
"""The run's scene in its output folder."""
SUMMARY = "summary.json"
CHECKPOINTS = "checkpoints"
RUN_FILES = (SCENE_FILE, SUMMARY, "energies.csv", "crack_path.csv", "particles.pvd", "particles_*.vtu",
             "fields.xdmf", "fields.h5", "*.png", "*.gif", "*.mp4", "*.tmp", CHECKPOINTS,
             "forces.csv", "load_displacement.csv", "crack_arms.csv")
"""What a run writes into its folder (``pfmpm run`` and ``fem``; ``pfmpm
animate`` adds a GIF or MP4, ``pfmpm post`` its CSVs and plots), as glob
patterns; ``checkpoints`` is a folder.
Overwriting a run deletes these and leaves everything else; ``scene.toml``
only if a run wrote it (:data:`_HEADER`), not a scene file of the user's."""
_MARKS = (SUMMARY, "energies.csv", "particles.pvd", "fields.xdmf", CHECKPOINTS)
"""The files whose presence makes a folder a run's (also of a pfmpm that wrote no ``scene.toml``)."""
_HEADER = "# The scene of run "
"""The first line of the ``scene.toml`` a run writes."""


class RunFolderError(FileExistsError):
    """An output folder that holds another run, or a checkpoint of another run
    or scene than its folder's; the message names the folder and what is in it."""


def scene_digest(tables: dict) -> str:
    """SHA-256 of a scene dict (:meth:`~pfmpm.scene.Scene.to_dict`, or
    ``scene.toml`` as read), over its keys sorted: the same scene, however
    its TOML was laid out, has the same digest."""
    return hashlib.sha256(json.dumps(tables, sort_keys=True).encode()).hexdigest()


def run_mark(folder: Path | str) -> str | None:
    """The first file that makes ``folder`` a run's, or ``None``: it holds no run."""
    if _kept_scene(Path(folder) / SCENE_FILE):
        return SCENE_FILE
    return next((name for name in _MARKS if (Path(folder) / name).exists()), None)


def _kept_scene(path: Path) -> bool:
    """Whether ``path`` is a ``scene.toml`` that a run wrote."""
    try:
        with open(path) as f:
            return f.readline().startswith(_HEADER)
    except (FileNotFoundError, IsADirectoryError, UnicodeDecodeError):
        return False


def run_id(folder: Path | str) -> str | None:
    """The id of the run in ``folder`` (its ``summary.json``), or ``None``:
    no run, or one written by a pfmpm that kept no id."""
    try:
        return json.loads((Path(folder) / SUMMARY).read_text()).get("run_id")
    except (FileNotFoundError, json.JSONDecodeError):
        return None


def check_fresh(folder: Path | str, overwrite: bool = False) -> Path:
    """``folder`` as the output folder of a new run, which need not exist yet.

    Raises
    ------
    NotADirectoryError
        If it or a folder above it is a file.
    RunFolderError
        If it holds another run and not ``overwrite``, or a ``scene.toml`` that
        no run wrote.
    """
    folder = _check_scene_file(check_directory(folder))
    mark = run_mark(folder)
    if mark is not None and not overwrite:
        raise RunFolderError(f"output directory {folder} holds another run (its {mark}): replace it with"
                             " --overwrite, or choose another directory")
    return folder


def _check_scene_file(folder: Path) -> Path:
    """``folder``, unless its ``scene.toml`` is one no run wrote (a user's scene
    file, which the run's would replace).

    Raises
    ------
    RunFolderError
    """
    path = folder / SCENE_FILE
    if path.exists() and not _kept_scene(path):
        raise RunFolderError(f"output directory {folder} has a {SCENE_FILE} that no run wrote, which the"
                             " run's would replace: choose another directory")
    return folder


def check_resume(folder: Path | str, ckpt) -> Path:
    """``folder`` as the output folder that the run of checkpoint ``ckpt``
    continues in: its own, or one that holds no run.

    Raises
    ------
    NotADirectoryError
        If it or a folder above it is a file.
    RunFolderError
        If ``folder`` keeps a scene other than the checkpoint's, or the id of
        another run (a checkpoint from before runs had ids belongs to no run
        that has one), or has a ``scene.toml`` that no run wrote.
    """
    folder = _check_scene_file(check_directory(folder))
    scene_file = folder / SCENE_FILE
    if ckpt.scene_sha256 is not None and scene_file.is_file():
        digest = scene_digest(read_toml(scene_file))
        if digest != ckpt.scene_sha256:
            raise RunFolderError(f"checkpoint {ckpt.path} is of another scene (sha256 {ckpt.scene_sha256[:12]})"
                                 f" than {scene_file} (sha256 {digest[:12]})")
    own = run_id(folder)
    if own is not None and ckpt.run_id != own:
        theirs = f"run {ckpt.run_id}" if ckpt.run_id else "a run of a pfmpm that kept no run id"
        raise RunFolderError(f"checkpoint {ckpt.path} belongs to {theirs}, not to the run {own} in {folder}")
    return folder


def start(folder: Path, scene: Scene, overwrite: bool = False, resume=None) -> str | None:
    """Make ``folder`` the output folder of a run of ``scene`` and return the run's id.

    A new run (no ``resume``) gets a new id, after :func:`check_fresh`; with
    ``overwrite``, the files of the run that was there are deleted first. A
    resumed one keeps its checkpoint's id, after :func:`check_resume` (none
    from a checkpoint of before runs had ids: the run goes on without, and
    resumes from its older checkpoints as well as its new ones). Either
    writes ``scene.toml``.
    """
    if resume is None:
        check_fresh(folder, overwrite)
        if run_mark(folder) is not None:
            clear(folder)
        ident = secrets.token_hex(8)
    else:
        check_resume(folder, resume)
        ident = resume.run_id
    folder.mkdir(parents=True, exist_ok=True)
    tmp = folder / (SCENE_FILE + ".tmp")
    tmp.write_text(f"{_HEADER}{ident or '(no id)'}, as it ran (its --set values applied).\n"
                   + toml_text(scene.to_dict()))
    tmp.replace(folder / SCENE_FILE)
    return ident


def clear(folder: Path) -> None:
    """Delete the files of :data:`RUN_FILES` in ``folder``: what a run wrote there."""
    for pattern in RUN_FILES:
        for path in folder.glob(pattern):
            if path.name == SCENE_FILE and not _kept_scene(path):
                continue
            if path.is_dir() and not path.is_symlink():
                shutil.rmtree(path)
            else:
                path.unlink()


def read_scene(folder: Path | str) -> Scene:
    """The scene of the run in ``folder``, from its ``scene.toml``.

    Raises
    ------
    FileNotFoundError
        Naming the file, if the folder has none (no run, or one of a pfmpm
        that wrote none).
    SceneError
        If the file is not a valid scene.
    """
    path = Path(folder) / SCENE_FILE
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file: {folder} holds no run, or one of a pfmpm that"
                                " did not keep its scene (give the scene file with --scene)")
    return Scene.from_toml(path)
