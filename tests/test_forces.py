"""Forces out (issue 53): the walls' reactions and the bodies' momenta.

``energies.csv`` keeps each wall's impulse and, with several bodies, each
body's momentum since t = 0; ``pfmpm.post.forces`` turns them into mean
forces between rows. Checked against Newton's second law to round-off (the
momentum of the bodies is the impulse of the loads and of the walls; two
bodies in contact change their momenta by equal and opposite amounts) and
against the fixed end of a bar under a step load, whose reaction is the
analytic square wave of the reflected wave, in both methods.
"""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pfmpm.output import read_csv
from pfmpm.post.forces import mean_forces
from pfmpm.scene import Body, BodyForce, Contact, Disk, Grid, Material, Rectangle, Scene, Time, Wall
from pfmpm.simulation import Simulation

from test_contact import disks

ROOT = Path(__file__).resolve().parents[1]
BAR = ROOT / "demos" / "vibrating_bar.toml"


def history(sim: Simulation, every: int) -> dict[str, np.ndarray]:
    """The energies.csv columns every ``every`` steps to the end, from t = 0."""
    rows = [sim.energies()]
    while sim.step < sim.scene.steps():
        sim.advance(min(every, sim.scene.steps() - sim.step))
        rows.append(sim.energies())
    return {k: np.array([r[k] for r in rows]) for k in rows[0]}


def bar_reaction(e, scene: Scene) -> tuple[float, float, np.ndarray]:
    """The step load F on the vibrating bar, the plateau times, and the
    left wall's mean reaction between rows."""
    F = 0.1 * 2.0 * scene.thickness  # traction x edge length x thickness
    forces = mean_forces(scene, e)
    return F, forces["t"], forces["wall_left_x"]


def check_bar(e, scene: Scene) -> None:
    """Newton's law to round-off, and the fixed end's square wave: the
    reaction is 0 until the wave arrives (L / c = 2.5), -2 F while it
    reflects there (2.5-7.5), 0 again (7.5-12.5)."""
    F, t, reaction = bar_reaction(e, scene)
    # Momentum = load impulse + wall impulse, every row (the load is a step).
    assert np.max(np.abs(e["momentum_x"] - (F * e["t"] + e["impulse_left_x"]))) < 1e-12 * F * e["t"][-1]
    for start, end, expected in ((0.3, 2.0, 0.0), (3.5, 6.5, -2.0 * F), (8.5, 11.5, 0.0)):
        window = (t > start) & (t < end)
        assert abs(np.mean(reaction[window]) - expected) < 0.02 * F, (start, np.mean(reaction[window]))


def test_a_fixed_end_carries_the_reflected_step_load():
    scene = Scene.from_toml(BAR, ["time.end=12.5"])
    e = history(Simulation(scene), every=2)
    assert "impulse_left_y" in e and "impulse_right_x" not in e
    check_bar(e, scene)


def test_the_fem_reports_the_same_reaction(tmp_path):
    scene = Scene.from_toml(BAR, ["time.end=12.5"])
    out = tmp_path / "fem"
    r = subprocess.run([sys.executable, "-m", "pfmpm.fem", str(BAR), "--out", str(out), "--set", "time.end=12.5",
                        "--quiet"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    check_bar(read_csv(out / "energies.csv"), scene)


def corner_block(left: str, bottom: str) -> Scene:
    """A block in the grid's lower-left corner under a slanted gravity."""
    m = Material("m", 100.0, 0.25, 1.0)
    block = Body("block", "m", Rectangle((0.0, 0.0), (3.0, 2.0)), particles_per_cell=2)
    return Scene(grid=Grid(size=(8.0, 6.0), h=0.5, degree=2), time=Time(end=20.0), materials=(m,),
                 bodies=(block,), loads=(BodyForce((-0.3, -1.0)),),
                 walls=(Wall("left", left), Wall("bottom", bottom)))


@pytest.mark.parametrize("left, bottom", [("slip", "slip"), ("fixed", "fixed")])
def test_walls_in_a_corner_carry_a_resting_blocks_weight(left, bottom):
    """Each wall holds the body along its normal; at the corner node that both
    fixed walls hold, each direction counts as the wall it is normal to. The
    impulses are the weight's to round-off (momentum = weight x t + impulses),
    and over the run the reactions carry the weight (the bouncing body's
    momentum over t is what is left)."""
    scene = corner_block(left, bottom)
    e = history(Simulation(scene), every=20)
    M = 6.0 * scene.thickness  # density 1, 3 x 2
    t = e["t"]
    for d, g in (("x", -0.3), ("y", -1.0)):
        walls = e[f"impulse_left_{d}"] + e[f"impulse_bottom_{d}"]
        assert np.max(np.abs(e[f"momentum_{d}"] - (M * g * t + walls))) < 1e-12 * M * t[-1]
    # Normal reactions push the block out of the corner; with slip walls
    # nothing holds it along a wall.
    assert e["impulse_left_x"][-1] > 0 and e["impulse_bottom_y"][-1] > 0
    if left == "slip":
        assert e["impulse_left_y"][-1] == 0.0 and e["impulse_bottom_x"][-1] == 0.0
    # Mean reactions over the run: the weight, up to the momentum left (measured
    # 1e-5 - 6e-5).
    T = t[-1]
    assert e["impulse_left_x"][-1] / T + e["impulse_bottom_x"][-1] / T == pytest.approx(0.3 * M, rel=1e-3)
    assert e["impulse_bottom_y"][-1] / T + e["impulse_left_y"][-1] / T == pytest.approx(M, rel=1e-3)


def test_colliding_disks_push_each_other_equally_and_oppositely():
    scene = disks(0.8)
    e = history(Simulation(scene), every=5)
    forces = mean_forces(scene, e)
    for d in "xy":
        a, b = forces[f"body_a_{d}"], forces[f"body_b_{d}"]
        peak = np.max(np.abs(a))
        assert peak > 0.1  # they met
        assert np.max(np.abs(a + b)) < 1e-10 * peak
        # Each disk's momentum is its own column; together the total.
        assert np.max(np.abs(e[f"momentum_{d}_a"] + e[f"momentum_{d}_b"] - e[f"momentum_{d}"])) < 1e-13
    # The collision pushes a back along x: its x momentum falls.
    assert e["momentum_x_a"][-1] < 0.5 * e["momentum_x_a"][0]


def test_three_disks_contact_impulses_per_pair_are_each_disks_momentum():
    """Three disks meet, with friction (b from the left onto a, c from above
    into the gap between them): each pair's contact impulse (``contact_<a>_<b>_x|y``, of the
    second body on the first) adds up, for each disk, to the change of its
    momentum to round-off, the only forces being contact; every pair met."""
    m = Material("m", 100.0, 0.3, 1.0)
    a = Body("a", "m", Disk((4.0, 3.0), 1.0), particles_per_cell=2)
    b = Body("b", "m", Disk((1.75, 3.0), 1.0), particles_per_cell=2, velocity=(0.3, 0.0))
    c = Body("c", "m", Disk((2.875, 4.7), 0.8), particles_per_cell=2, velocity=(0.0, -0.3))
    scene = Scene(grid=Grid(size=(8.0, 7.0), h=0.0625, degree=2), time=Time(end=2.5, cfl=0.5),
                  materials=(m,), bodies=(a, b, c), plane="strain", contact=Contact(friction=0.3))
    e = history(Simulation(scene), every=10)
    pair = {(x, y): np.array([e[f"contact_{x}_{y}_x"], e[f"contact_{x}_{y}_y"]]) for x, y in
            (("a", "b"), ("a", "c"), ("b", "c"))}
    on = {"a": pair["a", "b"] + pair["a", "c"], "b": pair["b", "c"] - pair["a", "b"],
          "c": -pair["a", "c"] - pair["b", "c"]}
    scale = max(np.abs(v).max() for v in pair.values())
    for body, impulse in on.items():
        momentum = np.array([e[f"momentum_x_{body}"], e[f"momentum_y_{body}"]])
        assert np.abs(momentum - momentum[:, :1] - impulse).max() < 1e-12 * scale, body
    # Every pair met: the smallest final impulse, of c on a, measured 0.0038 (b on c: 0.98).
    for name, impulse in pair.items():
        assert np.hypot(*impulse[:, -1]) > 1e-3 * scale, name


def test_post_forces_writes_the_curves_with_units(tmp_path):
    out = tmp_path / "bar"
    run = [sys.executable, "-m", "pfmpm.cli", "run", str(BAR), "--out", str(out), "--set", "time.end=12.5",
           "--set", "units=\"mm-ms-MPa\"", "--quiet"]
    assert subprocess.run(run, capture_output=True, text=True, timeout=300).returncode == 0
    r = subprocess.run([sys.executable, "-m", "pfmpm.cli", "post", "forces", str(out)], capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "wall left x: largest" in r.stdout and " N at t = " in r.stdout and " ms" in r.stdout
    assert (out / "forces.png").stat().st_size > 0
    forces = read_csv(out / "forces.csv")
    assert list(forces) == ["t", "wall_left_x", "wall_left_y", "net_x", "net_y"]
    # The net force is the load plus the wall's reaction.
    F = 0.1 * 2.0
    assert np.max(np.abs(forces["net_x"] - (F + forces["wall_left_x"]))) < 1e-9


@pytest.mark.parametrize("walls", [True, False])
def test_a_checkpoint_from_before_the_impulses(tmp_path, walls):
    """A file written before the walls' impulses were kept: without walls they
    were zero and the run resumes; with walls its energies.csv could not go
    on, and reading it is a one-line error."""
    import h5py

    from pfmpm import checkpoint

    out = tmp_path / "bar"
    run = [sys.executable, "-m", "pfmpm.cli", "run", str(BAR), "--out", str(out), "--set", "time.end=2",
           "--checkpoint-every", "10", "--quiet"] + ([] if walls else ["--set", "walls=[]"])
    assert subprocess.run(run, capture_output=True, text=True, timeout=300).returncode == 0
    path = checkpoint.list_checkpoints(out / "checkpoints")[-1]
    with h5py.File(path, "r+") as f:
        meta = json.loads(f.attrs["meta"])
        meta["solver"] = {k: v for k, v in meta["solver"].items() if not k.startswith("wall_impulse/")}
        arrays = {}
        f.visititems(lambda name, obj: arrays.__setitem__(name, obj[()]) if isinstance(obj, h5py.Dataset)
                     else None)
        f.attrs["meta"] = json.dumps(meta, sort_keys=True)
        f.attrs["sha256"] = checkpoint._digest(meta, arrays)
    if walls:
        with pytest.raises(checkpoint.CheckpointError, match="written before the walls' impulses were recorded"):
            checkpoint.read(path)
    else:
        scalars = checkpoint.read(path).solver["scalars"]
        assert all(scalars[f"wall_impulse/{s}/{d}"] == 0.0 for s in ("left", "right", "bottom", "top")
                   for d in "xy")
