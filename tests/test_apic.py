"""The APIC transfer (``[transfer] scheme = "apic"``, Jiang et al. 2015): a rigidly
spinning disk keeps its angular momentum and linear momentum to round-off on every
stencil, an affine velocity field goes to the grid and back unchanged on every
partition (each body's field its own where bodies share nodes), runs repeat bitwise
on one or two threads and after a restart, and the scene key is checked."""

import dataclasses
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pfmpm import checkpoint
from pfmpm.cli import main
from pfmpm.scene import (Body, Contact, Disk, Grid, Material, Rectangle, Scene, SceneError, Time,
                         TransferSpec)
from pfmpm.simulation import Simulation

ROOT = Path(__file__).resolve().parents[1]
BORDEN = ROOT / "demos" / "borden_plate.toml"
DISK_BEAM = ROOT / "demos" / "disk_beam.toml"

STENCILS = {"linear": (1, "bspline"), "quadratic": (2, "bspline"), "cubic": (3, "bspline"),
            "cpdi": (1, "cpdi")}


def with_stencil(scene: Scene, stencil: str) -> Scene:
    degree, shape = STENCILS[stencil]
    return dataclasses.replace(scene, grid=dataclasses.replace(scene.grid, degree=degree, shape=shape))


def spinning_disk(scheme: str, stencil: str, omega: float = 1.0) -> Scene:
    """A disk of radius R = 10 h (R = 1) about c = (2, 2), spinning rigidly,
    v = omega e_z x (x - c), for half a turn (rim speed 1, P-wave speed 11.6)."""
    c = 2.0
    body = Body("disk", "m", Disk((c, c), 1.0), particles_per_cell=2, velocity=(omega * c, -omega * c),
                velocity_gradient=((0.0, -omega), (omega, 0.0)))
    scene = Scene(grid=Grid(size=(4.0, 4.0), h=0.1), time=Time(end=np.pi / omega),
                  materials=(Material("m", 100.0, 0.3, 1.0),), bodies=(body,),
                  transfer=TransferSpec(scheme))
    return with_stencil(scene, stencil)


# Not on linear B-splines at single points: the disk's particles crossing cells
# make that step unstable within 60 steps with either transfer (docs/contact.md,
# "Linear grids: CPDI only").
@pytest.mark.parametrize("stencil", ["quadratic", "cubic", "cpdi"])
def test_a_rigid_spin_keeps_its_angular_momentum_with_apic(stencil):
    """Half a turn: the angular momentum, the particles' affine part included,
    changes by less than 1e-12 of itself (with the default FLIP transfer the
    disk loses 5e-3 of it, docs/method.md "APIC"), and the linear momentum
    stays zero to round-off."""
    scene = spinning_disk("apic", stencil)
    sim = Simulation(scene)
    p = sim.particles
    scale = float(np.sum(p.mass * np.hypot(p.v[:, 0], p.v[:, 1])))
    start = sim.energies()
    assert start["angular_momentum"] > 0.0
    chunks = 4
    for k in range(chunks):
        sim.advance((k + 1) * scene.steps() // chunks - k * scene.steps() // chunks)
        e = sim.energies()
        assert abs(e["angular_momentum"] / start["angular_momentum"] - 1.0) < 1e-12
        assert abs(e["momentum_x"] - start["momentum_x"]) < 1e-14 * scale
        assert abs(e["momentum_y"] - start["momentum_y"]) < 1e-14 * scale
    assert np.pi <= sim.time < np.pi + scene.dt()  # half a turn


def test_the_disk_starts_with_the_affine_matrix_of_its_spin():
    """B_p = G D_p (Solver.set_velocity_gradients): with quadratic B-splines
    D_p = h^2 / 4 I away from the grid's ends, so B_p = omega h^2 / 4 [[0, -1], [1, 0]];
    the affine part adds sum_p m_p h^2 / 2 omega to the particles' angular momentum."""
    sim = Simulation(spinning_disk("apic", "quadratic"))
    h2 = 0.1**2
    np.testing.assert_allclose(sim.particles.affine, np.tile([0.0, -h2 / 4, h2 / 4, 0.0], (len(sim.particles), 1)),
                               rtol=0, atol=1e-15)
    p = sim.particles
    orbital = float(np.sum(p.mass * (p.x[:, 0] * p.v[:, 1] - p.x[:, 1] * p.v[:, 0])))
    assert sim.energies()["angular_momentum"] == pytest.approx(orbital + p.mass.sum() * h2 / 2, rel=1e-14)
    assert "apic" in sim.modules()


def two_blocks(scheme: str, partition: str | None) -> Scene:
    """Two blocks side by side on the grid line x = 2 (sharing grid nodes), each
    with its own affine velocity field, moving apart; without a partition one field."""
    a = Body("a", "m", Rectangle((1.0, 1.0), (2.0, 3.0)), particles_per_cell=2, velocity=(-1.0, 0.2),
             velocity_gradient=((0.05, 0.1), (-0.2, 0.03)))
    b = Body("b", "m", Rectangle((2.0, 1.0), (3.0, 3.0)), particles_per_cell=2, velocity=(1.0, -0.3),
             velocity_gradient=((-0.04, -0.1), (0.15, 0.02)))
    contact = Contact(partition=partition) if partition else None
    return Scene(grid=Grid(size=(4.0, 4.0), h=0.1), time=Time(end=1.0),
                 materials=(Material("m", 100.0, 0.3, 1.0),), bodies=(a, b), contact=contact,
                 transfer=TransferSpec(scheme))


@pytest.mark.parametrize("stencil", ["quadratic", "cubic", "cpdi"])  # contact refuses linear B-splines
@pytest.mark.parametrize("partition", ["bodies", "damage_gradient"])
def test_apic_moves_affine_fields_through_the_grid_unchanged(partition, stencil):
    """One step from zero stress (no grid force): each body's affine field
    v = v0 + G x is reproduced at the nodes of its own field, so every particle
    keeps its velocity and affine matrix to round-off, also where the two
    bodies share nodes. FLIP keeps the velocity too (no acceleration), and one
    field would mix the bodies' fields at the shared nodes (checked)."""
    scene = with_stencil(two_blocks("apic", partition), stencil)
    sim = Simulation(scene)
    p = sim.particles
    v0, B0 = p.v.copy(), p.affine.copy()
    sim.advance(1)
    scale = np.abs(v0).max()
    np.testing.assert_allclose(p.v, v0, rtol=0, atol=1e-13 * scale)
    np.testing.assert_allclose(p.affine, B0, rtol=0, atol=1e-13 * scale * scene.grid.h)
    if partition == "bodies":
        one = Simulation(dataclasses.replace(scene, contact=None))
        one.advance(1)
        assert np.abs(one.particles.v - v0).max() > 1e-3 * scale


def test_linear_grid_apic_is_the_velocity_gradient_for_the_affine_weight():
    """On the degree-1 grid N_i D_p^-1 (x_i - x_p) = grad N_i: a particle's
    affine matrix over D_p is the velocity gradient of its nodes. A linear field
    shows it: B_p = G D_p with D_p = diag(xi (1 - xi)) h^2 per direction."""
    sim = Simulation(with_stencil(two_blocks("apic", None), "linear"))
    p, h = sim.particles, 0.1
    xi = (p.x / h) % 1.0
    D = xi * (1.0 - xi) * h * h
    (gxx, gxy), (gyx, gyy) = ((0.05, 0.1), (-0.2, 0.03))
    a = p.body == 0
    np.testing.assert_allclose(p.affine[a], np.stack([gxx * D[a, 0], gxy * D[a, 1], gyx * D[a, 0],
                                                      gyy * D[a, 1]], axis=1), rtol=1e-12, atol=0)


def test_the_transfer_key():
    assert TransferSpec().scheme == "flip"
    scene = spinning_disk("apic", "quadratic")
    assert Scene.from_dict(scene.to_dict()) == scene
    assert scene.to_dict()["transfer"] == {"scheme": "apic"}
    d = spinning_disk("flip", "quadratic").to_dict()
    del d["transfer"]
    assert Scene.from_dict(d).transfer.scheme == "flip"
    with pytest.raises(SceneError, match=r"^transfer\.scheme = 'pic': must be one of 'flip', 'apic'$"):
        Scene.from_dict({**d, "transfer": {"scheme": "pic"}})
    with pytest.raises(SceneError, match=r"^transfer\.alpha: unknown key \(allowed: scheme\)$"):
        Scene.from_dict({**d, "transfer": {"scheme": "apic", "alpha": 0.9}})
    flip = Simulation(Scene.from_dict(d))
    assert "affine" not in {c["name"] for c in flip.particles.columns()}
    with pytest.raises(Exception, match="APIC"):
        flip.solver.set_velocity_gradients(np.zeros((len(flip.particles), 2, 2)))


# The coarse Borden plate (4,000 particles; the crack starts at about 15 us) and
# the coarse disk-beam impact (tests/test_checkpoint.py), with APIC.
BORDEN_COARSE = ["grid.h=1.0", "materials.concrete.fracture.l0=2.0", "bodies.plate.particles_per_cell=1",
                 "output.energies_every=5", "output.every=40", "transfer.scheme=\"apic\"", "time.end=25"]
DISK_BEAM_COARSE = ["grid.h=1.0", "grid.origin=[-2.0, -1.0]", "grid.size=[52.0, 40.0]",
                    "materials.beam.fracture.l0=2.0", "materials.disk.fracture.l0=2.0",
                    "bodies.beam.particles_per_cell=1", "bodies.disk.particles_per_cell=1",
                    "output.energies_every=5", "output.every=40", "time.end=10",
                    "transfer.scheme=\"apic\""]
RUNS = {"borden": (BORDEN, BORDEN_COARSE),
        "borden-damage-gradient": (BORDEN, BORDEN_COARSE + ["contact.partition=\"damage_gradient\""]),
        "disk-beam": (DISK_BEAM, DISK_BEAM_COARSE)}


def output_files(out: Path) -> dict[str, bytes]:
    """Every output file of a run but the plots, checkpoints and summary (which has wall times)."""
    return {p.name: p.read_bytes() for p in sorted(out.iterdir()) if p.suffix in (".csv", ".vtu", ".pvd")}


def settings(overrides: list[str]) -> list[str]:
    return [a for s in overrides for a in ("--set", s)]


@pytest.mark.parametrize("run", RUNS)
def test_apic_runs_repeat_bitwise_on_one_or_two_threads_and_resumed(tmp_path, run):
    scene, overrides = RUNS[run]
    files = {}
    for threads in (1, 2):
        out = tmp_path / f"threads{threads}"
        env = {**os.environ, "OMP_NUM_THREADS": str(threads), "OMP_WAIT_POLICY": "passive",
               "PFMPM_ADAPTIVE_THREADS": "0"}
        r = subprocess.run([sys.executable, "-m", "pfmpm.cli", "run", str(scene), "--quiet", "--out", str(out),
                            "--checkpoint-every", "40", *settings(overrides)],
                           capture_output=True, text=True, env=env, timeout=600)
        assert r.returncode == 0, r.stderr
        assert "apic" in json.loads((out / "summary.json").read_text())["modules"]
        files[threads] = output_files(out)
    assert files[1] == files[2] and len(files[1]) >= 4
    # Stopped after the first checkpoint and resumed: the same files.
    full = tmp_path / "threads2"
    names = [p.name for p in checkpoint.list_checkpoints(full / "checkpoints")]
    assert len(names) >= 2
    ckpt = checkpoint.read(full / "checkpoints" / names[0])
    assert ckpt.particles["affine"].shape[1] == 4 and np.any(ckpt.particles["affine"])
    part = tmp_path / "part"
    shutil.copytree(full, part)
    for name in names[1:]:
        (part / "checkpoints" / name).unlink()
    assert main(["run", "--resume", str(part), "--quiet"]) == 0
    assert output_files(part) == files[2]
