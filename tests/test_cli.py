"""The pfmpm command: run output, output folders, overrides, errors, Ctrl-C, post and bench."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np
import pytest

from pfmpm import checkpoint
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
    assert result["model"] == "linear_elastic"


def test_bench_scenes_reports_each_scene_s_particles_and_memory():
    """``pfmpm bench --scenes``: a row per scene file, run in a process of its
    own; the bar's particle count is its scene's, its memory per particle
    positive (the peak less the size before the scene was built)."""
    r = pfmpm("bench", "--scenes", str(BAR), "--steps", "2", "--set", "time.end=1")
    assert r.returncode == 0, r.stderr
    row = next(line for line in r.stdout.splitlines() if line.startswith("| vibrating"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    from pfmpm.scene import Scene
    assert int(cells[1]) == len(Scene.from_toml(BAR).particles()["x"])
    assert float(cells[5]) > 0


@pytest.mark.parametrize("case", ["not utf-8", "a directory", "out is a file", "out under a file"])
def test_bad_paths_are_one_line_errors(tmp_path, case):
    """Issue 21, defect 2: each of these gave a traceback."""
    scene, out = BAR, tmp_path / "out"
    if case == "not utf-8":
        scene = tmp_path / "g.toml"
        scene.write_bytes(b"\x80garbage")
        named = f"{scene}: not UTF-8 text"
    elif case == "a directory":
        scene = ROOT / "demos"
        named = f"{scene}: is a directory, not a scene file"
    else:
        (tmp_path / "file").write_text("")
        out = tmp_path / "file" if case == "out is a file" else tmp_path / "file" / "sub"
        named = f"output directory {out} " + ("is a file" if case == "out is a file" else "lies under the file")
    for command in (["run", scene, "--out", out], ["fem", scene, "--out", out]):
        r = pfmpm(*command, "--quiet")
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 2 and len(lines) == 1 and lines[0].startswith(f"error: {named}"), r.stderr
    if case.startswith("out"):
        r = pfmpm("compare", "borden", "--out", out)
        assert r.returncode == 2 and r.stderr.strip() == f"error: {named}" + r.stderr.strip().split(named)[1]
        assert "Traceback" not in r.stderr


def test_version_and_help():
    from pfmpm import __version__

    r = pfmpm("--version")
    assert r.returncode == 0 and r.stdout.strip() == f"pfmpm {__version__}"
    r = pfmpm("bench", "--help")
    assert r.returncode == 0
    text = " ".join(r.stdout.split())
    for words in ("elastic: the momentum step alone", "phasefield:", "anisotropic:", "contact:",
                  "about this many particles", "steps per timed repeat", "median", "B-spline degree"):
        assert words in text, words
    r = pfmpm("--help")
    for command in ("run", "fem", "compare", "post", "animate", "bench", "polar"):
        assert command in r.stdout


def test_fem_beside_run(tmp_path):
    """``pfmpm fem`` runs a scene with the FEM reference, as ``python -m pfmpm.fem`` does."""
    borden = ROOT / "demos" / "borden_plate.toml"
    sets = ["--set", "grid.h=1.0", "--set", "materials.concrete.fracture.l0=2.0", "--set", "time.end=1"]
    r = pfmpm("fem", borden, "--out", tmp_path / "a", "--quiet", *sets)
    assert r.returncode == 0, r.stderr
    assert "\nwarning: output.snapshots = 50, 65, 80: after the run ends (t = 1.09" in r.stdout
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert summary["method"] == "fem" and summary["status"] == "completed" and summary["units"] == "mm-us-MPa"
    # Its folder is a run's, as pfmpm run's is.
    r = pfmpm("fem", borden, "--out", tmp_path / "a", "--quiet", *sets)
    assert r.returncode == 2 and r.stderr.startswith(f"error: output directory {tmp_path / 'a'} holds another run")
    # With an empty JIT cache, every form and element is compiled: quietly.
    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path / "cache"))
    r = subprocess.run([sys.executable, "-m", "pfmpm.fem", borden, "--out", tmp_path / "b", "--quiet", *sets],
                       capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    assert list((tmp_path / "cache").rglob("libffcx_*.c"))
    assert r.stderr == ""  # issue 21: FFCx logged every compiler command it ran
    assert (tmp_path / "a" / "energies.csv").read_bytes() == (tmp_path / "b" / "energies.csv").read_bytes()


def test_particle_output_has_displacement_damage_strain_volume_and_id(tmp_path):
    """Issue 21, defect 9: the VTU files hold, besides velocity, stress, c and
    history, the displacement from t = 0, the damage 1 - c, the strain (as
    the symmetric tensor ParaView reads), the volume and the particle id."""
    from pfmpm import Scene, Simulation

    scene = Scene.from_toml(ROOT / "demos" / "borden_plate.toml", [
        "grid.h=1.0", "materials.concrete.fracture.l0=2.0", "bodies.plate.particles_per_cell=2",
        "time.end=3", "output.every=1000", "output.snapshots=[]"])
    sim = Simulation(scene)
    sim.run(tmp_path, progress=False)
    last = sorted(tmp_path.glob("particles_*.vtu"))[-1]
    data = meshio.read(last).point_data
    assert {"velocity", "volume", "stress", "strain", "c", "history", "displacement", "damage",
            "id", "body", "material"} <= data.keys()
    p = sim.particles
    np.testing.assert_array_equal(data["id"].ravel(), p.id)  # the global ids (the seeding's)
    assert data["id"].dtype == np.int64 and np.array_equal(p.id, scene.particles()["id"])
    np.testing.assert_array_equal(data["displacement"][:, :2], p.x - scene.particles()["x"])
    # Pulled by 1 MPa: the edges move at sigma / (rho c_p) = 1.07e-4 mm/us, for 3 us.
    assert np.abs(data["displacement"][:, 1]).max() == pytest.approx(1.07e-4 * sim.time, rel=0.15)
    np.testing.assert_array_equal(data["damage"].ravel(), 1.0 - p.c)
    np.testing.assert_array_equal(data["volume"].ravel(), p.volume)
    strain = data["strain"]
    np.testing.assert_array_equal(strain[:, [0, 1, 3]], p.strain)  # xx, yy, xy
    np.testing.assert_array_equal(strain[:, [2, 4, 5]], 0.0)  # plane strain: zz = 0
    # The strain is the one the stress comes from: sigma_yy = lambda tr + 2 mu eps_yy where intact.
    E, nu = 32000.0, 0.2
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    intact = p.c > 0.999
    expected = lam * (p.strain[:, 0] + p.strain[:, 1]) + 2 * mu * p.strain[:, 1]
    np.testing.assert_allclose(data["stress"][intact, 1], expected[intact] * p.c[intact] ** 2, rtol=0.01,
                               atol=1e-6)


def test_bench_neo_hookean_and_its_limits():
    r = pfmpm("bench", "--model", "neo_hookean", "--particles", "2000", "--steps", "3", "--repeats", "1",
              "--json")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["model"] == "neo_hookean"
    r = pfmpm("bench", "--model", "neo_hookean", "--physics", "phasefield", "--particles", "2000")
    assert r.returncode == 2
    assert r.stderr == ("error: model = 'neo_hookean': physics must be elastic or contact,"
                        " not 'phasefield'\n")


def test_bench_damage_gradient_bands():
    """Three bands a direction cut the block in 16: more neighbour lists and
    separable nodes than one band; no bands is a one-line error."""
    runs = []
    for bands in ("1", "3"):
        r = pfmpm("bench", "--physics", "damage_gradient", "--particles", "20000", "--per-cell", "2",
                  "--steps", "2", "--repeats", "1", "--bands", bands, "--json")
        assert r.returncode == 0, r.stderr
        runs.append(json.loads(r.stdout))
    one, three = runs
    assert one["bands"] == 1 and three["bands"] == 3 and one["particles"] == three["particles"]
    assert set(one["damage_share"]) == {"damage", "neighbours", "gradient", "partition"}
    assert three["contact_nodes"] > 2 * one["contact_nodes"] > 0
    r = pfmpm("bench", "--physics", "damage_gradient", "--particles", "2000", "--bands", "0")
    assert r.returncode == 2 and r.stderr.strip() == "error: bands = 0: must be >= 1"


def test_a_used_output_folder_is_refused_overwritten_or_resumed_by_its_own_run(tmp_path):
    """Issue 53: a second run into a used folder stops with a one-line error and
    leaves it as it was; with --overwrite nothing of the first run remains (and
    nothing else is deleted); --resume of a folder whose newest checkpoint
    belongs to another scene, or to another run of the same scene, stops with
    a one-line error."""
    out = tmp_path / "A"
    first = ["run", BAR, "--out", out, "--quiet", "--set", "time.end=5", "--checkpoint-every", "20"]
    assert pfmpm(*first).returncode == 0
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert {"scene.toml", "summary.json", "particles_000100.vtu"} <= {str(p) for p in before}
    (out / "notes.txt").write_text("mine")

    r = pfmpm("run", BAR, "--out", out, "--quiet", "--set", "time.end=2")
    assert r.returncode == 2 and r.stderr == (f"error: output directory {out} holds another run (its"
                                              " scene.toml): replace it with --overwrite, or choose another"
                                              " directory\n")
    assert {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()} == {
        **before, Path("notes.txt"): b"mine"}

    r = pfmpm("run", BAR, "--out", out, "--quiet", "--set", "time.end=2", "--set", "output.every=1000",
              "--overwrite")
    assert r.returncode == 0, r.stderr
    steps = json.loads((out / "summary.json").read_text())["steps"]
    assert sorted(p.name for p in out.iterdir()) == sorted([
        "energies.csv", "energies.png", "notes.txt", "particles.pvd", "particles_000000.vtu",
        f"particles_{steps:06d}.vtu", "scene.toml", "summary.json"])
    assert "end = 2.0" in (out / "scene.toml").read_text()
    assert read_csv(out / "energies.csv")["step"][-1] == steps < 100
    # The kept scene runs again, in its own folder; a scene file of the user's is never replaced.
    r = pfmpm("run", out / "scene.toml", "--out", out, "--quiet", "--overwrite")
    assert r.returncode == 0 and json.loads((out / "summary.json").read_text())["steps"] == steps, r.stderr
    mine = tmp_path / "mine"
    mine.mkdir()
    shutil.copy(BAR, mine / "scene.toml")
    r = pfmpm("run", mine / "scene.toml", "--out", mine, "--quiet", "--overwrite")
    assert r.returncode == 2 and r.stderr == (f"error: output directory {mine} has a scene.toml that no run"
                                              " wrote, which the run's would replace: choose another directory\n")
    assert (mine / "scene.toml").read_bytes() == BAR.read_bytes() and len(list(mine.iterdir())) == 1

    def resume_with(other: Path) -> str:
        """--resume of a fresh run of BAR whose newest checkpoint is the one of ``other``."""
        mine = tmp_path / f"resume_{other.name}"
        assert pfmpm(*first[:3], mine, *first[4:]).returncode == 0
        theirs = checkpoint.list_checkpoints(other / "checkpoints")[-1]
        shutil.copy(theirs, mine / "checkpoints" / "step_000000900.h5")
        r = pfmpm("run", "--resume", mine, "--quiet")
        assert r.returncode == 2 and len(r.stderr.splitlines()) == 1 and "Traceback" not in r.stderr
        assert r.stderr.startswith(f"error: checkpoint {mine / 'checkpoints' / 'step_000000900.h5'} ")
        return r.stderr

    stiffer = tmp_path / "stiffer"
    assert pfmpm(*first[:3], stiffer, *first[4:], "--set", "materials.soft.E=120").returncode == 0
    err = resume_with(stiffer)
    assert "is of another scene (sha256 " in err and f"than {tmp_path / 'resume_stiffer' / 'scene.toml'}" in err
    again = tmp_path / "again"
    assert pfmpm(*first[:3], again, *first[4:]).returncode == 0
    other_id = json.loads((again / "summary.json").read_text())["run_id"]
    err = resume_with(again)
    assert f"belongs to run {other_id}, not to the run " in err


def test_post_reads_the_scene_the_run_kept(tmp_path):
    """The run folder keeps its scene with the --set values applied
    (scene.toml), and pfmpm post measures with it: here the Rayleigh speed of
    a concrete made 40 % stiffer by --set. A folder without scene.toml (of an
    older pfmpm) takes the scene file and its --set values instead."""
    from pfmpm.post import run_cracks
    from pfmpm.scene import Scene

    borden = ROOT / "demos" / "borden_plate.toml"
    sets = ["grid.h=1.0", "materials.concrete.fracture.l0=2.0", "bodies.plate.particles_per_cell=1",
            "time.end=20", "output.every=1000", "output.snapshots=[]", "materials.concrete.E=44800"]
    out = tmp_path / "borden"
    r = pfmpm("run", borden, "--out", out, "--quiet", *[a for s in sets for a in ("--set", s)])
    assert r.returncode == 0, r.stderr
    assert Scene.from_toml(out / "scene.toml") == Scene.from_toml(borden, sets)
    r = pfmpm("post", "crack-tip", out, "--json")
    assert r.returncode == 0, r.stderr
    report = json.loads(r.stdout)
    expected = run_cracks(Scene.from_toml(borden, sets), out)
    assert report["rayleigh"] == expected["rayleigh"]
    unset = run_cracks(Scene.from_toml(borden), out)
    assert report["rayleigh"] == pytest.approx(unset["rayleigh"] * 1.4 ** 0.5, rel=1e-12)
    # The printed report names the scene's units (mm-us-MPa).
    r = pfmpm("post", "crack-tip", out)
    lines = r.stdout.splitlines()
    assert lines[0].startswith(f"crack initiation: t = {report['initiation']:.4g} µs (an arm of the crack"
                               " from the notch 0.5 mm long)")
    assert lines[2].startswith("crack 1: from the notch tip at (50, 20) mm, t = 0 µs"), r.stdout
    arm = report["cracks"][0]["arms"][0]
    assert lines[3].startswith(f"  arm 1: from t = {arm['born']:.4g} µs") and " mm from the crack's start" in lines[3]
    assert f"{arm['max_speed']:.4g} mm/µs = {arm['max_speed'] / report['rayleigh']:.3f} v_R" in lines[3]

    r = pfmpm("post", "crack-tip", out, "--scene", borden)
    assert r.returncode == 2 and r.stderr == (f"error: --scene {borden}: {out} keeps the run's own scene,"
                                              f" {out / 'scene.toml'}\n")
    (out / "scene.toml").unlink()
    r = pfmpm("post", "crack-tip", out)
    assert r.returncode == 2 and len(r.stderr.splitlines()) == 1
    assert r.stderr.startswith(f"error: {out / 'scene.toml'}: no such file")
    r = pfmpm("post", "crack-tip", out, "--scene", borden, "--json", *[a for s in sets for a in ("--set", s)])
    assert r.returncode == 0 and json.loads(r.stdout) == report
