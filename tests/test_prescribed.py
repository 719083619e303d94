"""Prescribed motion (issue 53): ``[[prescribed]]`` boxes of grid nodes that
move with a given velocity or by a given displacement, in both methods.

A grip moving at constant speed into a bar sends the compressive wave of
stress rho c v; a displacement ramped slowly at one end of a bar fixed at
the other gives the static reaction E A u / L at both ends; the work of the
prescribed motion closes the energy balance; bad regions are one-line
errors.
"""

import subprocess
from pathlib import Path
import sys

import numpy as np
import pytest

from pfmpm.fem import FemSimulation
from pfmpm.output import read_csv
from pfmpm.post.forces import load_displacement, mean_forces
from pfmpm.scene import (Body, BodyForce, GridSpec, LinearElasticSpec, Prescribed, Ramp, Rectangle, Scene,
                         SceneError, Time, WallSpec)
from pfmpm.scene.toml import plain, toml_text
from pfmpm.simulation import Simulation

E, RHO = 100.0, 1.0
C = (E / RHO) ** 0.5  # nu = 0: the bar speed
V = 0.01
METHODS = {"mpm": Simulation, "fem": FemSimulation}
ROOT = Path(__file__).resolve().parents[1]


def run(sim, every: int = 5) -> dict[str, np.ndarray]:
    """The energies every ``every`` steps to the end, from t = 0."""
    rows = [sim.energies()]
    while sim.step < sim.scene.steps():
        sim.advance(min(every, sim.scene.steps() - sim.step))
        rows.append(sim.energies())
    return {k: np.array([r[k] for r in rows]) for k in rows[0]}


def grip_scene(ramp: float = 0.5) -> Scene:
    """A bar from x = 2 to 32 whose left end a grip (the nodes with x <= 3)
    pushes at V from t = 0 on, reached by a smooth ramp of ``ramp``."""
    m = LinearElasticSpec("soft", E, 0.0, RHO)
    bar = Body("bar", "soft", Rectangle((2.0, 2.0), (32.0, 4.0)), particles_per_cell=3)
    grip = Prescribed("grip", (0.0, 0.0), (3.0, 6.0), velocity=(V, 0.0), components="x", amplitude=Ramp(ramp))
    return Scene(grid=GridSpec(size=(40.0, 6.0), h=1.0, degree=2), time=Time(end=2.0), materials=(m,),
                 bodies=(bar,), plane="strain", prescribed=(grip,))


@pytest.mark.parametrize("method", METHODS)
def test_a_moving_grip_sends_the_bar_wave(method):
    """Behind the front (at 3 + c t = 23, the ramp's tail 5 long) the bar
    carries sigma = -rho c V: the grip's reaction once the ramp is over, and
    the stress in the middle of the plateau (6 < x < 14), within 1 %; over
    4 < x < 16 the MPM's stress ripples by 2 % (the dispersion of the front),
    the FEM's by 0.3 %. The momentum is the grip's impulse to round-off, and
    the grip's work closes the balance to 0.5 %."""
    scene = grip_scene()
    sim = METHODS[method](scene)
    e = run(sim)
    forces = mean_forces(scene, e)
    reaction = forces["region_grip_x"][forces["t"] > 0.7]
    assert np.mean(reaction) == pytest.approx(RHO * C * V * 2.0, rel=0.01)
    if method == "mpm":
        x, sigma = sim.particles.x[:, 0], sim.particles.stress[:, 0]
    else:
        x, sigma = sim._x[sim._dofs].mean(axis=1)[:, 0], sim.stresses()[:, 0]
    middle, wide = (x > 6.0) & (x < 14.0), (x > 4.0) & (x < 16.0)
    assert np.mean(sigma[middle]) == pytest.approx(-RHO * C * V, rel=0.01)
    assert np.mean(sigma[wide]) == pytest.approx(-RHO * C * V, rel=0.025)
    assert np.max(np.abs(e["momentum_x"] - e["impulse_grip_x"])) < 1e-12 * e["impulse_grip_x"][-1]
    # The ramp lags T / 2 (its midpoint rule is exact to second order in dt).
    assert e["displacement_grip_x"][-1] == pytest.approx(V * (e["t"][-1] - 0.25), rel=1e-4)
    drift = e["total"] - e["total"][0]
    assert np.max(np.abs(drift)) < 5e-3 * e["work_grip"][-1]
    assert e["work_grip"][-1] > 0


def pull_scene() -> Scene:
    """A bar over the whole grid (x = 0 to 30), fixed at the left wall; the
    right end's node column pulled by U = 0.03 over a smooth ramp of three
    wave periods (T = 30), then held."""
    m = LinearElasticSpec("soft", E, 0.0, RHO)
    bar = Body("bar", "soft", Rectangle((0.0, 2.0), (30.0, 4.0)), particles_per_cell=3)
    pull = Prescribed("pull", (29.9, -1.0), (30.1, 7.0), displacement=(0.03, 0.0), components="x",
                      amplitude=Ramp(30.0))
    return Scene(grid=GridSpec(size=(30.0, 6.0), h=1.0, degree=2), time=Time(end=60.0), materials=(m,),
                 bodies=(bar,), plane="strain", prescribed=(pull,), walls=(WallSpec("left", "fixed"),))


@pytest.mark.parametrize("method", METHODS)
def test_a_ramped_displacement_gives_the_static_reaction(method):
    """Once the ramp is over, both ends carry F = E A U / L (mean over
    t > 35, within 1 %; measured 0.02-0.2 %); the pull has moved U exactly
    and done the work of the stretched bar, E A U^2 / 2 L, within 1 %; the
    balance closes to 0.5 % of it."""
    scene = pull_scene()
    e = run(METHODS[method](scene))
    F = E * 2.0 * 0.03 / 30.0
    forces = mean_forces(scene, e)
    held = forces["t"] > 35.0
    assert np.mean(forces["region_pull_x"][held]) == pytest.approx(F, rel=0.01)
    assert np.mean(forces["wall_left_x"][held]) == pytest.approx(-F, rel=0.01)
    assert e["displacement_pull_x"][-1] == pytest.approx(0.03, rel=1e-12)
    assert e["work_pull"][-1] == pytest.approx(0.5 * F * 0.03, rel=0.01)
    assert np.max(np.abs(e["total"] - e["total"][0])) < 5e-3 * e["work_pull"][-1]
    curve = load_displacement(scene, e)
    assert curve["component"] == "x" and curve["displacement"][-1] == pytest.approx(0.03, rel=1e-3)


def test_post_load_displacement_and_the_scene_file(tmp_path):
    """The pull as a TOML scene (the README's form), its curve by pfmpm post."""
    scene = pull_scene()
    path = tmp_path / "pull.toml"
    path.write_text(toml_text(plain(scene)))
    assert Scene.from_toml(path) == scene
    out = tmp_path / "run"
    cli = [sys.executable, "-m", "pfmpm.cli"]
    r = subprocess.run(cli + ["run", str(path), "--out", str(out), "--set", "time.end=40", "--quiet"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    r = subprocess.run(cli + ["post", "load-displacement", str(out)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("region pull along x: largest load ") and "(scene units)" not in r.stdout
    curve = read_csv(out / "load_displacement.csv")
    assert list(curve) == ["t", "displacement", "load"] and (out / "load_displacement.png").stat().st_size > 0
    # Once the ramp is over the pull is held at U and carries E A U / L.
    held = curve["t"] > 35.0
    assert np.all(np.abs(curve["displacement"][held] - 0.03) < 1e-12)
    assert np.mean(curve["load"][held]) == pytest.approx(E * 2.0 * 0.03 / 30.0, rel=0.01)
    r = subprocess.run(cli + ["post", "load-displacement", str(out), "--region", "grip"], capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 2 and r.stderr == f"error: {out}: no prescribed region 'grip' (the scene's: pull)\n"


@pytest.mark.parametrize("change, message", [
    ({"velocity": (1.0, 0.0), "displacement": (1.0, 0.0)}, "velocity: give exactly one of velocity and displacement"),
    ({"velocity": None}, "velocity: give exactly one of velocity and displacement"),
    ({"velocity": None, "displacement": (1.0, 0.0)}, "amplitude: a displacement needs one"),
    ({"max": (0.0, 6.0)}, "max = [0.0, 6.0]: must exceed min = [0.0, 0.0] in both directions"),
    ({"components": "z"}, "components = 'z': must be one of 'x', 'y', 'xy'"),
    ({"name": "left"}, "name = 'left': is a grid side's"),
])
def test_bad_regions_are_named(change, message):
    fields = {"name": "grip", "min": (0.0, 0.0), "max": (3.0, 6.0), "velocity": (V, 0.0), "components": "x"}
    with pytest.raises(SceneError) as error:
        Prescribed(**(fields | change))
    assert str(error.value).startswith(message), str(error.value)


def test_regions_in_a_scene_are_checked():
    scene = grip_scene()
    grip = scene.prescribed[0]
    with pytest.raises(SceneError, match=r"^prescribed\[1\].name = 'grip': duplicate name"):
        Scene.from_dict(plain(scene) | {"prescribed": [plain(grip)] * 2})
    with pytest.raises(SceneError, match=r"^prescribed = 5: at most 4 regions"):
        Scene.from_dict(plain(scene) | {"prescribed": [plain(grip) | {"name": f"g{k}"} for k in range(5)]})
    between = plain(grip) | {"min": [3.1, 0.0], "max": [3.2, 6.0]}  # between two control points
    with pytest.raises(SceneError, match=r"^prescribed\[0\].max = \[3.2, 6.0\]: the box from min = \[3.1, 0.0\]"
                                         r" holds no grid node"):
        Simulation(Scene.from_dict(plain(scene) | {"prescribed": [between]}))


def test_a_run_with_regions_and_ramps_resumes_bitwise(tmp_path):
    """The three-point-bending demo (regions, a ramped striker) stopped at
    step 300 and resumed writes the same energies.csv, byte for byte, as the
    uninterrupted run: the regions' impulse, work and displacement are in the
    checkpoint, and the striker's velocity is set again at every step."""
    import shutil

    from pfmpm import checkpoint
    from pfmpm.cli import main

    demo = ROOT / "demos" / "three_point_bending.toml"
    args = ["run", str(demo), "--set", "time.end=40", "--set", "output.particles=false", "--quiet"]
    full, part = tmp_path / "full", tmp_path / "part"
    assert main([*args, "--out", str(full), "--checkpoint-every", "300"]) == 0
    shutil.copytree(full, part)
    for path in checkpoint.list_checkpoints(part / "checkpoints")[1:]:
        path.unlink()
    assert main(["run", "--resume", str(part), "--quiet"]) == 0
    assert (part / "energies.csv").read_bytes() == (full / "energies.csv").read_bytes()
    assert read_csv(full / "energies.csv")["work_striker"][-1] > 0


def test_a_region_that_reaches_no_particle_is_reported():
    """The set-up report warns of a region placed where its nodes reach no
    particle (a grip a cell and a half clear of the bar moves nothing)."""
    from pfmpm.scene.report import setup_report

    scene = grip_scene()
    assert not any("prescribed region" in w for w in setup_report(scene).warnings)
    away = Scene.from_dict(plain(scene) | {"prescribed": [plain(scene.prescribed[0]) | {"max": [0.4, 6.0]}]})
    (warning,) = [w for w in setup_report(away).warnings if "prescribed region" in w]
    assert warning == ("prescribed region grip reaches no particle at t = 0 (none within 1.5 of its box, its"
                       " nodes' reach): it moves nothing until material comes within it")
    # A region of a body's face has no box and holds its particles: no warning.
    assert not any("prescribed region" in w for w in setup_report(face_scene(face="left")).warnings)


@pytest.mark.parametrize("moving", [True, False])
def test_a_moving_box_carries_its_striker(moving):
    """A block (a striker) under a body force of -1 along x, held by a box
    that covers it, moves at V = (1.2, -0.25) for 6 time units, 7.4 cells.
    With ``moving`` the box goes with it: every particle of the block moves
    by V t exactly (to round-off) and keeps the velocity V, whatever the
    force, and the region's work is the kinetic energy it gave plus the work
    it did against the force. A box that stays put loses the block's nodes as
    it leaves, and the force then slows the block."""
    m = LinearElasticSpec("steel", E, 0.3, RHO)
    block = Body("striker", "steel", Rectangle((4.0, 8.0), (6.0, 10.0)), particles_per_cell=2)
    box = Prescribed("striker", (2.5, 6.5), (7.5, 11.5), velocity=(1.2, -0.25), moving=moving)
    scene = Scene(grid=GridSpec(size=(16.0, 16.0), h=1.0, degree=2), time=Time(end=6.0), materials=(m,),
                  bodies=(block,), plane="strain", prescribed=(box,), loads=(BodyForce((-1.0, 0.0)),))
    sim = Simulation(scene)
    x0 = sim.particles.x.copy()
    sim.advance(scene.steps())
    moved = sim.particles.x - x0
    expected = np.array([1.2, -0.25]) * sim.time
    e = sim.energies()
    if moving:
        assert np.abs(moved - expected).max() <= 1e-12 * np.abs(expected).max()
        assert np.abs(sim.particles.v - (1.2, -0.25)).max() <= 1e-13
        mass = sim.particles.mass.sum()
        kinetic = 0.5 * mass * (1.2 ** 2 + 0.25 ** 2)
        assert e["kinetic"] == pytest.approx(kinetic, rel=1e-12)
        assert e["work_striker"] == pytest.approx(kinetic + mass * 1.0 * expected[0], rel=1e-9)
        assert (e["displacement_striker_x"], e["displacement_striker_y"]) == pytest.approx(tuple(expected),
                                                                                            rel=1e-12)
    else:
        assert (expected[0] - moved[:, 0]).min() > 1.0  # measured 2.83


def face_scene(**where) -> Scene:
    """:func:`grip_scene` with the grip a region of the bar's own particles
    (``where``: its face, or particles by index) instead of a box."""
    scene = grip_scene()
    (grip,) = scene.prescribed
    held = Prescribed("grip", velocity=grip.velocity, components="x", amplitude=grip.amplitude, body="bar", **where)
    return Scene(**{**scene.__dict__, "prescribed": (held,)})


@pytest.mark.parametrize("method", METHODS)
def test_a_body_face_pushed_sends_the_bar_wave(method):
    """The grip as the bar's left face (its particle layer; in the FEM the
    vertices of its left edge): the same wave, sigma = -rho c V behind the
    front and as the reaction within 1 %, the momentum the face's impulse to
    round-off, and its work closing the balance to 0.5 %."""
    scene = face_scene(face="left")
    sim = METHODS[method](scene)
    e = run(sim)
    forces = mean_forces(scene, e)
    reaction = forces["region_grip_x"][forces["t"] > 0.7]
    assert np.mean(reaction) == pytest.approx(RHO * C * V * 2.0, rel=0.01)
    if method == "mpm":
        x, sigma = sim.particles.x[:, 0], sim.particles.stress[:, 0]
        # The face is the bar's first layer of particles, x0 + h / 6 at t = 0.
        held = np.flatnonzero(sim.particles.held_by)
        assert np.allclose(sim.particles.x[held, 0], 2.0 + 1.0 / 6.0 + e["displacement_grip_x"][-1], atol=1e-3)
        assert len(held) == 6
    else:
        x, sigma = sim._x[sim._dofs].mean(axis=1)[:, 0], sim.stresses()[:, 0]
    middle = (x > 6.0) & (x < 14.0)
    assert np.mean(sigma[middle]) == pytest.approx(-RHO * C * V, rel=0.01)
    assert np.max(np.abs(e["momentum_x"] - e["impulse_grip_x"])) < 1e-12 * e["impulse_grip_x"][-1]
    drift = e["total"] - e["total"][0]
    assert np.max(np.abs(drift)) < 5e-3 * e["work_grip"][-1]


def test_particles_by_index_are_the_region_their_face_is():
    """The left face's six particles named by index hold the same nodes: the
    run has the face run's energies to the bit."""
    face = run(Simulation(face_scene(face="left")))
    sim = Simulation(face_scene(face="left"))
    indices = np.flatnonzero(sim.particles.held_by)  # bar is the only body: its rows are all rows
    named = run(Simulation(face_scene(particles=[int(i) for i in indices])))
    for key in face:
        assert np.array_equal(face[key], named[key]), key


def test_a_whole_body_region_moves_the_body_rigidly():
    """The whole bar held at V along x: every particle moves at V once the
    ramp is over, with no stress, and the momentum is M V."""
    sim = Simulation(face_scene())
    e = run(sim)
    p = sim.particles
    assert np.all(p.held_by == 1)
    assert np.allclose(p.v[:, 0], V, rtol=1e-12)
    assert np.max(np.abs(p.stress)) < 1e-12 * RHO * C * V
    assert e["momentum_x"][-1] == pytest.approx(p.mass.sum() * V, rel=1e-12)


@pytest.mark.parametrize("region, message", [
    ({"body": "bar", "min": [0.0, 0.0]}, r"^prescribed\[0\]\.min = \[0\.0, 0\.0\]: give a box or a body, not both$"),
    ({"face": "left", "min": [0.0, 0.0], "max": [1.0, 1.0]}, r"^prescribed\[0\]\.face = 'left': needs a body$"),
    ({"body": "bar", "face": "front"},
     r"^prescribed\[0\]\.face = 'front': a side of a 3D grid \(z min or max\); a 2D grid has left, right, bottom, top$"),
    ({"body": "bar", "face": "left", "particles": [1]}, r"^prescribed\[0\]\.particles: give a face or particles, not both$"),
    ({"body": "bar", "particles": [1, 1]}, r"^prescribed\[0\]\.particles = \[1, 1\]: names a particle twice$"),
    ({"body": "beam"}, r"^prescribed\[0\]\.body = 'beam': no body with that name \(have: 'bar'\)$"),
    ({"body": "bar", "moving": True}, r"^prescribed\[0\]\.moving = true: is for a box: a body's region follows its particles$"),
    ({}, r"^prescribed\[0\]\.min: missing: give a box \(min and max\) or a body$"),
])
def test_bad_body_regions_are_named(region, message):
    d = plain(grip_scene())
    d["prescribed"] = [{"name": "grip", "velocity": [V, 0.0], "components": "x", **region}]
    with pytest.raises(SceneError, match=message):
        Scene.from_dict(d)


def test_a_particle_index_past_the_body_and_a_fem_particle_set_are_named():
    with pytest.raises(SceneError, match=r"^prescribed\[0\]\.particles = 1000: body 'bar' has 540 particles"):
        Simulation(face_scene(particles=[3, 1000]))
    with pytest.raises(SceneError, match=r"^prescribed\[0\]\.particles: the FEM path holds a box, a body or"):
        FemSimulation(face_scene(particles=[3]))
