"""Checkpoint and resume (of one body and of bodies in contact), reproducibility
across runs and thread counts, and the run-time guards (non-finite values,
unstable steps, light nodes)."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from pfmpm import Scene, Simulation
from pfmpm import checkpoint
from pfmpm.cli import main
from pfmpm.output import read_csv
from pfmpm.scene import LONE_PARTICLE_FACTOR, wave_speed

ROOT = Path(__file__).resolve().parents[1]
BORDEN = ROOT / "demos" / "borden_plate.toml"
BAR = ROOT / "demos" / "vibrating_bar.toml"
# The Borden plate at h = 1 mm, l0 = 2 mm, one particle per cell (4,000
# particles): the crack starts at about 15 us and runs to x ~ 77 mm by 40 us.
COARSE = ["grid.h=1.0", "materials.concrete.fracture.l0=2.0", "bodies.plate.particles_per_cell=1",
          "output.energies_every=5", "output.every=50"]
DISK_BEAM = ROOT / "demos" / "disk_beam.toml"
# The disk-beam impact at h = 1 mm, l0 = 2 mm, one particle per cell (934
# particles, 281 steps to 20 us on a grid reaching only a cell below the beam,
# whose end functions shorten the step): the disk and the beam share grid
# nodes from the first step, and the beam cracks while they touch. Both bodies
# can crack, each with its own phase field.
CONTACT_COARSE = ["grid.h=1.0", "grid.origin=[-2.0, -1.0]", "grid.size=[52.0, 40.0]",
                  "materials.beam.fracture.l0=2.0", "materials.disk.fracture.l0=2.0",
                  "bodies.beam.particles_per_cell=1", "bodies.disk.particles_per_cell=1",
                  "output.energies_every=5", "output.every=100", "time.end=20"]


def coarse_args(end):
    args = [str(BORDEN), "--quiet"]
    for s in COARSE + [f"time.end={end}"]:
        args += ["--set", s]
    return args


def pfmpm(*args, env=None, **kw):
    return subprocess.run([sys.executable, "-m", "pfmpm.cli", *map(str, args)], capture_output=True,
                          text=True, env=env, **kw)


def output_files(out):
    """Every output file of a run but the plots, checkpoints and summary (which has wall times)."""
    return {p.name: p.read_bytes() for p in sorted(out.iterdir())
            if p.suffix in (".csv", ".vtu", ".pvd")}


def test_resumed_run_is_bitwise_identical(tmp_path, capsys):
    full = tmp_path / "full"
    assert main(["run", *coarse_args(40), "--out", str(full), "--checkpoint-every", "100", "--keep", "5"]) == 0
    names = [p.name for p in checkpoint.list_checkpoints(full / "checkpoints")]
    assert names == ["step_000000100.h5", "step_000000200.h5", "step_000000300.h5"]

    # A run stopped after step 100 (what it wrote later is left in place and
    # must be replaced by the resumed run's own output).
    part = tmp_path / "part"
    shutil.copytree(full, part)
    for name in names[1:]:
        (part / "checkpoints" / name).unlink()
    assert main(["run", "--resume", str(part), "--quiet"]) == 0
    assert "from step 100" in capsys.readouterr().out

    e = read_csv(full / "energies.csv")
    assert e["crack_tip_x"][-1] > 65.0 and e["crack_tip_x"][e["step"] == 100][0] < 53.0, \
        "the crack should run after the restart"
    a, b = output_files(full), output_files(part)
    assert a.keys() == b.keys() and len(a) >= 9
    for name in a:
        assert a[name] == b[name], f"{name} differs after resuming"
    summary = json.loads((part / "summary.json").read_text())
    assert summary["status"] == "completed" and summary["resumed_from"].endswith("step_000000100.h5")
    # The cadence came from the checkpoint: the resumed run wrote 200 and 300.
    assert [p.name for p in checkpoint.list_checkpoints(part / "checkpoints")] == names


def test_checkpoint_holds_the_complete_state(tmp_path):
    scene = Scene.from_toml(BORDEN, COARSE + ["time.end=20", "output.particles=false"])
    sim = Simulation(scene)
    sim.run(tmp_path, progress=False, checkpoint_every=60)
    ckpt = checkpoint.read(tmp_path / "checkpoints" / "step_000000120.h5")
    assert ckpt.step == 120 and ckpt.status == "ok" and Scene.from_dict(ckpt.scene) == scene

    # Restored into a fresh simulation, the state gives the checkpointed
    # energies row exactly (the fracture energy comes from the saved solve).
    again = Simulation(scene)
    checkpoint.restore(again, ckpt)
    row = read_csv(tmp_path / "energies.csv")
    k = np.flatnonzero(row["step"] == 120)[0]
    e = again.energies()
    for column in ("kinetic", "elastic", "fracture", "external_work"):
        assert e[column] == row[column][k], column

    # The warm start is part of the state: without the solution before the
    # last, the same particles take different steps.
    cold = Simulation(scene)
    checkpoint.restore(cold, ckpt)
    state = cold.solver.state()
    state["arrays"]["phase_field/0/c_previous"] = state["arrays"]["phase_field/0/c"]
    cold.solver.restore(state)
    again.advance(5)
    cold.advance(5)
    assert not np.array_equal(again.particles.c, cold.particles.c)


def test_resumed_contact_run_is_bitwise_identical(tmp_path):
    full = tmp_path / "full"
    args = ["run", str(DISK_BEAM), "--quiet", "--out", str(full), "--checkpoint-every", "100"]
    for s in CONTACT_COARSE:
        args += ["--set", s]
    assert main(args) == 0
    names = [p.name for p in checkpoint.list_checkpoints(full / "checkpoints")]
    assert names == ["step_000000100.h5", "step_000000200.h5"]
    ckpt = checkpoint.read(full / "checkpoints" / names[0])
    scalars, arrays = ckpt.solver["scalars"], ckpt.solver["arrays"]
    assert scalars["contact/nodes"] > 0 and scalars["contact/active"] > 0, \
        "the bodies should be in contact at the checkpoint"
    assert sorted(arrays) == ["contact/pair_impulse", "grid/slab_sums"] + [f"phase_field/{k}/{name}" for k in (0, 1)
                                                         for name in ("c", "c_previous")]

    # Restored into a fresh simulation, the state gives the checkpointed
    # energies row exactly: the friction work and each body's fracture
    # energy come from the saved state, not from a new solve.
    again = Simulation(Scene.from_dict(ckpt.scene))
    checkpoint.restore(again, ckpt)
    e = read_csv(full / "energies.csv")
    k = np.flatnonzero(e["step"] == 100)[0]
    now = again.energies()
    for column in ("kinetic", "elastic", "fracture", "friction_dissipation", "fracture_beam",
                   "fracture_disk", "contact_beam_disk_x", "contact_beam_disk_y", "total"):
        assert now[column] == e[column][k], column
    assert again.solver.contact_stats() == {key.removeprefix("contact/"): value
                                            for key, value in scalars.items() if key.startswith("contact/")}

    # A run stopped after step 100, resumed.
    part = tmp_path / "part"
    shutil.copytree(full, part)
    (part / "checkpoints" / names[1]).unlink()
    assert main(["run", "--resume", str(part), "--quiet"]) == 0
    # Friction and the beam's crack act mostly after the restart (the
    # friction work of a sticking contact fluctuates about zero before).
    assert e["friction_dissipation"][-1] > 10.0 * abs(e["friction_dissipation"][k])
    assert e["fracture_beam"][-1] > 2.0 * e["fracture_beam"][k] > 0.0
    a, b = output_files(full), output_files(part)
    assert a.keys() == b.keys() and len(a) == 6
    for name in a:
        assert a[name] == b[name], f"{name} differs after resuming"
    header = (part / "energies.csv").read_text().splitlines()[0].split(",")
    assert header[-5:] == ["friction_dissipation", "fracture_beam", "fracture_disk",
                           "contact_beam_disk_x", "contact_beam_disk_y"]
    s, t = (json.loads((d / "summary.json").read_text()) for d in (full, part))
    assert t["status"] == "completed" and t["resumed_from"].endswith(names[0])
    assert t["contact"] == s["contact"] and t["phase_field"] == s["phase_field"]
    assert s["contact"]["active_node_pairs"] > scalars["contact/active"]
    assert s["contact"]["violations"] == {"C1": 0, "C2": 0, "C3": 0, "C4": 0}


def run_threads(tmp_path, threads, name, model):
    out = tmp_path / name
    # Passive waiting: on a busy machine, spinning OpenMP threads only slow
    # each other down (the results do not depend on it).
    env = {**os.environ, "OMP_NUM_THREADS": str(threads), "OMP_WAIT_POLICY": "passive",
           "PFMPM_ADAPTIVE_THREADS": "0"}  # every step on the count asked for
    r = pfmpm("run", *coarse_args(15), "--set", f"materials.concrete.fracture.model={model}",
              "--out", out, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    assert json.loads((out / "summary.json").read_text())["threads"] == threads
    return output_files(out)


@pytest.mark.parametrize("model", ("AT2", "AT1"))
def test_runs_repeat_bitwise_with_one_or_two_threads(tmp_path, model):
    # AT1: the bounded solve (4,500 nodes: two blocks of the deterministic sums)
    one = run_threads(tmp_path, 1, "one", model)
    two = run_threads(tmp_path, 2, "two", model)
    again = run_threads(tmp_path, 2, "again", model)
    assert one.keys() == two.keys() == again.keys()
    for name in one:
        assert one[name] == two[name], f"{name}: 1 and 2 threads differ"
        assert two[name] == again[name], f"{name}: a repeated run differs"


def start_bar(out, end):
    args = ["run", BAR, "--out", out, "--quiet", "--set", f"time.end={end}", "--set", "output.every=500"]
    return subprocess.Popen([sys.executable, "-m", "pfmpm.cli", *map(str, args)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def interrupt(proc, out, sig):
    csv = out / "energies.csv"
    deadline = time.time() + 60
    while time.time() < deadline and (not csv.exists() or len(csv.read_text().splitlines()) < 50):
        time.sleep(0.02)
    proc.send_signal(sig)
    return proc.communicate(timeout=60)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_signal_leaves_a_checkpoint_that_resumes(tmp_path, sig):
    out = tmp_path / "bar"
    _, err = interrupt(start_bar(out, 1000), out, sig)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted" and 0 < summary["steps"] < summary["steps_planned"], err
    assert f"resume with: pfmpm run --resume {out}" in err and "Traceback" not in err
    ckpt = checkpoint.find(out)
    assert ckpt.step == summary["steps"] and Path(summary["checkpoint"]) == ckpt.path
    if sig == signal.SIGTERM:
        return
    r = pfmpm("run", "--resume", out, "--quiet")
    assert r.returncode == 0, r.stderr
    full = tmp_path / "full"
    r = pfmpm("run", BAR, "--out", full, "--quiet", "--set", "time.end=1000", "--set", "output.every=500")
    assert r.returncode == 0, r.stderr
    assert output_files(full) == output_files(out)


def test_signal_exit_codes(tmp_path):
    for sig, code in ((signal.SIGINT, 130), (signal.SIGTERM, 143)):
        out = tmp_path / sig.name
        proc = start_bar(out, 1e4)
        interrupt(proc, out, sig)
        assert proc.returncode == code


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    """A run directory with two checkpoints of a short bar run."""
    out = tmp_path_factory.mktemp("saved")
    assert main(["run", str(BAR), "--out", str(out), "--quiet", "--set", "time.end=5",
                 "--checkpoint-every", "50"]) == 0
    return out


def damaged(saved, tmp_path, how):
    run = tmp_path / "run"
    shutil.copytree(saved, run)
    path = checkpoint.list_checkpoints(run / "checkpoints")[-1]
    if how == "truncated":
        data = path.read_bytes()
        path.write_bytes(data[: len(data) // 2])
    elif how == "flipped":
        with h5py.File(path, "r") as f:
            offset = f["particles/v"].id.get_offset() + 100
        with open(path, "r+b") as f:
            f.seek(offset)
            byte = f.read(1)
            f.seek(offset)
            f.write(bytes([byte[0] ^ 0x10]))
    elif how == "old":
        with h5py.File(path, "r+") as f:
            f.attrs["version"] = 1
    elif how == "foreign":
        path.unlink()
        with h5py.File(path, "w") as f:
            f["x"] = np.zeros(3)
    return run, path


@pytest.mark.parametrize("how, reason", [
    ("truncated", "cannot be read"),
    ("flipped", "checksum mismatch, the file is corrupt"),
    ("foreign", "not a pfmpm checkpoint"),
    ("old", f"format version 1, this pfmpm reads {checkpoint.VERSION}"),
])
def test_damaged_checkpoint_is_refused(saved, tmp_path, capsys, how, reason):
    run, path = damaged(saved, tmp_path, how)
    for target in (path, run):
        assert main(["run", "--resume", str(target), "--quiet"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and str(path) in err[0] and reason in err[0], err
    # Given the run directory, the error names the older checkpoint to use instead.
    assert f"older: {run / 'checkpoints' / 'step_000000050.h5'}" in err[0]


def test_checkpoint_carries_the_ids_and_a_resume_checks_them(saved):
    """The ids are written and, on resuming, compared with the scene's
    seeding row by row (not written: a run keeps its particles and their
    order); a file from before version 6, without them, takes the seeding's."""
    path = checkpoint.list_checkpoints(saved / "checkpoints")[-1]
    ckpt = checkpoint.read(path)
    sim = Simulation(Scene.from_dict(ckpt.scene))
    assert ckpt.version == checkpoint.VERSION == 8
    assert ckpt.particles["id"].dtype == np.int64
    np.testing.assert_array_equal(ckpt.particles["id"], sim.particles.id)
    checkpoint.restore(sim, ckpt)
    np.testing.assert_array_equal(sim.particles.x, ckpt.particles["x"])

    ids = ckpt.particles["id"]
    ids[5] += 1
    with pytest.raises(checkpoint.CheckpointError) as refused:
        checkpoint.restore(sim, ckpt)
    assert str(refused.value) == (f"checkpoint {path}: particles/id of particle 5 is {ids[5]},"
                                  f" the scene seeds id {ids[5] - 1} there")
    del ckpt.particles["id"]
    with pytest.raises(checkpoint.CheckpointError, match="particles/id is missing"):
        checkpoint.restore(sim, ckpt)
    ckpt.version = 5
    checkpoint.restore(sim, ckpt)
    np.testing.assert_array_equal(sim.particles.id, Scene.from_dict(ckpt.scene).particles()["id"])


DATA = Path(__file__).resolve().parent / "data"


def test_version_3_borden_resumes_as_it_ran(tmp_path):
    """A version-3 checkpoint (written by 55831d5, format of particle arrays
    and solver state by fixed lists) resumes into the named columns and
    state of version 4 and continues as that commit's uninterrupted run:
    the coarse Borden plate, phase field included.

    The stored run was made by a build for another CPU (``-march=native``):
    a build for a CPU with other vector units (AVX-512 against AVX2) groups
    some multiply-adds differently, so the two agree to round-off rather
    than bit for bit. On the 2026-12-01 machine (AMD EPYC, AVX-512) the
    first 25 rows are identical and the largest relative difference of an
    energy is 2.7e-14; momenta (zero up to round-off) differ by at most
    3e-13. A resumed run against an uninterrupted one on one build is
    bitwise (``test_resumed_run_is_bitwise_identical``).

    That commit solved the phase field with Jacobi CG, the second-order
    default until the Gauss-Seidel one; the run resumes with it, as a user
    would with ``phase_field.preconditioner = "jacobi"``."""
    run = tmp_path / "borden"
    (run / "checkpoints").mkdir(parents=True)
    shutil.copy(DATA / "borden_v3_step120.h5", run / "checkpoints" / "step_000000120.h5")
    ckpt = checkpoint.find(run)
    assert ckpt.particles["fracture_energy"].shape == ckpt.particles["mass"].shape
    assert sorted(ckpt.solver["arrays"]) == ["phase_field/0/c", "phase_field/0/c_previous"]
    assert ckpt.scene["phase_field"].get("preconditioner", "automatic") == "automatic"
    ckpt.scene["phase_field"]["preconditioner"] = "jacobi"
    sim = Simulation(Scene.from_dict(ckpt.scene))
    result = sim.run(run, progress=False, checkpoint_every=ckpt.checkpoint_every, keep=ckpt.keep,
                     resume=ckpt, draw=False)
    assert result.status == "completed"
    now, then = read_csv(run / "energies.csv"), read_csv(DATA / "borden_v3_energies.csv")
    assert list(now) == list(then)
    np.testing.assert_array_equal(now["step"], then["step"])
    for column in then:
        if column.startswith("momentum"):
            np.testing.assert_allclose(now[column], then[column], rtol=0, atol=1e-11, err_msg=column)
        else:
            np.testing.assert_allclose(now[column], then[column], rtol=1e-12, atol=0, err_msg=column)


def test_version_3_contact_state_is_restored(tmp_path):
    """A version-3 checkpoint of the disk-beam (two crackable bodies in
    contact, each with its phase field) restores the energies of its step,
    friction and per-body fracture included, and resumes. The columns not
    summed over the particles come back exactly; the particle sums to their
    last bits, which the sums by tile (2026-12-07) changed from the file's."""
    path = DATA / "disk_beam_v3_step100.h5"
    ckpt = checkpoint.read(path)
    assert ckpt.solver["scalars"]["contact/active"] > 0
    sim = Simulation(Scene.from_dict(ckpt.scene))
    checkpoint.restore(sim, ckpt)
    e = read_csv(DATA / "disk_beam_v3_energies.csv")
    k = np.flatnonzero(e["step"] == 100)[0]
    now = sim.energies()
    for column in ("friction_dissipation", "external_work"):
        assert now[column] == e[column][k], column
    for column in ("kinetic", "elastic", "fracture", "fracture_beam", "fracture_disk"):
        assert now[column] == pytest.approx(e[column][k], rel=1e-14, abs=0), column
    sim.advance(10)
    assert sim.step == 110


def test_version_2_is_read_unless_the_run_is_anisotropic(saved, tmp_path, capsys):
    """Version 3 changed only how gamma is turned (docs/method.md): a version-2
    file is read as version 3, unless one of its materials has the fourth-order term."""
    run = tmp_path / "borden"
    (run / "checkpoints").mkdir(parents=True)
    path = run / "checkpoints" / "step_000000120.h5"
    shutil.copy(DATA / "borden_v3_step120.h5", path)
    with h5py.File(path, "r+") as f:
        f.attrs["version"] = 2
    assert main(["run", "--resume", str(path), "--quiet"]) == 0
    cubic = tmp_path / "cubic"
    args = ["run", str(ROOT / "demos" / "borden_cubic.toml"), "--out", str(cubic), "--quiet",
            "--checkpoint-every", "2"]
    for s in COARSE[:3] + ["time.end=1.0"]:
        args += ["--set", s]
    assert main(args) == 0
    path = checkpoint.list_checkpoints(cubic / "checkpoints")[-1]
    with h5py.File(path, "r+") as f:
        f.attrs["version"] = 2
    capsys.readouterr()
    assert main(["run", "--resume", str(path), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "format version 2 holds an anisotropic run" in err[0], err


def test_resume_needs_a_scene_or_a_checkpoint_not_both(saved, tmp_path, capsys):
    assert main(["run", str(BAR), "--resume", str(saved)]) == 2
    assert main(["run", "--resume", str(saved), "--set", "time.end=9"]) == 2
    assert main(["run", "--resume", str(tmp_path)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert "not both" in err[0] and "--set" in err[1] and "no checkpoints" in err[2]


def test_keep_prunes_old_checkpoints(tmp_path):
    scene = Scene.from_toml(BAR, ["time.end=5", "output.particles=false"])
    Simulation(scene).run(tmp_path, progress=False, checkpoint_every=10, keep=2)
    steps = [checkpoint.read(p).step for p in checkpoint.list_checkpoints(tmp_path / "checkpoints")]
    assert steps == [scene.steps() // 10 * 10 - 10, scene.steps() // 10 * 10]
    assert not list((tmp_path / "checkpoints").glob(".*tmp"))


def test_planted_nan_stops_the_run_at_its_step(tmp_path, capsys):
    scene = Scene.from_toml(BORDEN, COARSE + ["time.end=5"])
    sim = Simulation(scene)
    sim.advance(7)
    sim.particles.fext[1234] = (np.nan, 0.0)  # the force is in no energy: only the step sees it
    result = sim.run(tmp_path, progress=False, checkpoint_every=5)
    assert result.status == "failed"
    at = f"during the step after step 7 (t = {7 * sim.dt:.6g}"[:-2]  # t to 4 digits
    assert "velocity of particle" in result.error and at in result.error
    # The state as it was is kept for inspection, and never resumed from.
    failed = checkpoint.read(Path(result.checkpoint))
    assert failed.status == "failed" and failed.step == 7 and failed.error == result.error
    assert Path(result.checkpoint).name == "failed_step_000000007.h5"
    with pytest.raises(checkpoint.CheckpointError, match="the state of a failed run"):
        checkpoint.find(failed.path)
    # Outputs are flushed: the row at step 7 and the summary are there.
    assert read_csv(tmp_path / "energies.csv")["step"][-1] == 7
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["status"] == "failed" and summary["error"] == result.error


@pytest.mark.parametrize("quantity, plant", [
    ("velocity", lambda p: p.v.__setitem__((3, 1), np.inf)),
    ("stress", lambda p: p.strain.__setitem__((3, 0), np.nan)),
])
def test_non_finite_quantity_is_named(quantity, plant):
    sim = Simulation(Scene.from_toml(BAR, ["time.end=1"]))
    sim.advance(2)
    plant(sim.particles)
    with pytest.raises(RuntimeError, match=rf"^{quantity} of particle \d+ .* during the step after step 2 "):
        sim.advance(3)


def test_unstable_step_is_reported():
    scene = Scene.from_toml(BAR, ["time.end=1", "walls=[]"])
    sim = Simulation(scene)
    m = scene.materials[0]
    sim.advance(1)
    # At cfl = 0.8, a speed of c on top of the wave speed c gives dt (c + |v|) = 1.6 kappa h.
    sim.particles.v[:, 0] += wave_speed(m.E, m.nu, m.density, scene.plane)
    with pytest.raises(RuntimeError, match=r"time step dt = .* became unstable: particle \d+ .*"
                                           r"exceeds the stability limit .* lower time.cfl or time.dt"):
        sim.advance(1)
    # The demo itself stays below the limit to the end.
    ok = Simulation(scene)
    ok.advance(scene.steps())
    assert ok.step == scene.steps()


def test_fastest_signal_is_what_the_stability_check_holds_dt_to():
    scene = Scene.from_toml(BAR, ["time.end=1", "walls=[]"])
    sim = Simulation(scene)
    m = scene.materials[0]
    c = wave_speed(m.E, m.nu, m.density, scene.plane)
    # At rest the largest c_p + |v_p| is the P-wave speed, and dt is cfl kappa h
    # over it, kappa the smaller of the grid's and a lone particle's.
    assert sim.solver.fastest_signal() == pytest.approx(c, rel=1e-14)
    kappa_h = min(scene.critical_length(), LONE_PARTICLE_FACTOR[scene.grid.degree] * scene.grid.h)
    assert scene.dt() * sim.solver.fastest_signal() / kappa_h == pytest.approx(scene.time.cfl, rel=1e-14)
    sim.particles.v[7] = (3.0, 4.0)
    assert sim.solver.fastest_signal() == pytest.approx(c + 5.0, rel=1e-14)


def test_light_nodes_are_counted(tmp_path):
    scene = Scene.from_toml(BAR, ["time.end=0.2", "output.particles=false"])
    sim = Simulation(scene)
    sim.advance(1)
    assert sim.solver.light_nodes == 0
    # A lone particle below the bar (y = 2..4), 1e-8 h left of the cell edge
    # x = 27: its weight at node column 26 is about 1e-16, and no other
    # particle reaches nodes (26, 0) and (26, 1). Too light to divide by.
    sim.particles.x[0] = (27.0 - 1e-8, 0.5)
    result = sim.run(tmp_path, progress=False)
    assert result.status == "completed" and result.light_nodes >= 1
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["light_nodes"] == result.light_nodes
    # Whether it matters: each held at most 1e-12 of the heaviest particle's mass, so at
    # most that times the top speed of momentum, against the bar's total mass times it.
    mass = sim.particles.mass
    assert sim.solver.mass_tol == 1e-12 * mass.max()
    bound = result.light_nodes * 1e-12 * mass.max() / mass.sum()
    assert summary["light_momentum"] == result.light_momentum == pytest.approx(bound, rel=1e-12)
