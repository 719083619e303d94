"""The efficiency study of Homel & Herbold 2017, section 3.5 (benchmarks.efficiency.measure,
benchmarks/efficiency/study.py): checks E1-E5 computed from a timing table whose answers
are known, painting a damage state, and the driver's smoke mode, whose table
must have its structure and runs that end bitwise the same on 1 and 2
threads (E5). No timing is asserted: docs/performance/efficiency.md records them."""

import json
import runpy
from pathlib import Path

import numpy as np
import pytest

from benchmarks.efficiency import measure as efficiency
from pfmpm.output import read_csv
from pfmpm.post.fragments import failed
from pfmpm.scene import Scene
from pfmpm.simulation import Simulation

ROOT = Path(__file__).resolve().parents[1]
DISK = ROOT / "tests" / "data" / "efficiency_disk.toml"


def table(ratio=1.5, gradient_power=1.0, digest_of=lambda n, d, t: 7):
    """Three rounds at four sizes, both methods, 1 and 2 threads: SF 1e-7 n_p s
    per step on one thread, DFG `ratio` times that, the particle DFG block
    3e-8 n_p^gradient_power (scaled to 3e-3 s at n_p = 1e5), the DFG blocks
    30 % of the DFG step and the neighbour lists 0.5 % of it; 2 threads half
    the time; the rounds spread by +-10 % about the median."""
    rows = []
    for r, noise in enumerate((1.1, 1.0, 0.9)):
        for n in (10_000, 50_000, 100_000, 400_000):
            for t in (1, 2):
                for d in (0, 1):
                    seconds = 1e-7 * n * (ratio if d else 1.0) / t * noise
                    gradient = 3e-3 * (n / 1e5) ** gradient_power * noise if d else 0.0
                    rows.append({
                        "round": r, "k": 1.0, "h": 0.1, "particles": n, "dfg": d, "threads": t,
                        "steps": 200, "warmup": 50, "seconds": seconds, "cpu_seconds": seconds * t,
                        "sort": 0.0, "phase_field": 0.0, "fields": 0.0, "p2g": 0.0, "grid": 0.0,
                        "g2p": 0.0, "damage": 0.0, "neighbours": 0.005 * seconds if d else 0.0,
                        "gradient": gradient,
                        "partition": 0.3 * seconds - gradient - 0.005 * seconds if d else 0.0,
                        "neighbour_builds": 1, "evaluated": 0.1 * n if d else 0.0,
                        "digest": digest_of(n, d, t), "load": 1.0})
    return rows


def test_checks_of_a_table_that_passes():
    c = efficiency.checks(table())
    assert c["E1"]["value"] == pytest.approx(0.005) and c["E1"]["passed"]
    # E2 on one thread for 3.2e4 < n_p < 1.5e5 only: the 50k and 100k sizes.
    assert c["E2"]["value"] == pytest.approx(1.5) and c["E2"]["passed"]
    assert set(c["E2"]["per_size"]) == {10_000, 50_000, 100_000, 400_000}
    assert c["E3"]["value"] == pytest.approx(1.0) and c["E3"]["passed"]
    assert c["E3"]["evaluated_slope"] == pytest.approx(1.0)
    assert c["E3"]["per_evaluation_slope"] == pytest.approx(1.0)
    assert c["E4"]["value"] == pytest.approx(0.3) and c["E4"]["particles"] == 400_000
    assert c["E4"]["passed"]
    assert c["E5"] == {"value": 0, "limit": 0, "passed": True, "compared": 8}
    assert c["slopes"]["sf_1"] == pytest.approx(1.0) and c["slopes"]["dfg_2"] == pytest.approx(1.0)
    # On CPU time (twice the wall time on 2 threads here): the same ratios on one thread.
    assert efficiency.checks(table(), time="cpu_seconds")["E2"]["value"] == pytest.approx(1.5)


def test_checks_of_a_table_that_fails():
    c = efficiency.checks(table(ratio=1.7, gradient_power=1.3,
                                digest_of=lambda n, d, t: 8 if (n, d, t) == (50_000, 1, 2) else 7))
    assert c["E2"]["value"] == pytest.approx(1.7) and not c["E2"]["passed"]
    assert c["E3"]["value"] == pytest.approx(1.3) and not c["E3"]["passed"]
    assert c["E3"]["per_evaluation_slope"] == pytest.approx(1.3)
    assert c["E5"]["value"] == 1 and not c["E5"]["passed"]
    # One thread count only: E5 cannot tell.
    one = [r for r in table() if r["threads"] == 1]
    assert efficiency.checks(one)["E5"]["passed"] is None


def test_medians_over_the_rounds():
    m = efficiency.medians(table())
    assert m[(50_000, 1, 2)]["seconds"] == pytest.approx(1e-7 * 50_000 * 1.5 / 2)
    assert len(m) == 16


def test_painting_at_the_reference_spacing_gives_the_reference_damage():
    scene = Scene.from_toml(DISK)
    reference = efficiency.reference_damage(scene, 0.375, 4.0)
    assert np.count_nonzero(failed(reference["damage"])) > 0  # fully damaged particles
    sim = Simulation(efficiency.scene_at(scene, 0.375, "sf"))
    efficiency.paint(sim, reference)
    assert np.array_equal(sim.particles.damage, reference["damage"])


def test_smoke_study(tmp_path):
    """benchmarks/efficiency/study.py --smoke: two sizes x two partitions x 1 and 2 threads."""
    from pfmpm import _core

    threads = _core.num_threads()
    driver = runpy.run_path(str(ROOT / "benchmarks" / "efficiency" / "study.py"))
    result = driver["main"]([str(DISK), "--smoke", "--out", str(tmp_path)])
    assert _core.num_threads() == threads  # set back after the 2-thread runs
    rows = read_csv(tmp_path / "efficiency.csv")
    assert list(rows) == list(efficiency.COLUMNS) and len(rows["seconds"]) == 8
    n = rows["particles"]
    assert len(set(n)) == 2 and np.all(n > 0)
    for key in efficiency.COLUMNS:
        assert np.all(np.isfinite(rows[key])) and np.all(rows[key] >= 0), key
    stages = sum(rows[s] for s in efficiency.STAGES)
    assert np.all(stages <= rows["seconds"] * (1 + 1e-9))  # parts of the timed steps
    dfg = rows["dfg"] == 1
    blocks = sum(rows[b] for b in efficiency.DFG_BLOCKS)
    assert np.all(blocks[~dfg] == 0.0) and np.all(rows["gradient"][dfg] > 0.0)
    assert np.all(rows["evaluated"][~dfg] == 0.0) and np.all(rows["evaluated"][dfg] > 0.0)
    assert np.all(blocks[dfg] <= rows["fields"][dfg] * (1 + 1e-9))
    # E5: each size and partition ends with the same state on 1 and 2 threads.
    assert result["E5"] == {"value": 0, "limit": 0, "passed": True, "compared": 4}
    assert json.loads((tmp_path / "checks.json").read_text())["wall"]["E5"]["passed"] is True
    assert (tmp_path / "fig19.png").stat().st_size > 0


def test_interleaved_runs_end_as_whole_runs():
    """time_runs with chunk: the two partitions' runs advanced a few steps at a
    time in turn end in the states of runs timed whole, one after the other;
    a chunk of no step is refused (it would never end)."""
    scene = Scene.from_toml(DISK)
    reference = efficiency.reference_damage(scene, 0.375, 4.0)
    whole = efficiency.time_runs(scene, 0.375, efficiency.METHODS, 1, 7, 2, reference)
    turns = efficiency.time_runs(scene, 0.375, efficiency.METHODS, 1, 7, 2, reference, chunk=3)
    assert [r["dfg"] for r in turns] == [0, 1]
    assert [r["steps"] for r in turns] == [7, 7]
    assert [r["digest"] for r in turns] == [r["digest"] for r in whole]
    assert turns[0]["digest"] != turns[1]["digest"]  # the partitions differ
    assert turns[1]["evaluated"] == whole[1]["evaluated"] > 0
    with pytest.raises(ValueError, match="chunk = 0: must be at least 1 step"):
        efficiency.time_runs(scene, 0.375, efficiency.METHODS, 1, 7, 2, reference, chunk=0)
