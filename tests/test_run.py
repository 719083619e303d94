"""The run loop of pfmpm.run, which the MPM and FEM paths share, on a stand-in
simulation: what it records when, and how a run ends."""

import json
import os
import signal
from pathlib import Path

import pytest

from pfmpm import SimulationError
from pfmpm.output import read_csv
from pfmpm.run import ENERGY_COLUMNS, run_to_end
from pfmpm.scene import Scene

BAR = Path(__file__).resolve().parents[1] / "demos" / "vibrating_bar.toml"


class Stepper:
    """A simulation for the run loop: a unit mass at constant speed 2.

    ``signal_at`` sends this process SIGTERM when that step is reached;
    ``fail_at`` raises a SimulationError there.
    """

    comm = None
    checkpoints = False
    cracks = False
    field_series = True

    def __init__(self, scene, signal_at=None, fail_at=None):
        self.scene = scene
        self.dt = scene.dt()
        self.step = 0
        self.frames = []
        self.advances = []
        self._signal_at, self._fail_at = signal_at, fail_at

    @property
    def time(self):
        return self.step * self.dt

    def advance(self, n):
        self.advances.append(n)
        for _ in range(n):
            self.step += 1
            if self.step == self._fail_at:
                raise SimulationError(f"x not finite at step {self.step}")
            if self.step == self._signal_at:
                os.kill(os.getpid(), signal.SIGTERM)

    def energies(self):
        return {"step": self.step, "t": self.time, "kinetic": 2.0, "elastic": 0.0, "fracture": 0.0,
                "external_work": 0.0, "total": 2.0, "momentum_x": 2.0, "momentum_y": 0.0}

    def columns(self, observed=()):
        return ENERGY_COLUMNS + list(observed)

    def open_frames(self, out, entries=()):
        sim = self

        class Frames:
            def write(self):
                sim.frames.append(sim.step)

            def close(self):
                sim.frames.append("closed")

        return Frames()

    def summary_fields(self, result):
        return {"stepper": True}


def bar(end_steps):
    """The vibrating bar scene, energies every 3 steps and frames every 5, to ``end_steps`` steps."""
    scene = Scene.from_toml(BAR, ["output.energies_every=3", "output.every=5"])
    return Scene.from_toml(BAR, ["output.energies_every=3", "output.every=5",
                                 f"time.end={end_steps * scene.dt()!r}"])


def test_a_run_records_at_every_multiple_and_at_both_ends(tmp_path):
    sim = Stepper(bar(17))
    result = run_to_end(sim, tmp_path, progress=False)
    assert (result.status, result.steps, result.steps_planned, result.error) == ("completed", 17, 17, None)
    assert read_csv(tmp_path / "energies.csv")["step"].tolist() == [0, 3, 6, 9, 12, 15, 17]
    assert sim.frames == [0, 5, 10, 15, 17, "closed"]
    assert sim.advances == [3, 2, 1, 3, 1, 2, 3, 2]  # stops at 3, 5, 6, 9, 10, 12, 15, 17
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["status"] == "completed" and summary["stepper"] and summary["scene"] == "vibrating-bar"
    assert (tmp_path / "energies.png").exists()


def test_sigterm_stops_the_run_after_the_chunk_it_arrives_in(tmp_path):
    sim = Stepper(bar(30), signal_at=7)
    before = signal.getsignal(signal.SIGTERM)
    result = run_to_end(sim, tmp_path, progress=False)
    assert (result.status, result.signal, result.steps) == ("interrupted", signal.SIGTERM, 9)
    assert read_csv(tmp_path / "energies.csv")["step"].tolist() == [0, 3, 6, 9]
    assert json.loads((tmp_path / "summary.json").read_text())["status"] == "interrupted"
    assert not (tmp_path / "energies.png").exists()
    assert signal.getsignal(signal.SIGTERM) == before  # the handler is put back


def test_a_simulation_error_fails_the_run_and_keeps_its_output(tmp_path):
    sim = Stepper(bar(30), fail_at=11)
    result = run_to_end(sim, tmp_path, progress=False)
    assert (result.status, result.error, result.steps) == ("failed", "x not finite at step 11", 11)
    assert read_csv(tmp_path / "energies.csv")["step"].tolist() == [0, 3, 6, 9]
    assert sim.frames == [0, 5, 10, "closed"]
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert (summary["status"], summary["error"]) == ("failed", "x not finite at step 11")


def test_a_simulation_without_checkpoints_refuses_them(tmp_path):
    with pytest.raises(ValueError, match="Stepper writes no checkpoints"):
        run_to_end(Stepper(bar(5)), tmp_path, progress=False, checkpoint_every=2)
