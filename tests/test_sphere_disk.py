"""The sphere-on-disk benchmark (H&H Fig. 20, benchmarks/sphere_disk): its
measures on manufactured particle sets with known answers, its energy and
momentum bookkeeping on manufactured rows, and the coarse run's bits on 1
and 2 threads and after a resume. The smoke run's physics is checked in
tests/test_scenes.py (check_sphere_disk); the two resolutions' numbers are on
docs/verification/sphere-disk.md."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.sphere_disk.measure import (SMALLEST, disk_fragments, energy_balance, impact_momentum,
                                            inside_other, material_fragments, momentum_error, render)
from pfmpm import scenes
from pfmpm.scene import Scene

H = 1.0
SPACING = 0.5


@pytest.fixture(scope="module")
def scene():
    return Scene.from_toml(scenes.path("sphere_disk"))


def cube_lattice(n: int, origin=(0.0, 0.0, 0.0)) -> np.ndarray:
    """n^3 particle centres of spacing 0.5 (2 x 2 x 2 per cell of h = 1)."""
    k = (np.arange(n) + 0.5) * SPACING
    return np.stack(np.meshgrid(k, k, k, indexing="ij"), axis=-1).reshape(-1, 3) + origin


def test_impact_momentum_is_the_spheres(scene):
    p = scene.particles()
    sphere = p["body"] == 1
    assert len(p["x"]) == 22_560 and np.count_nonzero(sphere) == 912
    # 912 particles of (h/2)^3 = 0.125 mm^3 of steel at 0.2 mm/us
    assert impact_momentum(scene) == pytest.approx(912 * 0.125 * 7850.0 * 0.2, rel=1e-14)


def test_momentum_error_and_energy_balance_from_rows():
    e = {"t": np.array([0.0, 1.0, 2.0]), "kinetic": np.array([100.0, 60.0, 50.0]),
         "elastic": np.array([0.0, 30.0, 10.0]), "damage_dissipation": np.array([0.0, 2.0, 20.0]),
         "friction_dissipation": np.array([0.0, 1.0, 5.0]),
         "momentum_x": np.array([0.0, 1e-9, -3e-9]), "momentum_y": np.zeros(3),
         "momentum_z": np.array([-50.0, -50.0 + 2e-9, -50.0])}
    assert momentum_error(e, 50.0) == pytest.approx(3e-9 / 50.0, rel=1e-12)
    r = energy_balance(e)
    assert r["KE0"] == 100.0
    assert (r["kinetic"], r["elastic"], r["damage"], r["friction"]) == pytest.approx((0.5, 0.1, 0.2, 0.05))
    assert r["balance"] == pytest.approx(0.15) and r["largest"] == pytest.approx(0.15)


def test_eight_octants_are_eight_fragments_of_their_volume(scene):
    """A 16^3 lattice (8 mm cube) failed on the two layers at each mid-plane:
    its intact particles (7^3 per octant) form eight fragments of the ball
    diameter of 7^3 particle volumes, d50 that size; a lone intact particle
    is debris below SMALLEST and a sphere particle is no part of the disk."""
    x = cube_lattice(16)
    damage = np.zeros(len(x))
    mid = np.any(np.abs(x - 4.0) < 0.3, axis=1)  # the layers at 3.75 and 4.25
    damage[mid] = 1.0
    x = np.vstack([x, [[20.0, 20.0, 20.0]], [[30.0, 0.0, 0.0]]])
    damage = np.append(damage, [0.0, 0.0])
    body = np.append(np.zeros(16**3, dtype=int), [0, 1])
    volume = np.full(len(x), SPACING**3)
    mass = 3890.0 * volume
    f = disk_fragments(scene, x, volume, mass, damage, body)
    size = (6.0 * 7**3 * SPACING**3 / math.pi) ** (1 / 3)
    assert f["fragments"] == 8 and f["largest"] == pytest.approx(size, rel=1e-14)
    assert f["d50"] == pytest.approx(size, rel=1e-14) and (6.0 * SPACING**3 / math.pi) ** (1 / 3) < SMALLEST
    assert f["sizes"] == pytest.approx(np.full(8, size)) and f["fractions"][-1] == 1.0
    assert f["intact"] == pytest.approx(8 * 7**3 / (16**3 + 1), rel=1e-14)
    assert f["failed"] == pytest.approx((16**3 - 14**3) / (16**3 + 1), rel=1e-14)
    # A failed layer in the lattice links nothing: D < 1 counts as intact for "unfailed".
    damage[np.append(mid, [False, False])] = 0.5
    assert disk_fragments(scene, x, volume, mass, damage, body, "unfailed")["fragments"] == 1
    assert disk_fragments(scene, x, volume, mass, damage, body, "undamaged")["fragments"] == 8


def two_halves(scene, shift: float):
    """A 16 x 8 x 8 block (spacing 0.5) cut at x = 4 by two failed layers, its
    right half moved by ``shift`` (mm) along -x, into the left, after
    labelling; the sphere's 2 x 2 x 2 particles 2 mm above the block's top
    layer. Returns the positions and the labels."""
    k = (np.arange(8) + 0.5) * SPACING
    X = np.stack(np.meshgrid((np.arange(16) + 0.5) * SPACING, k, k, indexing="ij"), axis=-1).reshape(-1, 3)
    damage = np.where(np.abs(X[:, 0] - 4.0) < 0.3, 1.0, 0.0)
    ball = cube_lattice(2, origin=(1.0, 1.0, 4.0 + 1.5))
    X = np.vstack([X, ball])
    damage = np.append(damage, np.zeros(len(ball)))
    body = np.append(np.zeros(16 * 64, dtype=int), np.ones(len(ball), dtype=int))
    labels = material_fragments(scene, X, damage, body)
    x = X.copy()
    x[(X[:, 0] > 4.0) & (body == 0), 0] -= shift
    return x, labels


def test_pieces_from_the_reference_configuration_and_who_is_inside(scene):
    """Two halves of a block, labelled in the reference configuration (the
    failed layers at x = 3.75 and 4.25 are -1), and the sphere's 8 particles
    4 spacings above the block's top. At rest no two pieces come within 2
    spacings (the halves 3 apart across the failed layers). The right half
    pushed 0.6 mm to the left: its first layer at 4.15, 1.8 spacings from the
    left's last at 3.25, nothing inside. Pushed 1.4 mm: that layer at 3.35,
    0.2 spacings from 3.25, so the 64 particles of each of the two layers lie
    inside the other piece (the diagonal neighbours are 1.02 spacings apart)."""
    x, labels = two_halves(scene, 0.0)
    assert len(np.unique(labels[labels >= 0])) == 3 and np.count_nonzero(labels < 0) == 2 * 64
    assert inside_other(x, labels, SPACING) == {"inside": 0, "closest": math.inf}
    x, labels = two_halves(scene, 0.6)
    r = inside_other(x, labels, SPACING)
    assert r["inside"] == 0 and r["closest"] == pytest.approx(1.8, rel=1e-12)
    x, labels = two_halves(scene, 1.4)
    r = inside_other(x, labels, SPACING)
    assert r["closest"] == pytest.approx(0.2, rel=1e-12) and r["inside"] == 2 * 64


def test_render_draws_the_pieces(tmp_path):
    import matplotlib.image

    x = cube_lattice(8)
    labels = np.where(x[:, 0] < 2.0, 0, 1)
    labels[np.abs(x[:, 0] - 2.0) < 0.3] = -1
    path = render(tmp_path / "pieces.png", x, labels, np.zeros(len(x), dtype=bool), "two pieces")
    pixels = matplotlib.image.imread(path)
    assert pixels.shape[0] > 500 and pixels[..., :3].std() > 0.02


def test_coarse_run_is_bitwise_on_one_and_two_threads_and_resumed(tmp_path):
    """The coarse scene to 5 us (141 steps: the sphere has struck and the disk
    has started to fail under it) on 1 and 2 threads, and resumed from its
    checkpoint at step 70 against the run that went on: the same bits."""
    import runpy
    from pathlib import Path

    study = runpy.run_path(str(Path(__file__).resolve().parents[1] / "benchmarks" / "sphere_disk" / "study.py"))
    r = study["bitwise"](tmp_path, 5.0)
    assert r["steps"] == 141 and r["resumed_at"] == 70
    assert r["damaged"] > 100, "the disk should have started to fail"
    assert r["threads_identical"] and r["resumed_identical"] and len(r["files"]) >= 4, r["files"]
