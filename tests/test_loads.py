"""Loads over time and on part of an edge or face (issue 53): a load's
``amplitude`` (a smooth ramp or a table) and a traction's ``span``, in both
methods.

A bar loaded by a ramp slower than its wave period carries the load to its
fixed end without the step's twofold overshoot, and the energy balance
closes with the work of the changing load; a span loads its part of the edge
exactly, and in 3D a patch of a face its area; bad amplitudes and spans are
one-line errors.
"""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pfmpm.output import read_csv
from pfmpm.post.forces import mean_forces
from pfmpm.scene import Ramp, Scene, SceneError, Table, Traction
from pfmpm.scene.toml import plain
from pfmpm.simulation import Simulation

from test_forces import history

ROOT = Path(__file__).resolve().parents[1]
BAR = ROOT / "demos" / "vibrating_bar.toml"
F = 0.1 * 2.0  # the bar's end load: traction x edge length x thickness 1
RAMP = ['loads.0.amplitude={type = "ramp", time = 20.0}', "time.end=40"]


def test_amplitudes_are_the_documented_functions():
    ramp = Ramp(10.0)
    assert [ramp(t) for t in (-1.0, 0.0, 2.5, 5.0, 10.0, 30.0)] == [0.0, 0.0, 0.15625, 0.5, 1.0, 1.0]
    # Zero rate at both ends (central differences over 2e-6 of the ramp).
    assert abs(ramp(1e-5) - ramp(-1e-5)) < 1e-9 and abs(ramp(10.0 + 1e-5) - ramp(10.0 - 1e-5)) < 1e-9
    table = Table((1.0, 2.0, 4.0), (0.0, 3.0, 1.0))
    assert [table(t) for t in (0.0, 1.5, 3.0, 9.0)] == [0.0, 1.5, 2.0, 1.0]


def check_ramped_bar(e, scene: Scene) -> None:
    """Against the same bar under a step: the fixed end's reaction is the load
    once the ramp is over (its mean over t > 25, to 0.1 %) and never
    overshoots to the step's 2 F (at most 1.1 F); the energy balance closes
    to 0.5 % of the work."""
    forces = mean_forces(scene, e)
    reaction, t = forces["wall_left_x"], forces["t"]
    assert np.mean(reaction[t > 25.0]) == pytest.approx(-F, rel=1e-3)
    assert np.max(np.abs(reaction)) < 1.1 * F
    drift = e["total"] - e["total"][0]
    assert np.max(np.abs(drift)) < 5e-3 * np.max(np.abs(e["external_work"]))
    # The momentum is the ramp's impulse (the integral of s^2 (3 - 2 s)) plus
    # the wall's, every row.
    s = np.clip(e["t"] / 20.0, 0.0, 1.0)
    load_impulse = F * np.where(e["t"] < 20.0, 20.0 * (s ** 3 - s ** 4 / 2), 10.0 + (e["t"] - 20.0))
    assert np.max(np.abs(e["momentum_x"] - load_impulse - e["impulse_left_x"])) < 2e-3 * F * e["t"][-1]


def test_a_ramped_load_reaches_its_static_reaction_without_overshoot():
    scene = Scene.from_toml(BAR, RAMP)
    check_ramped_bar(history(Simulation(scene), every=2), scene)


def test_the_fem_ramps_the_load_alike(tmp_path):
    scene = Scene.from_toml(BAR, RAMP)
    out = tmp_path / "fem"
    sets = [a for s in RAMP for a in ("--set", s)]
    r = subprocess.run([sys.executable, "-m", "pfmpm.fem", str(BAR), "--out", str(out), *sets, "--quiet"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    check_ramped_bar(read_csv(out / "energies.csv"), scene)


def test_each_step_takes_the_load_at_its_midpoint():
    scene = Scene.from_toml(BAR, ['loads.0.amplitude={type = "table", times = [0, 10], values = [0, 1]}'])
    sim = Simulation(scene)
    loaded = sim.particles.fext[:, 0] != 0.0
    assert not loaded.any()  # zero at t = 0
    sim.advance(3)
    layer = np.isclose(sim.particles.x[:, 0], sim.particles.x[:, 0].max(), atol=0.2)
    expected = (2.5 * sim.dt / 10.0) * 0.1 / 3.0  # a(t of the third step's midpoint) x traction x spacing
    np.testing.assert_allclose(sim.particles.fext[layer, 0], expected, rtol=1e-12)
    assert np.all(sim.particles.fext[~layer] == 0.0)


def test_a_span_loads_its_part_of_the_edge():
    """Half of the bar's right edge (y from 2 to 3 of 2 to 4): half the force,
    on the particles of that half, in both methods."""
    from pfmpm.fem import FemSimulation

    scene = Scene.from_toml(BAR, ["loads.0.span=[2.0, 3.0]"])
    sim = Simulation(scene)
    fext, x = sim.particles.fext, sim.particles.x
    assert fext[:, 0].sum() == pytest.approx(0.1 * 1.0, rel=1e-14)
    assert np.all(x[fext[:, 0] != 0.0, 1] < 3.0)
    fem = FemSimulation(scene)
    assert fem.external_force[:, 0].sum() == pytest.approx(0.1 * 1.0, rel=1e-14)


def test_amplitudes_and_spans_round_trip_through_toml():
    scene = Scene.from_toml(BAR, ['loads.0.amplitude={type = "table", times = [0, 1.5], values = [0, 2]}',
                                  "loads.0.span=[2.0, 3.5]"])
    assert scene.loads[0] == Traction("bar", "right", (0.1, 0.0), Table((0.0, 1.5), (0.0, 2.0)), (2.0, 3.5))
    assert Scene.from_dict(plain(scene)) == scene


@pytest.mark.parametrize("override, message", [
    ('loads.0.amplitude={type = "ramp", time = 0}', "loads[0].amplitude.time = 0: must be > 0"),
    ('loads.0.amplitude={type = "table", times = [0, 2, 1], values = [0, 1, 0]}',
     "loads[0].amplitude.times[2] = 1.0: must be greater than times[1] = 2.0"),
    ('loads.0.amplitude={type = "table", times = [0, 1], values = [1]}',
     "loads[0].amplitude.values = [1]: must have one value per time (2)"),
    ('loads.0.amplitude={type = "sine", period = 1}', "loads[0].amplitude.type = 'sine': must be one of"),
    ("loads.0.span=[3.0, 2.0]", "loads[0].span = [3.0, 2.0]: must be [a, b] with a < b"),
])
def test_bad_amplitudes_and_spans_are_named(override, message):
    with pytest.raises(SceneError) as error:
        Scene.from_toml(BAR, [override])
    assert str(error.value).startswith(message), str(error.value)


def test_a_span_off_the_edge_is_named():
    from pfmpm.fem import FemSimulation

    scene = Scene.from_toml(BAR, ["loads.0.span=[4.5, 6.0]"])
    with pytest.raises(SceneError, match=r"loads\[0\].span = \[4.5, 6.0\]: holds no particle of the right edge"
                                         r" layer of body 'bar'$"):
        Simulation(scene)
    with pytest.raises(SceneError, match=r"loads\[0\].span = \[4.5, 6.0\]: holds the midpoint of no cell edge"):
        FemSimulation(scene)


def block(h: float, span) -> dict:
    """A 3D box 8 x 4 x 4 on a grid of cell ``h``, its faces on grid lines,
    with a traction on a patch ``span`` of its top face, as tables."""
    return {"name": "block", "grid": {"size": [10.0, 6.0, 6.0], "origin": [-1.0, -1.0, -1.0], "h": h},
            "time": {"end": 1.0}, "materials": [{"name": "m", "E": 100.0, "nu": 0.3, "density": 1.0}],
            "bodies": [{"name": "b", "material": "m", "particles_per_cell": 2,
                        "shape": {"type": "box", "min": [0.0, 0.0, 0.0], "max": [8.0, 4.0, 4.0]}}],
            "loads": [{"type": "traction", "body": "b", "edge": "top", "traction": list(TRACTION), "span": span}]}


TRACTION = (0.5, -2.0, 0.25)
"""The patch's traction: every component, so that each is checked."""


@pytest.mark.parametrize("h", [1.0, 0.5])
def test_a_patch_of_a_face_gets_traction_times_its_area_in_both_methods(h):
    """The patch x in [2, 6], z in [1, 3] of the block's top face (area 8),
    its edges on grid lines: the MPM loads the top layer's particles in it
    ((h/2)^2 each), the FEM the face's triangles whose centroids lie in it
    (a third of each's area to its corners); both total the traction times
    8, and nothing outside the patch is loaded."""
    from pfmpm.fem import FemSimulation

    scene = Scene.from_dict(block(h, [[2.0, 6.0], [1.0, 3.0]]))
    assert scene.loads[0].patch() == ((0, 2.0, 6.0), (2, 1.0, 3.0))
    mpm, fem = Simulation(scene), FemSimulation(scene)
    runs = {"mpm": (mpm.particles.x, mpm.particles.fext, 4.0 - h / 4),  # the top particle layer
            "fem": (fem.vertices[:fem.owned], fem.external_force, 4.0)}  # the top face
    for name, (x, f, top) in runs.items():
        np.testing.assert_allclose(f.sum(axis=0), 8.0 * np.asarray(TRACTION), rtol=1e-12, err_msg=name)
        loaded = x[np.any(f != 0.0, axis=1)]
        assert np.all(loaded[:, 1] == top), name
        assert loaded[:, 0].min() >= 2.0 and loaded[:, 0].max() <= 6.0, name
        assert loaded[:, 2].min() >= 1.0 and loaded[:, 2].max() <= 3.0, name
    # The patch's particles, (4 / (h/2)) x (2 / (h/2)); its vertices, (4 / h + 1) x (2 / h + 1).
    assert np.count_nonzero(mpm.particles.fext[:, 1]) == (8 / h) * (4 / h)
    assert np.count_nonzero(fem.external_force[:, 1]) == (4 / h + 1) * (2 / h + 1)


@pytest.mark.parametrize("span, message", [
    ([2.0, 3.0], "loads[0].span = [2.0, 3.0]: in 3D a span is two intervals [[a, b], [c, d]], along x then z"
                 " on the top face"),
    ([[2.0, 6.0], [3.0, 1.0]], "loads[0].span = [[2.0, 6.0], [3.0, 1.0]]: must be [[a, b], [c, d]] with a < b"
                               " and c < d"),
    ([[2.0, 6.0], 1.0], "loads[0].span = [[2.0, 6.0], 1.0]: must be [a, b] (an edge's, 2D) or [[a, b], [c, d]]"),
    ([[2.0, 6.0], [1.0, 2.0], [0.0, 1.0]], "loads[0].span = [[2.0, 6.0], [1.0, 2.0], [0.0, 1.0]]: must be [a, b]"),
    ([[2.0, 6.0], [1.0, "z"]], "loads[0].span[1][1] = 'z': must be a number"),
])
def test_bad_patches_are_named(span, message):
    with pytest.raises(SceneError) as error:
        Scene.from_dict(block(1.0, span))
    assert str(error.value).startswith(message) and "\n" not in str(error.value), str(error.value)


def test_a_2d_span_of_two_intervals_is_named():
    with pytest.raises(SceneError) as error:
        Scene.from_toml(BAR, ["loads.0.span=[[2.0, 3.0], [0.0, 1.0]]"])
    assert str(error.value) == ("loads[0].span = [[2.0, 3.0], [0.0, 1.0]]: in 2D a span is one interval [a, b],"
                                " along y on the right edge")


def test_a_patch_off_the_face_is_named():
    """A patch beside the block's top face (z in [4.5, 5]) holds no particle
    and no triangle's centroid."""
    from pfmpm.fem import FemSimulation

    scene = Scene.from_dict(block(1.0, [[2.0, 6.0], [4.5, 5.0]]))
    with pytest.raises(SceneError, match=r"loads\[0\].span = \[\[2.0, 6.0\], \[4.5, 5.0\]\]: holds no particle of"
                                         r" the top face layer of body 'b'$"):
        Simulation(scene)
    with pytest.raises(SceneError, match=r"loads\[0\].span = .*: holds the centroid of no cell face of the FEM"
                                         r" mesh on the top face of body 'b'$"):
        FemSimulation(scene)


def test_patches_round_trip_through_toml():
    scene = Scene.from_dict(block(1.0, [[2.0, 6.0], [1.0, 3.0]]))
    assert scene.loads[0].span == ((2.0, 6.0), (1.0, 3.0))
    assert Scene.from_dict(plain(scene)) == scene
