"""Damage-field-gradient partitioning (Homel & Herbold 2017, sections 2.1-2.5).

The ``[contact] partition = "damage_gradient"`` scene keys and their one-line
errors; a bar cut by a fully damaged band parts with no force across it while
the single field still carries tension (the velocity-field smearing of the
paper's section 1.1.2); a curved band's nodal gradient follows its normal
(U3); nothing fully damaged runs with the single field's bits (U5); the
phase field as damage (d = 1 - c) opens the Borden notch as two faces, on 1
or 2 threads and across a restart with the same bits; the particle output
and summary.json carry the partition.
"""

import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pfmpm import checkpoint
from pfmpm.cli import main
from pfmpm.output import read_csv
from pfmpm.scene import (Body, Contact, ContactPair, Grid, Material, Rectangle, Scene, SceneError,
                         Time)
from pfmpm.simulation import Simulation

ROOT = Path(__file__).resolve().parents[1]
BORDEN = ROOT / "demos" / "borden_plate.toml"
# The Borden plate at h = 1 mm, l0 = 2 mm, one particle per cell (4,000),
# its fields split by the phase field's damage d = 1 - c.
COARSE = ["grid.h=1.0", "materials.concrete.fracture.l0=2.0", "bodies.plate.particles_per_cell=1",
          "output.energies_every=5", "output.every=50", "contact.partition=damage_gradient"]


def bar(partition: str | None, band: bool = True, h: float = 0.25) -> Scene:
    """A 10 x 2 bar whose halves move apart at 0.05; with ``band``, a band one cell
    wide across its middle of a material 1e8 times softer (failed), flagged as fully
    damaged under the damage gradient."""
    E = 100.0
    materials = (Material("intact", E, 0.3, 1.0), Material("failed", 1e-8 * E, 0.3, 1.0))
    half = h / 2 if band else 0.0
    bodies = [Body("left", "intact", Rectangle((1.0, 1.0), (6.0 - half, 3.0)), velocity=(-0.05, 0.0)),
              Body("right", "intact", Rectangle((6.0 + half, 1.0), (11.0, 3.0)), velocity=(0.05, 0.0))]
    if band:
        bodies.append(Body("band", "failed", Rectangle((6.0 - half, 1.0), (6.0 + half, 3.0))))
    contact = None
    if partition == "damage_gradient":
        flags = (Rectangle((6.0 - half, 0.0), (6.0 + half, 4.0)),) if band else ()
        contact = Contact(partition="damage_gradient", groups=(tuple(b.name for b in bodies),),
                          surfaces=flags)
    return Scene(grid=Grid(size=(12.0, 4.0), h=h, degree=2), time=Time(end=4.0, cfl=0.5),
                 materials=materials, bodies=tuple(bodies), plane="strain", contact=contact)


def force_across(scene: Scene) -> tuple[float, Simulation]:
    """The impulse across the bar's middle over the run: the change of the x momentum
    of the particles right of it."""
    sim = Simulation(scene)
    p = sim.particles
    right = p.x[:, 0] > 6.0
    before = float(np.sum(p.mass[right] * p.v[right, 0]))
    sim.advance(scene.steps())
    return float(np.sum(p.mass[right] * p.v[right, 0])) - before, sim


def test_a_fully_damaged_band_carries_no_tension():
    intact, _ = force_across(bar(None, band=False))
    smeared, _ = force_across(bar(None))
    parted, sim = force_across(bar("damage_gradient"))
    # The intact bar's halves pull on each other; a single field carries the
    # tension across the failed band too (velocity-field smearing).
    assert intact < -0.1 and smeared < -0.1
    # Split by the damage gradient, the halves part with no force between
    # them: below 1e-6 of the intact bar's.
    assert abs(parted) < 1e-6 * abs(intact)
    stats = sim.solver.contact_stats()
    assert stats["separable_total"] > 0 and stats["active"] == 0
    # Momentum of the whole bar, to round-off.
    e = sim.energies()
    assert abs(e["momentum_x"]) < 1e-12 and abs(e["momentum_y"]) < 1e-12


def test_nothing_fully_damaged_runs_as_one_field():
    """U5 with the phase field as damage: d = 1 - c > 0 near the notch, but with
    a threshold below the smallest c no particle is fully damaged, and the run
    has the single field's bits."""
    runs = []
    for extra in ([], COARSE[-1:] + ["contact.phase_field_threshold=0.0"]):
        scene = Scene.from_toml(BORDEN, COARSE[:-1] + extra + ["time.end=12"])
        sim = Simulation(scene)
        assert sim.particles.c.min() > 0.0
        sim.advance(scene.steps())
        runs.append(sim.particles)
    one, split = runs
    for name in ("x", "v", "stress", "c", "history"):
        assert np.array_equal(getattr(one, name), getattr(split, name)), name


def test_a_curved_band_has_its_normal_at_the_nodes():
    """U3: a semicircular band of radius 10 h (3 particles per cell): the nodal
    gradient (Algorithm 1) within one cell of the arc and more than 2 cells from
    its tips is within 15 degrees of the arc's normal."""
    h, radius, centre = 0.25, 2.5, np.array([4.0, 2.0])
    scene = Scene(grid=Grid(size=(8.0, 6.0), h=h, degree=2), time=Time(end=1.0),
                  materials=(Material("m", 100.0, 0.3, 1.0),),
                  bodies=(Body("block", "m", Rectangle((0.5, 0.5), (7.5, 5.5)), particles_per_cell=3),),
                  contact=Contact(partition="damage_gradient"))
    sim = Simulation(scene)
    p = sim.particles
    r = np.hypot(*(p.x - centre).T)
    p.surface[(np.abs(r - radius) < 0.5 * h) & (p.x[:, 1] > centre[1])] = 1
    sim.solver.prepare()
    rows = sim.solver.damage_partition()["nodal_gradient"]
    ny = sim.grid.nodes[1]
    # Node (i, j) of the quadratic open knot vector sits at ((i, j) - 0.5) h.
    xy = np.column_stack([rows[:, 0] // ny, rows[:, 0] % ny]) * h - 0.5 * h
    d = xy - centre
    dist = np.hypot(*d.T)
    angle = np.arctan2(d[:, 1], d[:, 0])
    near = (np.abs(dist - radius) < h) & (angle > 2 * h / radius) & (angle < math.pi - 2 * h / radius)
    G = rows[near, 2:]
    assert near.sum() > 40 and np.all(np.hypot(*G.T) > 0)
    cosine = np.abs(np.sum(G * d[near], axis=1)) / (np.hypot(*G.T) * dist[near])
    assert np.degrees(np.arccos(np.clip(cosine, -1, 1))).max() < 15.0


@pytest.mark.parametrize("override, key, reason", [
    ("contact.partition=\"fields\"", "contact.partition", "must be one of"),
    ("contact.separability=1.5", "contact.separability", "must be > 0 and < 1"),
    ("contact.kernel_radius=0.5", "contact.kernel_radius", "must exceed the particle spacing"),
    ("contact.skin=0", "contact.skin", "must be > 0"),
    ("contact.surface_detection=\"sph\"", "contact.surface_detection", "must be one of"),
    ("contact.surface_threshold=1.0", "contact.surface_threshold", "must be > 0 and < 1"),
    ("contact.phase_field_threshold=1.0", "contact.phase_field_threshold", "must be >= 0 and < 1"),
    ("contact.groups=[[\"plate\", \"pin\"]]", "contact.groups[0][1]", "no body with that name"),
    ("contact.surfaces=[{type=\"square\"}]", "contact.surfaces[0].type", "must be one of"),
])
def test_bad_damage_gradient_keys_are_one_line_errors(override, key, reason):
    with pytest.raises(SceneError) as err:
        Scene.from_toml(BORDEN, COARSE + [override])
    message = str(err.value)
    assert "\n" not in message and message.startswith(key) and reason in message, message


def test_damage_gradient_keys_need_the_partition():
    with pytest.raises(SceneError, match=r"^contact.separability = 0.5: needs partition"):
        Scene.from_toml(BORDEN, COARSE[:-1] + ["contact.separability=0.5"])


def test_groups_are_checked_across_bodies():
    m = Material("m", 100.0, 0.3, 1.0)
    bodies = (Body("a", "m", Rectangle((1.0, 1.0), (2.0, 2.0))),
              Body("b", "m", Rectangle((3.0, 1.0), (4.0, 2.0))))
    grid, time = Grid(size=(5.0, 3.0), h=0.25, degree=2), Time(end=1.0)
    with pytest.raises(SceneError, match=r"^contact.groups\[1\]\[0\] = 'a': body already in contact.groups\[0\]"):
        Scene(grid=grid, time=time, materials=(m,), bodies=bodies,
              contact=Contact(partition="damage_gradient", groups=(("a",), ("a", "b"))))
    with pytest.raises(SceneError, match=r"^contact.pairs\[0\].bodies = .*both bodies are in one"):
        Scene(grid=grid, time=time, materials=(m,), bodies=bodies,
              contact=Contact(partition="damage_gradient", groups=(("a", "b"),),
                              pairs=(ContactPair(("a", "b"), 0.2),)))
    scene = Scene(grid=grid, time=time, materials=(m,), bodies=bodies,
                  contact=Contact(partition="damage_gradient", friction=0.1,
                                  pairs=(ContactPair(("a", "b"), 0.2),)))
    assert scene.contact.friction_matrix(("a", "b")).tolist() == [[0.1, 0.2], [0.2, 0.1]]
    assert Scene.from_dict(scene.to_dict()) == scene


def run_borden(out: Path, end: float, env=None, extra=()) -> subprocess.CompletedProcess:
    args = [sys.executable, "-m", "pfmpm.cli", "run", str(BORDEN), "--quiet", "--out", str(out)]
    for s in COARSE + [f"time.end={end}", *extra]:
        args += ["--set", s]
    return subprocess.run(args, capture_output=True, text=True, env=env, timeout=600)


def output_files(out: Path) -> dict[str, bytes]:
    """Every output file of a run but the plots, checkpoints and summary (which has wall times)."""
    return {p.name: p.read_bytes() for p in sorted(out.iterdir()) if p.suffix in (".csv", ".vtu", ".pvd")}


def notch_opening(sim: Simulation) -> float:
    """Mean y of the particles just above the Borden notch minus that of those just below."""
    x = sim.particles.x
    along = x[:, 0] < 40.0
    above, below = along & (x[:, 1] > 20.0) & (x[:, 1] < 22.0), along & (x[:, 1] < 20.0) & (x[:, 1] > 18.0)
    return float(x[above, 1].mean() - x[below, 1].mean())


def test_phase_field_damage_opens_the_notch_as_two_faces(tmp_path):
    """The Borden notch (c near 0 on it) is fully damaged: its faces are two
    separable fields from the first step and open more than in one field,
    where the nodes the faces share still tie them. The output carries the
    particle damage gradient and the surface flag, summary.json the partition."""
    out = tmp_path / "dfg"
    assert main(["run", str(BORDEN), "--quiet", "--out", str(out),
                 *[a for s in COARSE + ["time.end=20"] for a in ("--set", s)]]) == 0
    summary = json.loads((out / "summary.json").read_text())
    contact = summary["contact"]
    assert "damage_gradient" in summary["modules"]
    assert contact["separable_nodes_last_step"] > 20
    assert contact["split_nodes_last_step"] >= contact["separable_nodes_last_step"]
    assert contact["violations"] == {"C1": 0, "C2": 0, "C3": 0, "C4": 0}
    assert contact["neighbour_builds"] >= 1 and contact["surface_particles"] == 0
    vtu = sorted(out.glob("particles_*.vtu"))[-1].read_text()
    assert 'Name="damage_gradient"' in vtu and 'Name="surface"' in vtu
    opening = []
    for extra in ([], COARSE[-1:]):
        scene = Scene.from_toml(BORDEN, COARSE[:-1] + extra + ["time.end=20"])
        sim = Simulation(scene)
        start = notch_opening(sim)
        sim.advance(scene.steps())
        opening.append(notch_opening(sim) - start)
    single, split = opening  # measured: 0.00651 and 0.00755 mm
    assert split > 1.1 * single > 0.0


def test_damage_gradient_runs_repeat_bitwise_on_one_or_two_threads_and_resumed(tmp_path):
    env = {**os.environ, "OMP_WAIT_POLICY": "passive"}
    runs = {}
    for name, threads in (("one", 1), ("two", 2)):
        r = run_borden(tmp_path / name, 30, env={**env, "OMP_NUM_THREADS": str(threads)})
        assert r.returncode == 0, r.stderr
        runs[name] = output_files(tmp_path / name)
    assert runs["one"] == runs["two"]
    # Stopped after step 50 and resumed: the same files.
    full = tmp_path / "full"
    assert main(["run", str(BORDEN), "--quiet", "--out", str(full), "--checkpoint-every", "50",
                 *[a for s in COARSE + ["time.end=30"] for a in ("--set", s)]]) == 0
    names = [p.name for p in checkpoint.list_checkpoints(full / "checkpoints")]
    assert len(names) >= 2
    part = tmp_path / "part"
    shutil.copytree(full, part)
    for name in names[1:]:
        (part / "checkpoints" / name).unlink()
    assert main(["run", "--resume", str(part), "--quiet"]) == 0
    assert output_files(full) == output_files(part) == runs["two"]
    s, t = (json.loads((d / "summary.json").read_text())["contact"] for d in (full, part))
    assert {k: v for k, v in s.items() if k != "seconds"} == {k: v for k, v in t.items() if k != "seconds"}
