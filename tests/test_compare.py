"""PF-MPM against PF-FEM (pfmpm.compare, ``pfmpm compare borden``).

The measures on ``energies.csv`` on histories whose answers are known, the
driver at a tiny size, and the agreement of the two methods on the Borden
plate at the default h and l0 up to 25 us.
"""

import csv
import json
import math
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pfmpm import scenes
from pfmpm.compare import (BORDEN_SCENE, COLUMNS, OUTPUTS, agreement, branch_time, compare_borden,
                           comparison_overrides, initiation_time, reference)
from pfmpm.output import read_csv
from pfmpm.scene import Crack, Scene
from pfmpm.scene.toml import read_toml
from pfmpm.simulation import Simulation

ROOT = Path(__file__).resolve().parents[1]
DEMO = ROOT / "demos" / "borden_plate.toml"
NOTCH = Crack(points=((0.0, 20.0), (50.0, 20.0)))


def history(t0_init=10.0, t0_branch=20.0, scale=1.0):
    """Synthetic Borden-like columns every 0.5 us.

    The tip sits at x = 50 until ``t0_init``, then runs at 1 mm/us along
    y = 20; from ``t0_branch`` it also drifts off the line at 0.5 mm/us.
    Elastic energy rises linearly to 0.12 at 12 us and falls after;
    fracture energy is 0.18 plus 0.01 per us of crack growth.  ``scale``
    multiplies the elastic energy.
    """
    t = np.arange(0.0, 40.01, 0.5)
    x = 50.0 + np.clip(t - t0_init, 0.0, None)
    y = 20.0 + 0.5 * np.clip(t - t0_branch, 0.0, None)
    elastic = scale * np.where(t <= 12.0, 0.01 * t, 0.12 - 0.002 * (t - 12.0))
    fracture = 0.18 + 0.01 * (x - 50.0)
    return {"t": t, "crack_tip_x": x, "crack_tip_y": y, "elastic": elastic, "fracture": fracture}


def test_initiation_and_branch_times_of_known_histories():
    e = history()
    # x > 50.5 first at 11.0 (x = 51); 10.5 gives exactly 50.5, which does not count.
    assert initiation_time(e) == 11.0
    # |y - 20| > 1 first at 22.5 (y = 21.25, x = 62.5 > 55).
    assert branch_time(e, NOTCH) == 22.5
    # Off the line but not yet 5 mm ahead of the notch tip: not a branch.
    assert branch_time(history(t0_init=10.0, t0_branch=0.0), NOTCH) == 15.5  # x = 55.5
    # A notch pointing the other way sees the same tip as behind it: never.
    assert math.isnan(branch_time(e, Crack(points=((100.0, 20.0), (50.0, 20.0)))))
    quiet = history(t0_init=100.0, t0_branch=100.0)
    assert math.isnan(initiation_time(quiet)) and math.isnan(branch_time(quiet, NOTCH))


def test_agreement_of_known_histories():
    # MPM: 3 % more elastic energy and initiation 2 us later than FEM.
    fem, mpm = history(), history(t0_init=12.0, scale=1.03)
    a = agreement(mpm, fem)
    assert (a["initiation_mpm_us"], a["initiation_fem_us"]) == (13.0, 11.0)
    assert a["initiation_diff_us"] == 2.0
    # Window up to the earlier initiation (11 us): the FEM energy is 0.01 t there,
    # so the RMS difference over t = 0, 0.5, ..., 11 is 0.03 * 0.01 * rms(t), over 0.11.
    t = np.arange(0.0, 11.01, 0.5)
    assert a["elastic_window_us"] == 11.0 and a["elastic_peak"] == pytest.approx(0.11)
    assert a["elastic_rms_rel"] == pytest.approx(0.03 * 0.01 * np.sqrt(np.mean(t**2)) / 0.11, rel=1e-12)
    # At 40 us the MPM crack is 2 mm shorter: 0.46 against 0.48, gains 0.28 against 0.30.
    assert a["t_end"] == 40.0
    assert a["fracture_end_rel_diff"] == pytest.approx(-0.02 / 0.48, rel=1e-12)
    assert a["fracture_gain_rel_diff"] == pytest.approx(-0.02 / 0.30, rel=1e-12)


def test_reference_extrapolates_the_fem_runs():
    # Three levels converging at order 1.5 (errors 0.1 h^1.5 about 1.0): that order is used, exactly.
    ends = {h: 1.0 + 0.1 * h**1.5 for h in (1.0, 0.5, 0.25)}
    r = reference(ends)
    assert r["observed_order"] == pytest.approx(1.5, rel=1e-12) and r["order"] == r["observed_order"]
    assert r["value"] == pytest.approx(1.0, rel=1e-12) and r["h"] == [0.5, 0.25]
    # Two levels: the assumed order 2; oscillating levels: no observed order.
    assert reference({1.0: 1.3, 0.5: 1.1})["value"] == pytest.approx(1.1 - 0.2 / 3, rel=1e-12)
    wild = reference({1.0: 1.3, 0.5: 1.1, 0.25: 1.2})
    assert math.isnan(wild["observed_order"]) and wild["order"] == 2.0
    assert reference({0.5: 0.7})["kind"] == "finest FEM run"


def read_table(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return rows, list(rows[0].keys())


def pfmpm(*args, **kw):
    return subprocess.run([sys.executable, "-m", "pfmpm.cli", *map(str, args)],
                          capture_output=True, text=True, **kw)


def test_compare_driver_at_a_tiny_size(tmp_path):
    """Issue 21, defects 6 and 9: one reference for both methods' errors,
    particles and dofs apart, branch times and their resolution in the
    table, frames of every run."""
    out = tmp_path / "cmp"
    r = pfmpm("compare", "borden", "--h", "1.0,0.5", "--l0", "1.0", "--end", "6", "--out", out,
              "--scene", DEMO, "--frames", "3", "--quiet", timeout=300)
    assert r.returncode == 0, r.stderr
    names = ("speed_vs_error.csv", "energies_overlay.png", "crack_tip_speed_overlay.png",
             "phase_field_side_by_side.png", "crack_path_side_by_side.png", "speed_vs_error.png",
             "comparison.md", "agreement.json")
    for name in names:
        assert (out / name).stat().st_size > 0, name
        assert str(out / name) in r.stdout  # says where it is

    rows, header = read_table(out / "speed_vs_error.csv")
    assert header == COLUMNS
    assert [(row["method"], float(row["h"])) for row in rows] == [
        ("mpm", 1.0), ("mpm", 0.5), ("fem", 1.0), ("fem", 0.5)]
    runs = {(row["method"], float(row["h"])): row for row in rows}
    # Sizes of the 100 x 40 plate: 9 particles per cell; 3 dofs (u, c) per vertex.
    assert (runs["mpm", 1.0]["particles"], runs["mpm", 1.0]["dofs"]) == (str(100 * 40 * 9), "")
    assert int(runs["mpm", 0.5]["particles"]) == 200 * 80 * 9
    assert (runs["fem", 1.0]["particles"], runs["fem", 1.0]["dofs"]) == ("", str(3 * 101 * 41))
    assert int(runs["fem", 0.5]["dofs"]) == 3 * 201 * 81

    end = {}
    for (method, h), row in runs.items():
        run = out / f"{method}_h{h:g}"
        e = read_csv(run / "energies.csv")
        summary = json.loads((run / "summary.json").read_text())
        assert summary["status"] == "completed" and int(row["steps"]) == summary["steps"]
        assert float(row["wall_s"]) == pytest.approx(summary["wall_s"], rel=1e-12)
        assert 6.0 <= e["t"][-1] < 6.0 + summary["dt"]
        assert float(row["fracture_energy_end"]) == e["fracture"][-1]
        assert float(row["elastic_energy_peak"]) == e["elastic"].max()
        assert float(row["crack_tip_x_end"]) == e["crack_tip_x"][-1]
        # 6 us: the crack has not even started
        assert math.isnan(float(row["initiation_us"])) and math.isnan(float(row["branch_us"]))
        end[method, h] = e["fracture"][-1]
        # Three frames, at 0, 3 and 6 us, of each run.
        if method == "mpm":
            assert len(list(run.glob("particles_*.vtu"))) == 3
        else:
            xdmf = (run / "fields.xdmf").read_text()
            assert xdmf.count('<Attribute Name="displacement"') == 3
    # The reference: Richardson (order 2 assumed, with two h) from the FEM runs, for both methods.
    ref = end["fem", 0.5] + (end["fem", 0.5] - end["fem", 1.0]) / 3
    for key, row in runs.items():
        assert float(row["error"]) == pytest.approx(abs(end[key] / ref - 1), rel=1e-12)
        assert 0 < float(row["error"]) < 0.25

    a = json.loads((out / "agreement.json").read_text())
    assert a["h"] == 0.5 and a["l0"] == 1.0 and a["initiation_mpm_us"] is None
    assert a["model"] == "AT2"
    assert a["branch_mpm_us"] is None and a["branch_fem_us"] is None
    assert a["reference"]["kind"] == "richardson" and a["reference"]["h"] == [1.0, 0.5]
    assert a["reference"]["order"] == 2.0 and a["reference"]["observed_order"] is None
    assert a["reference"]["value"] == pytest.approx(ref, rel=1e-12)
    # Rows every 10 steps of dt = 0.105 us (h = 0.5): the times are known to 1.05 us.
    assert a["record_interval_us"] == pytest.approx(1.05 * 0.577, rel=1e-6)
    assert a["elastic_rms_rel"] < 0.05  # both are elastic up to 6 us
    text = (out / "comparison.md").read_text()
    assert "| mpm | 0.5 | 144000 | - |" in text and "| fem | 0.5 | - | 48843 |" in text
    assert "Richardson extrapolation (assumed order 2) of the PF-FEM runs at h = 1 and 0.5" in text
    assert "crack branching (tip 1 mm off the notch line) [us], +- 0.606" in text
    assert "crack initiation (tip 0.5 mm past its start) [us], +- 0.606" in text


def test_an_interrupted_comparison_resumes(tmp_path, monkeypatch):
    """``--resume``: the completed runs are kept, an interrupted MPM run continues
    from its checkpoint to the same bits as a run that was never stopped."""
    settings = dict(hs=[1.0], l0=2.0, end=4.0, scene_path=DEMO, frames=2, progress=False)
    whole = compare_borden(tmp_path / "whole", log=lambda line: None, **settings)

    advance = Simulation.advance

    def advance_then_ctrl_c(sim, steps):  # Ctrl-C once, a few steps into the MPM run
        advance(sim, steps)
        if sim.step >= 5 and not interrupted:
            interrupted.append(sim.step)
            os.kill(os.getpid(), signal.SIGINT)

    interrupted = []
    monkeypatch.setattr(Simulation, "advance", advance_then_ctrl_c)
    with pytest.raises(KeyboardInterrupt):
        compare_borden(tmp_path / "cut", log=lambda line: None, **settings)
    monkeypatch.undo()
    summary = json.loads((tmp_path / "cut" / "mpm_h1" / "summary.json").read_text())
    assert summary["status"] == "interrupted" and 0 < summary["steps"] < summary["steps_planned"]
    lines = []
    resumed = compare_borden(tmp_path / "cut", log=lines.append, resume=True, **settings)
    assert lines[0].startswith("PF-MPM h = 1: 36000 particles, ") and f"from step {summary['steps']}" in lines[0]
    for name in ("mpm_h1", "fem_h1"):
        assert ((tmp_path / "cut" / name / "energies.csv").read_bytes()
                == (tmp_path / "whole" / name / "energies.csv").read_bytes())
    assert resumed.rows[0]["wall_s"] > summary["wall_s"]
    # Resumed again, nothing is left to run; other settings are refused.
    lines.clear()
    compare_borden(tmp_path / "cut", log=lines.append, resume=True, **settings)
    assert all("completed before" in line for line in lines) and len(lines) == 2
    with pytest.raises(ValueError, match=r"other settings \(end\)"):
        compare_borden(tmp_path / "cut", log=lines.append, resume=True, **{**settings, "end": 5.0})
    r = pfmpm("compare", "borden", "--resume", "--out", tmp_path / "cut", "--l0", "1")
    assert r.returncode == 2 and r.stderr.strip() == "error: --l0: cannot change the study of a resumed comparison"
    assert whole.reference["kind"] == "finest FEM run"


def test_compare_runs_either_model(tmp_path):
    """``--model AT1``: both methods solve AT1 with the bound, and the outputs say so."""
    out = tmp_path / "cmp"
    r = pfmpm("compare", "borden", "--h", "1.0", "--l0", "2.0", "--end", "3", "--model", "AT1",
              "--out", out, "--scene", DEMO, "--quiet", timeout=300)
    assert r.returncode == 0, r.stderr
    assert "\nAT1: agreement at h = 1:" in r.stdout
    assert json.loads((out / "agreement.json").read_text())["model"] == "AT1"
    assert (out / "comparison.md").read_text().splitlines()[2].startswith("AT1 phase field, l0 = 2 mm")
    mpm, fem = (json.loads((out / f"{m}_h1" / "summary.json").read_text())["phase_field"]
                for m in ("mpm", "fem"))
    assert mpm["bounded"] and mpm["passes"] >= mpm["solves"] > 1
    assert fem["solver"] == "vinewtonrsls: cg + jacobi" and fem["passes"] >= 1


def test_a_new_comparison_refuses_a_used_directory_unless_told_to_overwrite_it(tmp_path):
    """Issue 53: like pfmpm run, a new comparison stops with one line in a directory
    that holds one; --overwrite deletes that comparison and its runs (those of
    an h the new one does not run too), and nothing else."""
    out = tmp_path / "cmp"
    args = ["compare", "borden", "--l0", "2.0", "--end", "0.5", "--out", out, "--scene", DEMO, "--frames", "0",
            "--set", "bodies.plate.particles_per_cell=1", "--quiet"]
    assert pfmpm(*args, "--h", "0.5", timeout=300).returncode == 0
    (out / "notes.txt").write_text("mine")
    r = pfmpm(*args, "--h", "1.0", timeout=300)
    assert r.returncode == 2 and r.stderr == (f"error: output directory {out} holds another comparison or run"
                                              " (its study.json): replace it with --overwrite, continue it with"
                                              " --resume, or choose another directory\n")
    r = pfmpm(*args, "--h", "1.0", "--overwrite", timeout=300)
    assert r.returncode == 0, r.stderr
    kept = ["notes.txt", "study.json", "mpm_h1", "fem_h1", *OUTPUTS]
    assert sorted(p.name for p in out.iterdir()) == sorted(kept)
    assert json.loads((out / "study.json").read_text())["settings"]["h"] == [1.0]
    r = pfmpm("compare", "borden", "--resume", "--overwrite", "--out", out)
    assert r.returncode == 2
    assert r.stderr == "error: --overwrite: cannot change the study of a resumed comparison\n"


def test_l0_below_h_is_refused_before_any_run(tmp_path):
    out = tmp_path / "cmp"
    r = pfmpm("compare", "borden", "--h", "1.0,0.5", "--l0", "0.75", "--out", out, "--scene", DEMO)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "materials[0].fracture.l0 = 0.75" in lines[0], r.stderr
    assert "h = 1" in lines[0] and not out.exists()


def test_the_comparison_finds_the_crackable_materials_by_their_tables():
    """Not by the Borden material's name: renamed, it still gets the run's l0,
    and every crackable material of a scene does."""
    tables = read_toml(DEMO)
    tables["materials"][0]["name"] = "glass"
    tables["bodies"][0]["material"] = "glass"
    sets = comparison_overrides(tables, 1.0, 2.0, 5.0)
    assert sets == ["grid.h=1.0", "materials.0.fracture.l0=2.0", "materials.0.fracture.model=AT2",
                    "time.end=5.0"]
    scene = Scene.from_dict(tables, sets)
    assert scene.materials[0].name == "glass" and scene.materials[0].fracture.l0 == 2.0
    beam_and_disk = read_toml(ROOT / "demos" / "disk_beam.toml")
    assert comparison_overrides(beam_and_disk, 1.0, 2.0, 5.0)[1:3] == [
        "materials.0.fracture.l0=2.0", "materials.1.fracture.l0=2.0"]


def test_the_default_scene_ships_with_the_package():
    """``pfmpm compare borden`` runs from any directory (issue 21, defect 8): its
    scene is the one in the imported (installed) package, not the repository's."""
    assert BORDEN_SCENE == scenes.path("borden_plate") and BORDEN_SCENE.is_absolute()
    assert BORDEN_SCENE.parent == Path(scenes.__file__).parent
    assert BORDEN_SCENE.read_bytes() == DEMO.read_bytes()


@pytest.mark.slow
def test_mpm_and_fem_agree_on_the_borden_plate(tmp_path):
    """Default h = 0.25 and l0 = 0.5, to 20 us (initiation is at about 13 us).

    MPM with 2 x 2 particles per cell (the demo has 3 x 3) to keep it short.
    Measured: initiation 13.03 us (MPM) and 13.33 us (FEM), elastic energy
    RMS difference 0.77 % of the peak, fracture energy at 20 us 4.4 % apart
    and 1.21 (MPM) and 1.23 (FEM) times the notch's.
    """
    result = compare_borden(tmp_path, [0.25], 0.5, 20.0, scene_path=DEMO, frames=0,
                            overrides=["bodies.plate.particles_per_cell=2"], progress=False,
                            log=lambda line: None)
    a = result.agreement
    print({k: round(v, 4) for k, v in a.items()})
    assert 8.0 < a["initiation_fem_us"] < 18.0
    assert abs(a["initiation_diff_us"]) <= 2.0
    assert a["elastic_window_us"] == min(a["initiation_mpm_us"], a["initiation_fem_us"])
    assert 0.10 < a["elastic_peak"] < 0.14
    assert a["elastic_rms_rel"] < 0.10
    assert abs(a["fracture_end_rel_diff"]) < 0.10
    # The crack has grown: the fracture energy at 20 us is well above the notch's.
    mpm, fem = (read_csv(tmp_path / f"{m}_h0.25" / "energies.csv") for m in ("mpm", "fem"))
    for e in (mpm, fem):
        assert e["fracture"][-1] > 1.15 * e["fracture"][0]
    # One h: the reference is the FEM run there.
    errors = {row["method"]: row["error"] for row in result.rows}
    assert errors["fem"] == 0.0 and errors["mpm"] == pytest.approx(abs(a["fracture_end_rel_diff"]), rel=1e-9)
