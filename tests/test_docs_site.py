"""The documentation site (docs/, as tools/docs.sh builds it) builds without
a single Sphinx warning, and its API pages document the package's names
(Sphinx and MyST-Parser from Debian, which tools/setup.sh installs)."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

def test_the_site_builds_without_warnings(tmp_path):
    html = tmp_path / "html"
    build = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-j", "1", "-b", "html",
         "-d", str(tmp_path / "doctrees"), str(ROOT / "docs"), str(html)],
        capture_output=True, text=True, timeout=300)
    assert build.returncode == 0, build.stderr
    pages = {page: (html / "api" / f"{page}.html").read_text() for page in ("pfmpm", "scene", "post")}
    documented = {
        "pfmpm": ["pfmpm.simulation.Simulation", "pfmpm.SimulationError", "pfmpm.run.run_to_end",
                  "pfmpm.observe.CrackTip", "pfmpm.parallel.DistributedSimulation"],
        "scene": ["pfmpm.scene.Scene", "pfmpm.scene.GridSpec", "pfmpm.scene.Body", "pfmpm.scene.LinearElasticSpec",
                  "pfmpm.scene.NeoHookeanSpec", "pfmpm.scene.Contact", "pfmpm.scene.units.UnitSystem"],
        "post": ["pfmpm.post.tip.initiation_time", "pfmpm.post.forces.mean_forces", "pfmpm.post.fragments.fragments"],
    }
    for page, names in documented.items():
        for name in names:
            assert f'id="{name}"' in pages[page], f"api/{page}.html does not document {name}"
