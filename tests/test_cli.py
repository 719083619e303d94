"""The pfmpm command: run output, overrides, errors, Ctrl-C and bench."""

import json
import os
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np
import pytest

from pfmpm.output import read_csv

ROOT = Path(__file__).resolve().parents[1]
BAR = ROOT / "demos" / "vibrating_bar.toml"


def pfmpm(*args, **kw):
    return subprocess.run([sys.executable, "-m", "pfmpm.cli", *map(str, args)], capture_output=True, text=True, **kw)


def test_run_writes_energies_particles_and_summary(tmp_path):
    out = tmp_path / "bar"
    r = pfmpm("run", BAR, "--out", out, "--quiet", "--set", "time.end=5.0", "--set", "output.every=20")
    assert r.returncode == 0, r.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed"
    assert summary["particles"] == 25 * 2 * 9
    assert summary["steps"] * summary["dt"] == pytest.approx(5.0, abs=summary["dt"])
    assert {"explicit_mpm", "walls"} <= set(summary["modules"])

    e = read_csv(out / "energies.csv")
    for column in ("t", "kinetic", "elastic", "external_work", "momentum_x", "momentum_y"):
        assert column in e
    assert e["t"][0] == 0.0 and e["t"][-1] == pytest.approx(summary["t_end"])
    assert e["kinetic"][0] == 0.0 and e["external_work"][-1] > 0.0

    # The PVD index lists every snapshot; each VTU reads back with meshio.
    entries = ET.parse(out / "particles.pvd").getroot().findall(".//DataSet")
    assert len(entries) == len(list(out.glob("particles_*.vtu"))) >= 3
    mesh = meshio.read(out / entries[-1].get("file"))
    assert mesh.points.shape == (450, 3)
    assert mesh.point_data["velocity"].shape == (450, 3)
    assert mesh.point_data["stress"].shape == (450, 6)
    assert set(np.unique(mesh.point_data["body"])) == {0}
    assert (out / "energies.png").stat().st_size > 0


def test_bad_scene_is_one_line_error_naming_the_key(tmp_path):
    r = pfmpm("run", BAR, "--out", tmp_path, "--set", "materials.soft.nu=0.5")
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "materials[0].nu = 0.5" in lines[0], r.stderr
    assert "Traceback" not in r.stderr

    bad = tmp_path / "bad.toml"
    bad.write_text(BAR.read_text().replace("degree = 2", "degree = 2\nspacing = 1.0"))
    r = pfmpm("run", bad, "--out", tmp_path)
    assert r.returncode == 2 and "grid.spacing: unknown key" in r.stderr


def test_missing_scene_file(tmp_path):
    r = pfmpm("run", tmp_path / "nope.toml")
    assert r.returncode == 2 and "nope.toml" in r.stderr and "Traceback" not in r.stderr


def test_ctrl_c_stops_cleanly_with_output_intact(tmp_path):
    out = tmp_path / "long"
    args = ["run", BAR, "--out", out, "--quiet", "--set", "time.end=1e4", "--set", "output.every=500"]
    proc = subprocess.Popen([sys.executable, "-m", "pfmpm.cli", *map(str, args)], stderr=subprocess.PIPE, text=True)
    csv = out / "energies.csv"
    deadline = time.time() + 60
    while time.time() < deadline and (not csv.exists() or len(csv.read_text().splitlines()) < 50):
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "interrupted at step" in err and "Traceback" not in err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted" and 0 < summary["steps"] < summary["steps_planned"]
    e = read_csv(csv)  # every row complete
    assert e["step"][-1] <= summary["steps"] and np.all(np.isfinite(e["kinetic"]))
    for entry in ET.parse(out / "particles.pvd").getroot().findall(".//DataSet"):
        assert len(meshio.read(out / entry.get("file")).points) == 450


def test_failed_run_keeps_output_and_says_where(tmp_path):
    # A fixed dt is checked against the stability limit, but a body that
    # flies off the grid is only found while running.
    out = tmp_path / "fly"
    r = pfmpm("run", BAR, "--out", out, "--quiet", "--set", "walls=[]", "--set", "bodies.bar.velocity=[2.0, 0.0]")
    assert r.returncode == 1
    assert "outside the grid" in r.stderr and "step" in r.stderr
    assert json.loads((out / "summary.json").read_text())["status"] == "failed"
    assert len(read_csv(out / "energies.csv")["t"]) >= 1


def test_bench_json():
    r = pfmpm("bench", "--particles", "2000", "--steps", "3", "--repeats", "1", "--json")
    assert r.returncode == 0, r.stderr
    result = json.loads(r.stdout)
    assert result["particles"] == 15 * 15 * 9  # ceil(sqrt(2000 / 9)) = 15 cells a side
    assert result["steps"] == 3 and result["threads"] >= 1
    assert result["particle_steps_per_s"] == pytest.approx(result["particles"] * 3 / result["seconds"])
