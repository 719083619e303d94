"""Scenes in three dimensions: a slab between slip walls against the 2D
plane-strain run, the 3D shapes' seeding, the VTU output, a resumed run, the
bench's cube, and the one-line errors of a 2D feature in 3D and of a 3D key
in 2D."""

from __future__ import annotations

import copy
import math
import shutil
import subprocess
import sys
from pathlib import Path

import meshio
import numpy as np
import pytest

from pfmpm import Scene, Simulation, checkpoint
from pfmpm.animate import animate
from pfmpm.bench import bench
from pfmpm.cli import main
from pfmpm.output import read_csv
from pfmpm.scene import Body, Box, Cylinder, Disk, Extrusion, GridSpec, LinearElasticSpec, SceneError, Sphere, Time
from pfmpm.scene.toml import read_toml

ROOT = Path(__file__).resolve().parents[1]
BAR = ROOT / "demos" / "vibrating_bar.toml"
BAR3D = ROOT / "demos" / "bar3d.toml"
STEPS, DT = 200, 0.03
"""The slab runs 200 steps of a fixed dt below both dimensions' limits."""
RUN = [f"time.dt={DT}", f"time.end={STEPS * DT}", "output.energies_every=1", "output.particles=false",
       "bodies.bar.particles_per_cell=2"]


def slab(tables: dict) -> dict:
    """The 2D scene ``tables`` as a slab two cells thick (z in [-h, h], so its
    mid-plane is z = 0) between slip walls normal to z: every shape extruded,
    every vector given a zero z component."""
    d = copy.deepcopy(tables)
    h = d["grid"]["h"]
    d["grid"]["size"] = [*d["grid"]["size"], 2 * h]
    d["grid"]["origin"] = [*d["grid"].get("origin", [0.0, 0.0]), -h]
    for body in d["bodies"]:
        body["shape"] = {"type": "extrusion", "shape": body["shape"], "z0": -h, "z1": h}
    for load in d.get("loads", []):
        load["traction"] = [*load["traction"], 0.0]
    d["walls"] = d.get("walls", []) + [{"side": "back", "type": "slip"}, {"side": "front", "type": "slip"}]
    return d


def test_slab_between_slip_walls_is_the_plane_strain_run(tmp_path):
    """The vibrating bar (quadratic B-splines, 2 x 2 particles per cell at 1/4
    and 3/4 of a cell, fixed left wall, traction step) and its slab two cells
    thick: per unit thickness the slab's energies.csv is the plane-strain
    run's to 1e-10 over 200 steps, as are its mass and its angular momentum
    about z (the 2D scalar), and nothing moves out of the plane."""
    plane = Scene.from_toml(BAR, RUN)
    solid = Scene.from_dict(slab(read_toml(BAR)), RUN)
    assert solid.dim == 3 and solid.dt() == plane.dt() == DT
    thickness = 2.0 * plane.grid.h
    for scene, out in ((plane, tmp_path / "plane"), (solid, tmp_path / "slab")):
        assert Simulation(scene).run(out, progress=False).status == "completed"
    a, b = read_csv(tmp_path / "plane" / "energies.csv"), read_csv(tmp_path / "slab" / "energies.csv")
    assert len(a["step"]) == len(b["step"]) == STEPS + 1
    energy, momentum = np.abs(a["external_work"]).max(), np.abs(a["momentum_x"]).max()
    scales = {"kinetic": energy, "elastic": energy, "external_work": energy, "total": energy,
              "wall_work": energy, "momentum_x": momentum, "momentum_y": momentum,
              "impulse_left_x": momentum, "impulse_left_y": momentum}
    gaps = {k: np.abs(a[k] - b[k] / thickness).max() / scale for k, scale in scales.items()}
    assert max(gaps.values()) < 1e-10, gaps
    assert a["elastic"].max() > 0.3 * energy, "the bar should have stretched"
    assert np.abs(b["momentum_z"]).max() < 1e-12 * momentum * thickness
    # About the mid-plane z = 0 the in-plane components of L cancel pair by pair.
    assert np.abs(b["angular_momentum_x"]).max() + np.abs(b["angular_momentum_y"]).max() < 1e-12 * momentum
    # The mass and the 2D angular momentum are not columns of a 2D run: step by step.
    sims = Simulation(plane), Simulation(solid)
    worst = 0.0
    for _ in range(STEPS):
        for sim in sims:
            sim.advance(1)
        e2, e3 = (sim.energies() for sim in sims)
        worst = max(worst, abs(e2["mass"] - e3["mass"] / thickness) / e2["mass"],
                    abs(e2["angular_momentum"] - e3["angular_momentum_z"] / thickness) / (25.0 * momentum))
        assert e2["momentum_x"] == pytest.approx(e3["momentum_x"] / thickness, rel=0, abs=1e-10 * momentum)
    assert worst < 1e-10
    print(f"slab against plane strain, {STEPS} steps: largest relative gap {max(gaps.values()):.2g} in"
          f" energies.csv ({max(gaps, key=gaps.get)}), {worst:.2g} in mass and angular momentum")


@pytest.mark.parametrize("shape, volume", [
    (Sphere(center=(5.0, 5.0, 5.0), radius=3.0), 4.0 / 3.0 * math.pi * 27.0),
    (Cylinder(start=(2.0, 3.0, 4.0), end=(8.0, 6.0, 6.0), radius=1.5), math.pi * 2.25 * 7.0),
    (Extrusion(Disk(center=(5.0, 5.0), radius=3.0), z0=1.0, z1=9.0), math.pi * 9.0 * 8.0),
])
def test_3d_shapes_seed_their_volume(shape, volume):
    """The particles' volumes add up to the shape's within 2 % (a lattice of
    spacing h/2 at h = 0.5), and every particle lies in the shape."""
    scene = Scene(grid=GridSpec(size=(10.0, 10.0, 10.0), h=0.5), time=Time(end=1.0),
                  materials=(LinearElasticSpec(name="m", E=100.0, nu=0.3, density=2.0),),
                  bodies=(Body(name="b", material="m", shape=shape),))
    p = scene.particles()
    assert p["x"].shape[1] == 3 and shape.contains(*p["x"].T).all()
    assert p["volume"] == pytest.approx(0.25**3)
    assert p["volume"].sum() == pytest.approx(volume, rel=0.02)
    assert p["mass"].sum() == pytest.approx(2.0 * p["volume"].sum())


def test_a_box_seeds_n_cubed_per_cell_in_cell_order():
    """A box of 2 x 3 x 4 cells with 3 x 3 x 3 per cell: 648 particles at the
    sub-cell centres, numbered by cell (x outer, z fastest), then x fastest
    within it."""
    scene = Scene(grid=GridSpec(size=(4.0, 4.0, 5.0), h=1.0, origin=(0.0, 0.0, -1.0)), time=Time(end=1.0),
                  materials=(LinearElasticSpec(name="m", E=100.0, nu=0.3, density=1.0),),
                  bodies=(Body(name="b", material="m", shape=Box(min=(1.0, 0.0, -1.0), max=(3.0, 3.0, 3.0)),
                               particles_per_cell=3, velocity=(1.0, 2.0, 3.0)),))
    p = scene.particles()
    x = p["x"]
    assert len(x) == 2 * 3 * 4 * 27
    assert np.allclose(x[:4], [[1 + 1 / 6, 1 / 6, -1 + 1 / 6], [1.5, 1 / 6, -1 + 1 / 6],
                              [1 + 5 / 6, 1 / 6, -1 + 1 / 6], [1 + 1 / 6, 0.5, -1 + 1 / 6]])
    cells = np.floor(x - [0.0, 0.0, -1.0]).astype(int)
    key = (cells[:, 0] * 4 + cells[:, 1]) * 5 + cells[:, 2]
    assert np.all(np.diff(key) >= 0)
    assert np.allclose(p["v"], [1.0, 2.0, 3.0]) and p["volume"].sum() == pytest.approx(24.0)


def test_weibull_strengths_scale_with_the_3d_particle_volume():
    """A neo-Hookean cube with Rankine damage and a Weibull strength field (H&H
    eq. 25): its 13,824 strengths, drawn for particles of volume (h/2)^3, pass
    a Kolmogorov-Smirnov test against P(sigma_f < s) = 1 - exp(-ln 2 (V /
    V_ref) (s / sigma_ref)^m) with that volume, and fail it with the volume a
    2D scene's particle of the same lattice would have, (h/2)^2 times a unit
    thickness."""
    from scipy import stats

    from pfmpm.scene import NeoHookeanSpec, RankineSpec, WeibullSpec
    h = 0.5
    weibull = WeibullSpec(m=6.0, V_ref=0.01, seed=5)
    rock = NeoHookeanSpec(name="rock", E=100.0, nu=0.3, density=1.0,
                          damage=RankineSpec(sigma_f=2.0, Gf=1.0, weibull=weibull))
    scene = Scene(grid=GridSpec(size=(8.0, 8.0, 8.0), h=h), time=Time(end=1.0), materials=(rock,),
                  bodies=(Body(name="cube", material="rock", shape=Box(min=(1.0, 1.0, 1.0), max=(7.0, 7.0, 7.0))),))
    sim = Simulation(scene)
    strength = np.asarray(sim.particles.sigma_f)
    V = (h / 2) ** 3
    assert len(strength) == 13_824 and np.asarray(sim.particles.volume) == pytest.approx(V)
    assert stats.kstest(strength, lambda s: weibull.cdf(s, 2.0, V)).pvalue > 0.01
    assert stats.kstest(strength, lambda s: weibull.cdf(s, 2.0, (h / 2) ** 2)).pvalue < 1e-6
    assert np.median(strength) == pytest.approx(weibull.median(2.0, V), rel=0.03)


def test_three_failed_planes_cut_a_cube_into_eight_fragments():
    """A cube 4 x 4 x 4 (h = 0.5, 2 x 2 x 2 per cell: spacing 0.25) failed at
    t = 0 on the two layers of particles at each midplane: its intact
    particles link (within 1.5 spacings, scipy's connected components) into
    eight fragments, each of 7^3 particles, whose equivalent diameter is that
    of the ball of their volume, (6 V / pi)^(1/3)."""
    from pfmpm.post.fragments import LINK, failed, fragment_sizes
    from pfmpm.scene import InitialDamage, NeoHookeanSpec, RankineSpec
    rock = NeoHookeanSpec(name="rock", E=100.0, nu=0.3, density=2.0, damage=RankineSpec(sigma_f=1.0, Gf=1.0))
    planes = tuple(InitialDamage(D=1.0, min=tuple(1.8 if k == d else -1.0 for k in range(3)),
                                 max=tuple(2.2 if k == d else 5.0 for k in range(3))) for d in range(3))
    scene = Scene(grid=GridSpec(size=(6.0, 6.0, 6.0), h=0.5, origin=(-1.0, -1.0, -1.0)), time=Time(end=1.0),
                  materials=(rock,), initial_damage=planes,
                  bodies=(Body(name="cube", material="rock", shape=Box(min=(0.0, 0.0, 0.0), max=(4.0, 4.0, 4.0))),))
    p = Simulation(scene).particles
    intact = ~failed(p.damage)
    assert np.count_nonzero(~intact) == 16**3 - 14**3  # the two layers of particles at each midplane
    sizes, masses = fragment_sizes(np.asarray(p.x)[intact], np.asarray(p.volume)[intact],
                                   np.asarray(p.mass)[intact], LINK * 0.25)
    volume = 7**3 * 0.25**3
    assert len(sizes) == 8
    assert sizes == pytest.approx(np.full(8, (6.0 * volume / math.pi) ** (1 / 3)), rel=1e-14)
    assert masses == pytest.approx(np.full(8, 2.0 * volume), rel=1e-14)


def cube_with_damage(*entries) -> Simulation:
    """A neo-Hookean cube 4 x 4 x 4 with Rankine damage (h = 0.5, 2 x 2 x 2
    per cell: particle spacing 0.25, centres at 0.125 + 0.25 k) and the
    initial damage ``entries``."""
    from pfmpm.scene import InitialDamage, NeoHookeanSpec, RankineSpec
    rock = NeoHookeanSpec(name="rock", E=100.0, nu=0.3, density=2.0, damage=RankineSpec(sigma_f=1.0, Gf=1.0))
    return Simulation(Scene(grid=GridSpec(size=(6.0, 6.0, 6.0), h=0.5, origin=(-1.0, -1.0, -1.0)),
                            time=Time(end=1.0), materials=(rock,),
                            initial_damage=tuple(InitialDamage(**e) for e in entries),
                            bodies=(Body(name="cube", material="rock",
                                         shape=Box(min=(0.0, 0.0, 0.0), max=(4.0, 4.0, 4.0))),)))


def test_a_patch_damages_the_particles_near_its_planar_polygon():
    """A square patch in the plane x = 2, corners (2, 1, 1) to (2, 3, 3), half
    width 0.15: the particles within 0.15 of the square, the two layers
    x = 1.875 and 2.125 over the 8 x 8 centres whose (y, z) lies in it (the
    nearest outside, 0.125 past its rim and 0.125 off its plane, are 0.177
    away). A patch across the whole cube at D = 1 cuts it into two
    fragments of 7 x 16 x 16 particles; one over its lower half leaves it whole."""
    from pfmpm.post.fragments import LINK, failed, fragment_sizes
    square = [(2.0, 1.0, 1.0), (2.0, 3.0, 1.0), (2.0, 3.0, 3.0), (2.0, 1.0, 3.0)]
    p = cube_with_damage({"D": 0.5, "points": square, "half_width": 0.15}).particles
    x, hit = np.asarray(p.x), np.asarray(p.damage) > 0
    assert np.count_nonzero(hit) == 2 * 8 * 8
    assert np.all(np.abs(x[hit, 0] - 2.0) == 0.125) and np.all((x[hit, 1:] > 1.0) & (x[hit, 1:] < 3.0))
    assert np.all(np.asarray(p.damage)[hit] == 0.5)
    for zmax, pieces in ((5.0, 2), (2.0, 1)):
        wall = [(2.0, -1.0, -1.0), (2.0, 5.0, -1.0), (2.0, 5.0, zmax), (2.0, -1.0, zmax)]
        p = cube_with_damage({"D": 1.0, "points": wall, "half_width": 0.15}).particles
        intact = ~failed(p.damage)
        sizes, masses = fragment_sizes(np.asarray(p.x)[intact], np.asarray(p.volume)[intact],
                                       np.asarray(p.mass)[intact], LINK * 0.25)
        assert len(sizes) == pieces
        if pieces == 2:
            assert masses == pytest.approx(np.full(2, 2.0 * 7 * 16 * 16 * 0.25**3), rel=1e-14)


@pytest.mark.parametrize("points, message", [
    ([[2.0, 1.0, 1.0], [2.0, 3.0, 1.0]],
     "initial_damage[0].points = [[2.0, 1.0, 1.0], [2.0, 3.0, 1.0]]: a patch needs at least three corners"),
    ([[2.0, 1.0, 1.0], [2.0, 3.0, 1.0], [2.0, 3.0, 3.0], [2.1, 1.0, 3.0]],
     "off the patch's plane (a patch is a planar polygon)"),
    ([[2.0, 1.0, 1.0], [2.0, 2.0, 1.0], [2.0, 3.0, 1.0]],
     "initial_damage[0].points = [[2.0, 1.0, 1.0], [2.0, 2.0, 1.0], [2.0, 3.0, 1.0]]: the corners enclose"
     " no area"),
    ([[1.0, 1.0], [3.0, 3.0]],
     "initial_damage[0].points = [[1.0, 1.0], [3.0, 3.0]]: a band's 2D polyline in a 3D scene"),
])
def test_bad_patches_are_one_line_errors(points, message):
    """Through the TOML tables, as a user writes them: one line naming the key."""
    tables = solid()
    tables["materials"][0].update(model="neo_hookean", damage={"model": "rankine", "sigma_f": 1.0, "Gf": 1.0})
    tables["initial_damage"] = [{"points": points, "half_width": 0.1}]
    with pytest.raises(SceneError) as err:
        Scene.from_dict(tables)
    assert message in str(err.value) and "\n" not in str(err.value)


def test_3d_run_writes_3d_points_and_six_stress_components(tmp_path):
    """The VTU files of a 3D run hold 3D points and the symmetric stress as
    ParaView's six components (xx, yy, zz, xy, yz, xz), read back with
    meshio; energies.csv has the z momentum, the angular momentum and the
    walls' impulses in z; pfmpm animate reads the frames in 3D (speeds the
    velocity's magnitude) and draws them as particles in perspective."""
    out = tmp_path / "bar3d"
    scene = Scene.from_toml(BAR3D, ["time.end=1.0", "output.every=20", "bodies.bar.particles_per_cell=1",
                                    "grid.h=1.0"])
    sim = Simulation(scene)
    assert sim.particles.x.shape == (len(sim.particles), 3) and sim.particles.stress.shape[1] == 6
    assert np.shares_memory(sim.particles.x, sim.particles.x)  # a view of the core's column
    result = sim.run(out, progress=False)
    last = meshio.read(out / f"particles_{result.steps:06d}.vtu")
    assert np.array_equal(last.points, sim.particles.x)
    assert np.ptp(last.points[:, 2]) > 0.5
    stress = last.point_data["stress"]
    assert stress.shape == (len(sim.particles), 6)
    assert np.array_equal(stress, sim.particles.stress[:, [0, 1, 3, 2, 4, 5]])
    assert np.abs(stress[:, 0]).max() > 0.01  # the traction's sigma_xx
    assert last.point_data["velocity"].shape[1] == 3
    e = read_csv(out / "energies.csv")
    assert {"momentum_z", "angular_momentum_z", "impulse_left_z", "wall_work"} <= e.keys()
    assert e["impulse_left_x"][-1] < 0.0  # the fixed wall holds the bar against the traction
    # The last frame as a picture: its particles in perspective, coloured by speed.
    import matplotlib.image

    from pfmpm.animate import frames
    t, x, speed = frames(out, "velocity", 3)[-1]
    assert np.array_equal(x, last.points) and np.allclose(speed, np.linalg.norm(last.point_data["velocity"], axis=1))

    picture = animate(out, out / "speed.png", field="velocity")
    pixels = matplotlib.image.imread(picture)
    assert pixels.shape[0] > 500 and pixels[..., :3].std() > 0.05  # drawn, not blank
    assert len(list(out.glob("*.gif"))) == 0
    gif = animate(out, field="velocity")
    from PIL import Image
    with Image.open(gif) as image:
        assert image.n_frames == len(list(out.glob("particles_*.vtu")))


@pytest.mark.parametrize("shape", ["bspline", "cpdi"])
def test_3d_run_resumes_bitwise(tmp_path, shape):
    """A 3D run resumed from its checkpoint writes the same files as the run
    that went on; with CPDI the checkpoint carries the domains, and the VTU
    files hold them."""
    full = tmp_path / "full"
    # Two checkpoints, at steps 50 and 100: the degree-1 grid of CPDI takes longer steps (87 to
    # t = 4), so it runs to t = 5 (109 steps).
    end, grid = ("5.0", ["--set", "grid.degree=1", "--set", 'grid.shape="cpdi"']) if shape == "cpdi" else ("4.0", [])
    args = ["run", str(BAR3D), "--set", f"time.end={end}", "--set", "output.every=25", "--set", "grid.h=1.0",
            "--set", "bodies.bar.particles_per_cell=1", *grid, "--quiet"]
    assert main([*args, "--out", str(full), "--checkpoint-every", "50", "--keep", "5"]) == 0
    names = [p.name for p in checkpoint.list_checkpoints(full / "checkpoints")]
    assert names[:2] == ["step_000000050.h5", "step_000000100.h5"]
    part = tmp_path / "part"
    shutil.copytree(full, part)
    for name in names[1:]:
        (part / "checkpoints" / name).unlink()
    assert main(["run", "--resume", str(part), "--quiet"]) == 0
    files = [p.name for p in sorted(full.iterdir()) if p.suffix in (".csv", ".vtu", ".pvd")]
    assert len(files) >= 5
    for name in files:
        assert (full / name).read_bytes() == (part / name).read_bytes(), f"{name} differs after resuming"
    if shape == "cpdi":
        last = meshio.read(sorted(full.glob("*.vtu"))[-1])
        r = [last.point_data[f"domain_r{k}"] for k in (1, 2, 3)]
        assert all(e.shape == (len(last.points), 3) for e in r)
        # The domains, once the lattice's cubes of half-edge h/2 = 0.5, stretched by the pull.
        assert np.abs(np.stack(r, axis=1) - 0.5 * np.eye(3)).max() > 1e-6
        assert np.linalg.det(np.stack(r, axis=2)).min() > 0.9 * 0.125


def test_bench_cube():
    r = bench(particles=1000, steps=2, repeats=1, dim=3)
    assert r["dim"] == 3 and r["per_cell"] == 2 and r["particles"] == 5**3 * 8  # 5 cells a side
    assert r["particle_steps_per_s"] == pytest.approx(r["particles"] * 2 / r["seconds"])
    with pytest.raises(ValueError, match="dim = 3: physics must be elastic, contact, damage_gradient or phasefield"):
        bench(physics="anisotropic", particles=1000, dim=3)
    # A crack patch to the cube's middle: its phase field is solved every step.
    r = bench(physics="phasefield", particles=1000, steps=2, repeats=1, dim=3)
    assert r["particles"] == 5**3 * 8 and r["phase_field_iterations_per_step"] > 0
    r = bench(physics="contact", particles=1000, steps=2, repeats=1, dim=3)
    assert r["particles"] == 5**3 * 8 and r["physics"] == "contact"
    # Three failed planes one cell thick through the cube's middle: the
    # partition splits the nodes around them and computes their gradients.
    r = bench(physics="damage_gradient", particles=1000, steps=2, repeats=1, dim=3)
    assert r["particles"] == 5**3 * 8 and r["contact_nodes"] > 0 and r["damage_share"]["gradient"] > 0
    r = bench(particles=1000, steps=2, repeats=1, dim=3, degree=1, shape="cpdi")
    assert r["particles"] == 5**3 * 8 and r["shape"] == "cpdi"


def test_3d_bodies_in_contact_exchange_the_impulse_they_record(tmp_path):
    """A ball thrown obliquely at a block, each its own field with Coulomb
    contact (mu = 0.3): every component of the ball's momentum changes by the
    contact impulse of the block on it (``contact_ball_block_x|y|z``), and the
    total momentum stays its initial value, to 1e-12 at every row."""
    d = {"name": "throw", "grid": {"size": [8.0, 6.0, 6.0], "h": 0.5}, "time": {"end": 2.0},
         "output": {"energies_every": 5, "particles": False},
         "materials": [{"name": "m", "E": 100.0, "nu": 0.3, "density": 1.0}],
         "bodies": [{"name": "ball", "material": "m", "velocity": [1.0, 0.3, -0.2],
                     "shape": {"type": "sphere", "center": [2.0, 3.0, 3.0], "radius": 1.0}},
                    {"name": "block", "material": "m",
                     "shape": {"type": "box", "min": [3.5, 1.0, 1.0], "max": [6.5, 5.0, 5.0]}}],
         "contact": {"friction": 0.3}}
    scene = Scene.from_dict(d)
    assert Simulation(scene).run(tmp_path, progress=False).status == "completed"
    e = read_csv(tmp_path / "energies.csv")
    mass = Simulation(scene).particles.mass
    scale = float(np.sum(mass)) * 1.0
    assert np.abs(e["contact_ball_block_x"]).max() > 0.1 * scale, "the ball should have hit the block"
    for axis in "xyz":
        gained = e[f"momentum_{axis}_ball"] - e[f"momentum_{axis}_ball"][0]
        assert np.abs(gained - e[f"contact_ball_block_{axis}"]).max() < 1e-12 * scale
        assert np.abs(e[f"momentum_{axis}"] - e[f"momentum_{axis}"][0]).max() < 1e-12 * scale


def sliding_block(mu: float, g: float, v0: float, end: float) -> dict:
    """A 2 x 2 x 1 block at speed v0 along (1, 1, 0) / sqrt(2) on a slab 100
    times heavier and stiffer (on a fixed back wall), gravity g along -z on
    the block, h = 0.5, to t = ``end``; without its [contact] table."""
    c = v0 / math.sqrt(2.0)
    return {"name": "slide", "grid": {"size": [9.0, 9.0, 3.0], "h": 0.5, "origin": [-0.5, -0.5, 0.0]},
            "time": {"end": end, "cfl": 0.5}, "output": {"energies_every": 10, "particles": False},
            "materials": [{"name": "block", "E": 1000.0, "nu": 0.3, "density": 1.0},
                          {"name": "slab", "E": 1e5, "nu": 0.3, "density": 100.0}],
            "bodies": [{"name": "slab", "material": "slab",
                        "shape": {"type": "box", "min": [0.0, 0.0, 0.0], "max": [8.0, 8.0, 1.0]}},
                       {"name": "block", "material": "block", "velocity": [c, c, 0.0],
                        "shape": {"type": "box", "min": [1.0, 1.0, 1.0], "max": [3.0, 3.0, 2.0]}}],
            "loads": [{"type": "body_force", "body": "block", "acceleration": [0.0, 0.0, -g]}],
            "walls": [{"side": "back", "type": "fixed"}]}


def run_slide(sim: Simulation, out: Path):
    """Run the sliding block to its end: its energies.csv, the block's mass,
    its velocity (x, y) per row, its deceleration (a line fit of its speed
    over 0.5 < t < 3: settled, far from stopping at t = 8) and the largest
    departure of its direction from (1, 1) over that time."""
    assert sim.run(out, progress=False).status == "completed"
    e = read_csv(out / "energies.csv")
    M = float(sim.particles.mass[sim.particles.body == 1].sum())
    vx, vy = e["momentum_x_block"] / M, e["momentum_y_block"] / M
    sliding = (e["t"] > 0.5) & (e["t"] < 3.0)
    deceleration = -np.polyfit(e["t"][sliding], np.hypot(vx, vy)[sliding], 1)[0]
    return e, M, vx, vy, deceleration, np.abs(vy[sliding] / vx[sliding] - 1.0).max()


def test_a_block_sliding_obliquely_decelerates_at_mu_g(tmp_path):
    """A 2 x 2 x 1 block sliding at speed 1 along (1, 1, 0) / sqrt(2) on a slab
    100 times heavier and stiffer (on a fixed back wall), gravity g = 0.25
    along -z on the block, mu = 0.5: friction in the tangent plane opposes
    the slip, so the block keeps its direction, decelerates at mu g, stops
    after v0^2 / (2 mu g), and friction takes its kinetic energy."""
    import json

    mu, g, v0 = 0.5, 0.25, 1.0
    d = sliding_block(mu, g, v0, end=9.0)
    d["contact"] = {"friction": 0.0, "pairs": [{"bodies": ["slab", "block"], "friction": mu}]}
    sim = Simulation(Scene.from_dict(d))
    e, M, vx, vy, deceleration, direction = run_slide(sim, tmp_path)
    assert deceleration == pytest.approx(mu * g, rel=0.03)
    assert direction < 1e-12
    block = sim.particles.body == 1
    moved = sim.particles.x[block, :2].mean(axis=0) - 2.0
    assert moved == pytest.approx(np.full(2, v0**2 / (2 * mu * g) / math.sqrt(2.0)), rel=0.03)
    assert np.abs(sim.particles.v[block]).max() < 0.01 * v0
    assert sim.energies()["friction_dissipation"] == pytest.approx(0.5 * M * v0**2, rel=0.02)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["contact"]["violations"] == {"C1": 0, "C2": 0, "C3": 0, "C4": 0}


def test_a_block_sliding_on_a_failed_plane_decelerates_at_mu_g(tmp_path):
    """The block and slab of the test above in one contact group, so one
    velocity field until the damage gradient splits it, joined by a failed
    plane: the particle layers on either side of their interface are
    surface particles (fully damaged, H&H section 2.4). The partition parts
    the two at the plane and the crack faces' friction, mu, takes over: the
    block decelerates at mu g while it slides, keeps its direction, and
    friction takes its kinetic energy."""
    import json

    mu, g, v0 = 0.5, 0.25, 1.0
    d = sliding_block(mu, g, v0, end=4.0)
    d["contact"] = {"partition": "damage_gradient", "friction": mu, "groups": [["slab", "block"]],
                    "surfaces": [{"type": "box", "min": [0.0, 0.0, 0.75], "max": [8.0, 8.0, 1.25]}]}
    sim = Simulation(Scene.from_dict(d))
    failed = sim.particles.surface == 1
    assert np.all(np.abs(sim.particles.x[failed, 2] - 1.0) == 0.125)  # the layers either side of z = 1
    e, M, vx, vy, deceleration, direction = run_slide(sim, tmp_path)
    assert deceleration == pytest.approx(mu * g, rel=0.03)
    assert direction < 1e-12
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["contact"]["separable_node_steps"] > 0
    assert summary["contact"]["violations"] == {"C1": 0, "C2": 0, "C3": 0, "C4": 0}
    # Friction took the kinetic energy the block lost, less what gravity's
    # work on its settling and the elastic energy hold.
    lost = 0.5 * M * (v0**2 - (vx[-1] ** 2 + vy[-1] ** 2))
    assert e["friction_dissipation"][-1] == pytest.approx(lost, rel=0.03)
    print(f"\nblock on a failed plane: deceleration / mu g - 1 = {deceleration / (mu * g) - 1:+.2e},"
          f" direction {direction:.1e},"
          f" friction dissipation / kinetic energy lost - 1 = {e['friction_dissipation'][-1] / lost - 1:+.2e},"
          f" separable node-steps {summary['contact']['separable_node_steps']}")


def test_run_fragments_reads_3d_frames(tmp_path):
    """Two balls one above the other (the same x and y, 1.0 apart in z
    between their surfaces) at rest: in the run's frames each is one
    fragment and their closest particles 1.0 + a spacing apart, which a
    frame read in x and y alone would show overlapping."""
    from pfmpm.post.fragments import run_fragments
    d = {"name": "stack", "grid": {"size": [6.0, 6.0, 9.0], "h": 0.5}, "time": {"end": 0.1},
         "output": {"every": 5},
         "materials": [{"name": "m", "E": 100.0, "nu": 0.3, "density": 1.0}],
         "bodies": [{"name": "low", "material": "m", "shape": {"type": "sphere", "center": [3.0, 3.0, 2.5], "radius": 1.5}},
                    {"name": "high", "material": "m", "shape": {"type": "sphere", "center": [3.0, 3.0, 6.5], "radius": 1.5}}]}
    scene = Scene.from_dict(d)
    assert Simulation(scene).run(tmp_path, progress=False).status == "completed"
    rows = run_fragments(scene, tmp_path)
    assert len(rows) >= 2
    for row in rows:
        assert row["fragments"] == {"low": 1, "high": 1}
        # particle centres 0.125 inside each surface: 1.0 + 2 x 0.125 apart at the poles, in spacings of 0.25
        assert row["closest"] == pytest.approx((1.0 + 0.25) / 0.25, rel=1e-6)


def test_a_slab_disk_hitting_a_block_against_the_plane_run(tmp_path):
    """A disk thrown at a block (each its own field, mu = 0.3) and its slab two
    cells thick between slip walls. Until the two share a node the slab is
    the plane-strain run to round-off; momentum agrees throughout. In
    contact it is not: the normal of K&T eqs. 70-71, from the two fields'
    mass gradients, has a z component wherever their nodal masses differ
    (the slab's faces z = +-t/2 are in each body's mass gradient), so the
    pair law pushes along a tilted normal. The gap it leaves in the kinetic
    energy (4.1 % of the peak over these 200 steps) is recorded on
    docs/verification/three-dimensions.md; the 1e-10 the issue asks for
    needs z-periodic boundaries or a normal held in the plane."""
    d = {"name": "hit", "grid": {"size": [8.0, 4.0], "h": 0.25}, "time": {"end": 1.0, "dt": 0.005},
         "output": {"energies_every": 1, "particles": False},
         "materials": [{"name": "m", "E": 100.0, "nu": 0.3, "density": 1.0}],
         "bodies": [{"name": "disk", "material": "m", "velocity": [1.0, 0.2],
                     "shape": {"type": "disk", "center": [2.0, 2.0], "radius": 1.0}},
                    {"name": "block", "material": "m",
                     "shape": {"type": "rectangle", "min": [3.25, 0.5], "max": [6.0, 3.5]}}],
         "contact": {"friction": 0.3}}
    solid = slab(d)
    solid["bodies"][0]["velocity"] = [1.0, 0.2, 0.0]
    for name, tables in (("plane", d), ("slab", solid)):
        assert Simulation(Scene.from_dict(tables)).run(tmp_path / name, progress=False).status == "completed"
    a, b = read_csv(tmp_path / "plane" / "energies.csv"), read_csv(tmp_path / "slab" / "energies.csv")
    thickness = 0.5
    energy, momentum = np.abs(a["kinetic"]).max(), np.abs(a["momentum_x"]).max()
    gap = np.abs(a["kinetic"] - b["kinetic"] / thickness) / energy
    touch = int(np.argmax(gap > 1e-12))  # the first row in contact
    assert 20 < touch < int(np.argmax(np.abs(a["contact_disk_block_x"]) > 0))
    assert np.abs(a["elastic"][:touch] - b["elastic"][:touch] / thickness).max() < 1e-12 * energy
    for k in ("momentum_x", "momentum_y"):
        assert np.abs(a[k] - b[k] / thickness).max() < 1e-10 * momentum
    assert 1e-3 < gap.max() < 0.1


def solid() -> dict:
    """A small valid 3D scene, as tables."""
    return {"name": "cube", "grid": {"size": [6.0, 6.0, 6.0], "h": 1.0}, "time": {"end": 1.0},
            "materials": [{"name": "m", "E": 100.0, "nu": 0.3, "density": 1.0}],
            "bodies": [{"name": "b", "material": "m",
                        "shape": {"type": "box", "min": [2.0, 2.0, 2.0], "max": [4.0, 4.0, 4.0]}}]}


def flat() -> dict:
    """A small valid 2D scene, as tables."""
    return {"name": "square", "grid": {"size": [6.0, 6.0], "h": 1.0}, "time": {"end": 1.0},
            "materials": [{"name": "m", "E": 100.0, "nu": 0.3, "density": 1.0}],
            "bodies": [{"name": "b", "material": "m",
                        "shape": {"type": "rectangle", "min": [2.0, 2.0], "max": [4.0, 4.0]}}]}


BAD = [
    # a 2D feature in a 3D scene
    (solid, ['bodies.b.shape={type = "rectangle", min = [2.0, 2.0], max = [4.0, 4.0]}'],
     "bodies[0].shape = 'rectangle': a 2D shape (rectangle) in a 3D scene (grid.size has 3 entries); extrude it"),
    (solid, ['bodies.b.holes=[{type = "disk", center = [3.0, 3.0], radius = 0.5}]'],
     "bodies[0].holes[0] = 'disk': a 2D shape (disk) in a body of the 3D shape box"),
    (solid, ['materials.m.fracture={Gc = 1.0, l0 = 2.0, anisotropy = {symmetry = "orthotropic", g1111 = 1.0,'
             ' g2222 = 80.0, g1212 = 74.0}}'],
     "materials[0].fracture.anisotropy = 'orthotropic': an anisotropic crack resistance is two-dimensional yet"),
    (solid, ['materials.m.model="drucker_prager"', "materials.m.friction_angle=30.0", "materials.m.cohesion=1.0"],
     "materials[0].model = 'drucker_prager': the drucker_prager model is two-dimensional yet"),
    (solid, ['plane="stress"'], "plane = 'stress': plane stress is two-dimensional yet"),
    (solid, ['contact={partition = "damage_gradient", friction = 0.3, surfaces = [{type = "rectangle",'
             ' min = [2.0, 2.0], max = [3.0, 3.0]}]}'],
     "contact.surfaces[0] = 'rectangle': a 2D shape (rectangle) in a 3D scene (grid.size has 3 entries)"),
    (solid, ["cracks=[{points = [[2.0, 3.0], [3.0, 3.0]]}]"],
     "cracks[0].points = [[2.0, 3.0], [3.0, 3.0]]: 2D points in a 3D scene (grid.size has 3 entries)"),
    (solid, ["bodies.b.orientation=30.0"], "bodies[0].orientation = 30.0: the material orientation is"
                                           " two-dimensional yet"),
    (solid, ["bodies.b.velocity=[1.0, 0.0]"],
     "bodies[0].velocity = [1.0, 0.0]: has 2 components, but the scene is 3D (grid.size has 3 entries)"),
    (solid, ['loads=[{type = "body_force", acceleration = [0.0, -1.0]}]'],
     "loads[0].acceleration = [0.0, -1.0]: has 2 components, but the scene is 3D"),
    (solid, ['loads=[{type = "traction", body = "b", edge = "top", traction = [0.0, 1.0, 0.0], span = [2.0, 3.0]}]'],
     "loads[0].span = [2.0, 3.0]: in 3D a span is two intervals [[a, b], [c, d]], along x then z on the top face"),
    (solid, ["grid.origin=[0.0, 0.0]"], "grid.origin = [0.0, 0.0]: has 2 components, but the scene is 3D"),
    (solid, ['bodies.b.shape={type = "extrusion", shape = {type = "box", min = [0, 0, 0], max = [1, 1, 1]},'
             " z0 = 0.0, z1 = 1.0}"], "bodies[0].shape.shape = 'box': a 3D shape (box): an extrusion takes a 2D one"),
    (solid, ['bodies.b.shape={type = "cylinder", start = [1.0, 1.0, 1.0], end = [1.0, 1.0, 1.0], radius = 1.0}'],
     "bodies[0].shape.end = [1.0, 1.0, 1.0]: must lie a finite distance from start"),
    # a 3D key in a 2D scene
    (flat, ['walls=[{side = "back", type = "slip"}]'],
     "walls[0].side = 'back': a side of a 3D grid (z min or max); a 2D grid has left, right, bottom, top"),
    (flat, ["grid.size=[6.0, 6.0, 6.0]"],
     "bodies[0].shape = 'rectangle': a 2D shape (rectangle) in a 3D scene"),
    (flat, ["grid.origin=[0.0, 0.0, 0.0]"], "grid.origin = [0.0, 0.0, 0.0]: has 3 components, but the scene is 2D"),
    (flat, ['bodies.b.shape={type = "sphere", center = [3.0, 3.0, 3.0], radius = 1.0}'],
     "bodies[0].shape = 'sphere': a 3D shape (sphere) in a 2D scene (grid.size has 2 entries)"),
    (flat, ['loads=[{type = "traction", body = "b", edge = "front", traction = [0.0, 1.0]}]'],
     "loads[0].edge = 'front': a side of a 3D grid (z min or max)"),
    (flat, ['loads=[{type = "traction", body = "b", edge = "top", traction = [0.0, 1.0, 0.0]}]'],
     "loads[0].traction = [0.0, 1.0, 0.0]: has 3 components, but the scene is 2D"),
    (flat, ['prescribed=[{name = "grip", body = "b", velocity = [0.0, 1.0], components = "z"}]'],
     "prescribed[0].components = 'z': must be one of 'x', 'y', 'xy'"),
    (flat, ['initial_damage=[{min = [0.0, 0.0, 0.0], max = [1.0, 1.0, 1.0]}]'],
     "initial_damage[0].min = [0.0, 0.0, 0.0]: has 3 components, but the scene is 2D"),
]


@pytest.mark.parametrize("tables, sets, message", BAD, ids=[m.split(":")[0] for _, _, m in BAD])
def test_bad_dimensions_are_one_line_errors(tables, sets, message):
    with pytest.raises(SceneError) as err:
        Scene.from_dict(tables(), sets)
    assert str(err.value).startswith(message) and "\n" not in str(err.value)


def test_pfmpm_run_of_a_bad_3d_scene_is_one_line(tmp_path):
    """No traceback from the command line either; and the FEM path says which 3D shapes it meshes."""
    scene = tmp_path / "bad.toml"
    scene.write_text(BAR3D.read_text().replace('type = "cylinder"', 'type = "disk"'))
    for command in ("run", "fem"):
        r = subprocess.run([sys.executable, "-m", "pfmpm.cli", command, str(scene), "--out", str(tmp_path / "o"),
                            "--quiet"], capture_output=True, text=True)
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 2 and len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
        assert lines[0].startswith("error: bodies[0].shape")
    r = subprocess.run([sys.executable, "-m", "pfmpm.cli", "fem", str(BAR3D), "--out", str(tmp_path / "f"),
                        "--quiet"], capture_output=True, text=True)
    assert r.returncode == 2 and r.stderr.strip() == ("error: bodies[0].shape = 'cylinder': the FEM path in 3D"
                                                      " needs a box or an extruded rectangle")
