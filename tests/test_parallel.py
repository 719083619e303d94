"""The MPM on many MPI ranks (pfmpm.parallel): the bits of one process on
1, 2 and 3 ranks, no particle lost, and the refusals."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pfmpm import Scene
from pfmpm.output import read_csv
from pfmpm.parallel import RankError, Slabs, check_distributable
from test_fem import _mpirun

DEMOS = Path(__file__).resolve().parent.parent / "demos"

#: A block of the vibrating bar's soft material flying along x at 30 (three
#: times its wave speed) through 80 cells: about 0.6 cells a step, so in
#: 100 steps it crosses from rank 0's cells into rank 2's on 3 ranks.
PROJECTILE = """
name = "projectile"
plane = "strain"
[grid]
size = [80.0, 8.0]
h = 1.0
degree = 2
[time]
end = 1.0
cfl = 0.8
[output]
every = 100
energies_every = 5
particles = false
[[materials]]
name = "soft"
E = 100.0
nu = 0.3
density = 1.0
[[bodies]]
name = "block"
material = "soft"
particles_per_cell = 2
shape = { type = "rectangle", min = [3.0, 2.0], max = [9.0, 6.0] }
velocity = [30.0, 0.0]
"""


def _target(x: float, y: float) -> str:
    """A body "target" of the projectile's size and material, at rest, its
    lower left corner at (x, y)."""
    return f"""
[[bodies]]
name = "target"
material = "soft"
particles_per_cell = 2
shape = {{ type = "rectangle", min = [{x}, {y}], max = [{x + 6.0}, {y + 4.0}] }}
"""


#: The projectile and a block at rest far ahead of it, with no contact
#: between them (one velocity field): the momentum columns per body.
TWO_BLOCKS = PROJECTILE.replace('name = "projectile"', 'name = "two-blocks"') + _target(70.0, 2.0)

#: The projectile strikes a block at rest, with Coulomb friction between
#: them (a field per body, K&T eqs. 63-77), on a taller grid.
CONTACT = (PROJECTILE.replace('name = "projectile"', 'name = "strike"').replace("[80.0, 8.0]", "[80.0, 16.0]")
           + "\n[contact]\nfriction = 0.3\n" + _target(20.0, 3.0))


def _python(ranks: int | None) -> tuple[list[str], dict]:
    """The command that starts Python on ``ranks`` ranks under mpirun, or
    (None) in one process without MPI, and its environment: one thread."""
    env = dict(os.environ, OMP_NUM_THREADS="1")
    if os.geteuid() == 0:
        env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    if ranks is None:
        return [sys.executable], env
    mpirun = _mpirun()  # mpirun -n 2 [--oversubscribe]
    mpirun[2] = str(ranks)
    return mpirun + [sys.executable], env


def _run(tmp_path: Path, scene: Path, sets: list[str], ranks: int | None, steps: int,
         extra: tuple[str, ...] = ()) -> tuple[bytes, dict]:
    """``pfmpm run`` of ``scene`` for ``steps`` steps, on ``ranks`` ranks under
    mpirun or (None) in one process without MPI: its energies.csv and summary."""
    launcher, env = _python(ranks)
    out = tmp_path / f"ranks{ranks}"
    args = ["-m", "pfmpm.cli", "run", str(scene), "--quiet", "--out", str(out), *extra]
    args += [item for s in sets + [f"time.end={steps * Scene.from_toml(scene, sets).dt()!r}"] for item in ("--set", s)]
    proc = subprocess.run(launcher + args, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed"
    return (out / "energies.csv").read_bytes(), summary


def test_slabs_split_whole_tiles_by_particle_count():
    # 10 tiles along x (80 cells); the particles crowd into the first 16 cells.
    counts = np.zeros(80, dtype=np.int64)
    counts[:16] = 100
    counts[16:] = 1
    slabs = Slabs(80, counts, 3)
    assert slabs.tiles.tolist() == [0, 1, 2, 10]
    assert slabs.loads.tolist() == [800, 800, 64]
    assert slabs.cell_range(1) == (8, 16) and slabs.cell_range(2) == (16, 80)
    assert slabs.owner(np.array([0, 7, 8, 15, 16, 79])).tolist() == [0, 0, 1, 1, 2, 2]
    # Even counts split evenly; a grid's last tile may be cut short.
    slabs = Slabs(30, np.ones(30), 2)
    assert slabs.tiles.tolist() == [0, 2, 4] and slabs.cell_range(1) == (16, 30)


def test_more_ranks_than_tiles_are_refused():
    with pytest.raises(RankError, match=r"^mpirun -n 5: the grid has 30 cells along x, 4 tiles of 8; at most 4 ranks$"):
        Slabs(30, np.ones(30), 5)


def test_scenes_that_do_not_run_distributed_yet_are_refused():
    with pytest.raises(RankError, match=r"^scene 'borden-plate' has a phase field .* run it without mpirun$"):
        check_distributable(Scene.from_toml(DEMOS / "borden_plate.toml"))
    with pytest.raises(RankError, match=r"^scene 'brazilian' has the damage-gradient partition, which does not"):
        check_distributable(Scene.from_toml(DEMOS / "brazilian.toml"))
    check_distributable(Scene.from_toml(DEMOS / "vibrating_bar.toml"))


@pytest.mark.parametrize("scene", ["vibrating_bar", "pulse", "bar_cpdi", "bar3d", "projectile", "two_blocks",
                                   "contact"])
def test_ranks_give_the_bits_of_one_process(tmp_path, scene):
    """``mpirun -n 2, 3 pfmpm run`` (and for the bar ``-n 1``) writes the energies.csv of one process
    without MPI byte for byte, and the same SHA-256 of the id-sorted particle
    state: 200 steps of the vibrating bar (a wall, a traction, 4 tiles along
    x) and of its 3D twin (8 tiles), with their particle series (every 50
    steps), and the projectile's 100
    (every particle changes rank), alone, with a second body, and striking
    it with friction."""
    if scene in ("vibrating_bar", "bar3d"):
        path = DEMOS / f"{scene}.toml"
        sets, steps = [], 200
    elif scene == "bar_cpdi":  # CPDI's stencils reach 5 cells apart: a wider ghost layer
        path = DEMOS / "vibrating_bar.toml"
        sets, steps = ["grid.degree=1", "grid.shape=cpdi"], 200
    elif scene == "pulse":  # the bar's traction as a triangle pulse, over by t = 4 (step 87)
        path = tmp_path / "pulse.toml"
        path.write_text((DEMOS / "vibrating_bar.toml").read_text().replace(
            "traction = [0.1, 0.0]",
            "traction = [0.1, 0.0]\namplitude = { type = \"table\", times = [0.0, 2.0, 4.0], values = [0.0, 1.0, 0.0] }"))
        sets, steps = ["output.particles=false"], 200
    else:
        path = tmp_path / f"{scene}.toml"
        path.write_text({"projectile": PROJECTILE, "two_blocks": TWO_BLOCKS, "contact": CONTACT}[scene])
        sets, steps = [], 100
    serial, summary = _run(tmp_path, path, sets, None, steps)
    rows = read_csv(tmp_path / "ranksNone" / "energies.csv")
    assert rows["step"][-1] == steps
    if scene == "two_blocks":
        assert rows["momentum_x_block"][-1] == pytest.approx(30.0 * 24.0) and rows["momentum_x_target"][-1] == 0.0
    if scene == "contact":  # the strike happened: momentum passed to the target, friction worked
        assert rows["momentum_x_target"][-1] > 0.1 * 30.0 * 24.0
        assert summary["contact"]["active_node_pairs"] > 0
    frames = sorted(p.name for p in (tmp_path / "ranksNone").glob("particles*"))
    assert len(frames) == (6 if "bar" in scene else 0)  # the index and steps 0, 50, .., 200
    if scene == "pulse":  # the pulse's work, then none
        work = rows["external_work"]
        assert work[-1] > 0.0 and work[-1] == work[rows["t"] > 4.1][0]
    # Under mpirun -n 1 a run is the process without MPI: checked once, on the bar.
    for ranks in (1, 2, 3) if scene == "vibrating_bar" else (2, 3):
        csv, other = _run(tmp_path, path, sets, ranks, steps)
        assert other["ranks"] == ranks
        assert csv == serial, f"{ranks} ranks"
        assert other["particles_sha256"] == summary["particles_sha256"], f"{ranks} ranks"
        assert other["particles"] == summary["particles"]
        assert other.get("contact") == summary.get("contact"), f"{ranks} ranks"
        for name in frames:
            assert (tmp_path / f"ranks{ranks}" / name).read_bytes() == (tmp_path / "ranksNone" / name).read_bytes(), \
                f"{name} on {ranks} ranks"


def test_a_projectile_crossing_three_ranks_loses_nothing(tmp_path):
    """The block flies from rank 0's cells through rank 1's into rank 2's:
    its mass and momentum stay those of t = 0 to round-off, and its
    particles are all there."""
    path = tmp_path / "projectile.toml"
    path.write_text(PROJECTILE)
    _, summary = _run(tmp_path, path, [], 3, 100)
    e = read_csv(tmp_path / "ranks3" / "energies.csv")
    assert summary["particles"] == 6 * 4 * 4  # every particle at the end
    assert summary["tiles_per_rank"] == [1, 1, 8]  # the split by particle count at t = 0
    assert e["step"][-1] == 100
    # The block's back, x = 3 at t = 0, ends in rank 2's cells [16, 80).
    assert 3.0 + 30.0 * e["t"][-1] > 16.0
    p0 = e["momentum_x"][0]
    assert p0 == pytest.approx(30.0 * 24.0)  # 24 of mass at 30
    np.testing.assert_allclose(e["momentum_x"], p0, rtol=1e-13)
    np.testing.assert_allclose(e["momentum_y"], 0.0, atol=1e-13 * p0)
    np.testing.assert_allclose(e["kinetic"], e["kinetic"][0], rtol=1e-12)


def test_a_checkpoint_of_two_ranks_resumes_on_three_bitwise(tmp_path):
    """The vibrating bar on 2 ranks, checkpointed at steps 100 and 200; the
    step-200 file removed, it resumes from step 100 on 3 ranks. Its
    energies.csv is byte for byte that of one process run straight through,
    and its particle state has the same SHA-256. The checkpoint holds what
    one process's holds."""
    from pfmpm import checkpoint

    path = DEMOS / "vibrating_bar.toml"
    sets = ["output.particles=false"]
    straight, summary = _run(tmp_path, path, sets, None, 200, ("--checkpoint-every", "100"))
    _run(tmp_path, path, sets, 2, 200, ("--checkpoint-every", "100"))
    one = checkpoint.read(tmp_path / "ranksNone" / "checkpoints" / "step_000000100.h5")
    two = checkpoint.read(tmp_path / "ranks2" / "checkpoints" / "step_000000100.h5")
    assert one.particles.keys() == two.particles.keys()
    for name in one.particles:
        assert np.array_equal(one.particles[name], two.particles[name]), name
    assert one.solver["scalars"] == two.solver["scalars"]
    for name in one.solver["arrays"]:
        assert np.array_equal(one.solver["arrays"][name], two.solver["arrays"][name]), name
    (tmp_path / "ranks2" / "checkpoints" / "step_000000200.h5").unlink()
    launcher, env = _python(3)
    proc = subprocess.run(launcher + ["-m", "pfmpm.cli", "run", "--resume", str(tmp_path / "ranks2"),
                                    "--quiet"], env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    resumed = json.loads((tmp_path / "ranks2" / "summary.json").read_text())
    assert resumed["ranks"] == 3 and resumed["resumed_from"].endswith("step_000000100.h5")
    assert (tmp_path / "ranks2" / "energies.csv").read_bytes() == straight
    assert resumed["particles_sha256"] == summary["particles_sha256"]


def test_a_particle_passing_a_neighbour_stops_the_run_on_every_rank(tmp_path):
    """A particle of rank 0 put into rank 2's cells before a step: after it,
    every rank stops with one error naming the particle's id, never a silent
    loss."""
    scene = tmp_path / "projectile.toml"
    scene.write_text(PROJECTILE)
    script = tmp_path / "jump.py"
    # Each rank writes its own file: the ranks' stdout would interleave.
    script.write_text(f"""
from pathlib import Path
from mpi4py import MPI
from pfmpm import Scene, SimulationError
from pfmpm.parallel import DistributedSimulation
sim = DistributedSimulation(Scene.from_toml({str(scene)!r}), MPI.COMM_WORLD)
rank = MPI.COMM_WORLD.rank
if rank == 0:
    sim.particles.x[0, 0] = 75.0
    Path({str(tmp_path)!r}, "moved").write_text(str(sim.particles.id[0]))
try:
    sim.advance(1)
except SimulationError as err:
    Path({str(tmp_path)!r}, f"error{{rank}}").write_text(str(err))
""")
    launcher, env = _python(3)
    proc = subprocess.run(launcher + [str(script)], env=env, capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    moved = (tmp_path / "moved").read_text()
    for rank in range(3):
        line = (tmp_path / f"error{rank}").read_text()
        assert re.fullmatch(rf"particle id {moved} at x = 75\.\d+ moved from rank 0's cells past"
                            rf" a neighbour's, into rank 2's, at step 1 \(t = 0\.0\d+\); a particle may only cross"
                            rf" into a neighbouring rank's cells: run on fewer ranks", line), line
