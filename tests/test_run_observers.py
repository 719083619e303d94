"""The observers of the run loop (pfmpm.observe, issue 53): a user's own
observer adds a column to energies.csv beside the standard ones, keeps its
state in checkpoints, and the figures are drawn after the simulation is gone."""

import gc
import shutil
import weakref
from pathlib import Path

import numpy as np
import pytest

from pfmpm import Scene, Simulation, checkpoint
from pfmpm.observe import CRACK_PATH, CrackObserver, CrackPath, CrackTip, Observer, default_observers
from pfmpm.output import read_csv

ROOT = Path(__file__).resolve().parents[1]
# The Borden plate at h = 1 mm, l0 = 2 mm, one particle per cell (4,000
# particles, 166 steps to 20 us): the crack starts at about 15 us.
BORDEN = ROOT / "demos" / "borden_plate.toml"
COARSE = ["grid.h=1.0", "materials.concrete.fracture.l0=2.0", "bodies.plate.particles_per_cell=1",
          "output.energies_every=5", "output.every=40", "output.snapshots=[0.0, 12.0]", "time.end=20"]


class MaxSpeed(Observer):
    """At each row, the largest particle speed now (``max_speed``) and how
    far a particle at that speed since the row before would have gone since
    t = 0 (``max_travel``, the sum of speed times the time since the row
    before), which a resumed run can only continue from its checkpoint."""

    def __init__(self):
        self.travel, self.t = 0.0, 0.0

    def columns(self):
        return ["max_speed", "max_travel"]

    def record(self, sim, row, force):
        if row is None:
            return
        v = sim.particles.v
        speed = float(np.sqrt(np.max(v[:, 0] ** 2 + v[:, 1] ** 2)))
        self.travel += speed * (sim.time - self.t)
        self.t = sim.time
        row["max_speed"], row["max_travel"] = speed, self.travel

    def state(self):
        return {"max_travel": np.array([self.travel, self.t])}

    def restore(self, sim, state):
        self.travel, self.t = (float(value) for value in state["max_travel"])


def speeds_at(scene, steps):
    """The largest particle speed of ``scene`` at each of ``steps``, stepping it without the run loop."""
    sim = Simulation(scene)
    speeds = []
    for step in steps:
        sim.advance(int(step) - sim.step)
        v = sim.particles.v
        speeds.append(np.sqrt(np.max(v[:, 0] ** 2 + v[:, 1] ** 2)))
    return np.array(speeds)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The coarse Borden plate run with the standard observers alone, and
    with MaxSpeed too (checkpoints every 60 steps)."""
    scene = Scene.from_toml(BORDEN, COARSE)
    plain, watched = tmp_path_factory.mktemp("plain"), tmp_path_factory.mktemp("watched")
    assert Simulation(scene).run(plain, progress=False).status == "completed"
    sim = Simulation(scene)
    result = sim.run(watched, progress=False, checkpoint_every=60, keep=5,
                     observers=default_observers(sim) + [MaxSpeed()])
    assert result.status == "completed"
    return scene, plain, watched


def test_a_users_observer_adds_its_column_and_changes_nothing_else(runs):
    scene, plain, watched = runs
    e, before = read_csv(watched / "energies.csv"), read_csv(plain / "energies.csv")
    assert list(e) == list(before) + ["max_speed", "max_travel"]
    assert list(before)[-9:] == CrackTip.columns()
    for column in before:
        np.testing.assert_array_equal(e[column], before[column], err_msg=column)
    assert e["step"].tolist() == list(range(0, scene.steps(), 5)) + [scene.steps()]
    # The column is the largest |v| of the particles at the row's step.
    expected = speeds_at(scene, e["step"])
    np.testing.assert_array_equal(e["max_speed"], expected)
    assert expected[0] == 0.0 and expected[-1] > 1e-4  # at rest, then the traction sets the plate moving
    np.testing.assert_array_equal(e["max_travel"], np.cumsum(expected * np.diff(e["t"], prepend=0.0)))
    for name in (CRACK_PATH, "particles.pvd", "particles_000160.vtu"):
        assert (watched / name).read_bytes() == (plain / name).read_bytes(), name


def test_a_resumed_run_continues_the_observers_state(runs, tmp_path):
    scene, _, watched = runs
    full = read_csv(watched / "energies.csv")
    step = 60
    # A resumed run that started its sum afresh would write another column.
    travel = full["max_travel"][full["step"] == step][0]
    assert travel > 0.0

    part = tmp_path / "part"
    shutil.copytree(watched, part)
    for path in checkpoint.list_checkpoints(part / "checkpoints")[1:]:
        path.unlink()
    ckpt = checkpoint.find(part)
    assert ckpt.step == step and ckpt.observed["max_travel"].tolist() == [travel, full["t"][full["step"] == step][0]]
    assert {"crack_tip", "crack_id", "crack_time", "crack_xy", "snapshot_times", "series_time"} <= ckpt.observed.keys()
    sim = Simulation(Scene.from_dict(ckpt.scene))
    result = sim.run(part, progress=False, checkpoint_every=ckpt.checkpoint_every, keep=ckpt.keep, resume=ckpt,
                     observers=default_observers(sim) + [MaxSpeed()])
    assert result.status == "completed"
    for name in ("energies.csv", CRACK_PATH, "particles.pvd", "particles_000166.vtu"):
        assert (part / name).read_bytes() == (watched / name).read_bytes(), name


def test_two_observers_of_one_column_are_refused(tmp_path):
    sim = Simulation(Scene.from_toml(BORDEN, COARSE))
    with pytest.raises(ValueError, match="energies.csv column max_speed is given twice"):
        sim.run(tmp_path / "out", progress=False, observers=[MaxSpeed(), MaxSpeed()])
    assert not (tmp_path / "out").exists()


def test_the_figures_are_drawn_after_the_simulation_is_gone(tmp_path):
    """What ``pfmpm run`` does to keep its peak memory down: the figures of
    ``draw=False`` hold no reference to the simulation."""
    sim = Simulation(Scene.from_toml(BORDEN, COARSE))
    result = sim.run(tmp_path, progress=False, draw=False)
    alive = weakref.ref(sim)
    del sim
    gc.collect()
    assert alive() is None
    assert not list(tmp_path.glob("*.png"))
    result.figures.draw()
    assert sorted(p.name for p in tmp_path.glob("*.png")) == ["crack_path.png", "crack_tip.png", "energies.png",
                                                              "phase_field.png"]


def test_the_crack_path_follows_the_ids_whatever_the_order():
    """Points given in any order, or split between two owners (ranks), give
    the same path by id: the ids cracked, ascending, the time of the first
    record each was cracked at and its position then."""
    rng = np.random.default_rng(5)
    n = 60
    ids = np.sort(rng.choice(1000, size=n, replace=False))
    xy1, xy2 = rng.random((n, 2)), rng.random((n, 2))
    c1 = np.where(rng.random(n) < 0.2, 0.0, 1.0)
    c2 = np.minimum(c1, np.where(rng.random(n) < 0.3, 0.0, 1.0))
    paths = [CrackPath(0.5) for _ in range(4)]
    order = rng.permutation(n)
    half = [order[:n // 2], order[n // 2:]]
    for t, c, xy in ((1.0, c1, xy1), (2.0, c2, xy2)):
        paths[0].update(t, c, xy, ids)
        paths[1].update(t, c[order], xy[order], ids[order])
        for path, part in zip(paths[2:], half):
            path.update(t, c[part], xy[part], ids[part])
    first = c1 < 0.5
    cracked = c2 < 0.5
    np.testing.assert_array_equal(paths[0].ids, ids[cracked])
    np.testing.assert_array_equal(paths[0].times, np.where(first, 1.0, 2.0)[cracked])
    np.testing.assert_array_equal(paths[0].positions, np.where(first[:, None], xy1, xy2)[cracked])
    merged = CrackPath(0.5)
    merged.restore(*(np.concatenate([getattr(p, name) for p in paths[2:]]) for name in ("ids", "times", "positions")))
    for path in (paths[1], merged):
        for name in ("ids", "times", "positions"):
            np.testing.assert_array_equal(getattr(path, name), getattr(paths[0], name))


def test_the_crack_path_of_a_file_by_rows_is_read_by_the_ids_of_those_rows():
    """Checkpoints before version 7 kept the crack path with a row per
    crackable particle, NaN while intact: a restore takes the ids of those
    rows, as the path by id of the same particles. A hole in the plate makes
    the ids past it differ from the rows."""
    sim = Simulation(Scene.from_toml(BORDEN, COARSE + ['bodies.plate.holes=[{type = "disk", center = [80.0, 5.0],'
                                                       ' radius = 3.0}]']))
    p = sim.particles
    p.c[[3500, 3900]] = 0.0
    assert p.id[3500] != 3500
    watched = CrackObserver(sim)
    watched.record(sim, {}, True)
    state = watched.state()
    rows = np.flatnonzero(p.c < sim.scene.output.crack_threshold)  # with the initial crack's
    np.testing.assert_array_equal(state["crack_id"], p.id[rows])
    times, xy = np.full(len(p), np.nan), np.full((len(p), 2), np.nan)
    times[rows], xy[rows] = sim.time, p.x[rows]
    again = CrackObserver(sim)
    again.restore(sim, {"crack_tip": state["crack_tip"], "crack_time": times, "crack_xy": xy})
    for name, value in again.state().items():
        np.testing.assert_array_equal(value, state[name], err_msg=name)
