"""The scenes of the paper problems, shipped with the package.

Kakouris & Triantafyllou (2019): the Borden plate (isotropic, cubic and
orthotropic surface energy), the composite plate, the disk-beam impact and the
two rings. Homel & Herbold (2017): the billet, the wedge, disk and block, and the
dynamic Brazilian disk. ``demos/<name>.toml`` in the repository are links to these files,
and ``benchmarks/<name>/`` holds each problem's measure and smoke settings.
"""

from importlib import resources
from pathlib import Path

__all__ = ["names", "path"]


def names() -> list[str]:
    """The names of the shipped scenes, e.g. ``"borden_plate"``."""
    return sorted(f.name.removesuffix(".toml") for f in resources.files(__name__).iterdir()
                  if f.name.endswith(".toml"))


def path(name: str) -> Path:
    """The file of the shipped scene ``name``.

    Raises
    ------
    FileNotFoundError
        If no scene has that name.
    """
    found = resources.files(__name__) / f"{name}.toml"
    if not found.is_file():
        raise FileNotFoundError(f"no shipped scene {name!r} (have: {', '.join(names())})")
    return Path(str(found))
