"""The set-up report (pfmpm.scene.report): each body's extent as seeded, the
gap between bodies that start apart and when they meet, what sets the time
step, and warnings for what the run will not do as the scene seems to ask."""

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import pytest

from pfmpm import Simulation
from pfmpm.scene import (Body, Contact, Disk, FractureSpec, GridSpec, LinearElasticSpec, Output, Rectangle,
                         Scene, Time, wave_speed)
from pfmpm.scene.report import setup_report
from pfmpm.scene.toml import toml_text

ROOT = Path(__file__).resolve().parents[1]
STIFF = LinearElasticSpec(name="stiff", E=400.0, nu=0.3, density=1.0)
SOFT = LinearElasticSpec(name="soft", E=100.0, nu=0.3, density=1.0)


def two_disks(end: float = 30.0, dt: float | None = None) -> Scene:
    """Two disks of radius 5 on the particle row y = 10.25 (spacing 0.5), the
    stiff one moving right at 0.1, the soft one left at 0.15.

    The left disk's outline reaches x = 14.875: its last particle on the row is
    at 14.75, its square ends at 15.0 (and the rows either side end there too,
    their outline at 14.85); the right one's starts at 20.125, its first
    particle at 20.25, its square at 20.0. So the gap is 5.0 = D - 2R - s/2
    (centres D = 15.25 apart, not the 5.25 of the outlines), closing at
    0.25: they meet at t = 20."""
    return Scene(grid=GridSpec(size=(40.0, 20.0), h=1.0), time=Time(end=end, dt=dt),
                 materials=(STIFF, SOFT),
                 bodies=(Body("left", "stiff", Disk((9.875, 10.25), 5.0), velocity=(0.1, 0.0)),
                         Body("right", "soft", Disk((25.125, 10.25), 5.0), velocity=(-0.15, 0.0))),
                 contact=Contact())


def test_the_extent_is_the_seeded_particles_box_and_the_outline_is_named_where_it_differs():
    """A beam top at 76.2 on a lattice of spacing 0.5 is seeded to 76.0 (issue 53):
    the report says so, and each extent is the bounding box of the body's
    particles widened by half a spacing."""
    steel = LinearElasticSpec(name="steel", E=210000.0, nu=0.3, density=7850.0)
    scene = Scene(grid=GridSpec(size=(120.0, 110.0), h=1.0, origin=(-10.0, -10.0)), time=Time(end=1.0),
                  materials=(steel,), units="mm-us-MPa",
                  bodies=(Body("beam", "steel", Rectangle((0.0, 0.0), (100.0, 76.2))),
                          Body("disk", "steel", Disk((50.0, 85.3), 5.0), particles_per_cell=4)))
    report = setup_report(scene)
    sim = Simulation(scene)
    for b, (body, extent) in enumerate(zip(scene.bodies, report.extents)):
        x = sim.particles.x[sim.particles.body == b]
        half = 0.5 * body.spacing(scene.grid.h)
        assert extent.body == body.name and extent.particles == len(x)
        assert extent.lo == tuple(x.min(axis=0) - half) and extent.hi == tuple(x.max(axis=0) + half)
    assert report.extents[0].hi == (100.0, 76.0) and report.extents[0].shape == (0.0, 0.0, 100.0, 76.2)
    lines = report.lines()
    assert lines[0] == ("body beam (steel): 30400 particles 0.5 mm apart, from (0, 0) to (100, 76) mm;"
                        " its shape spans (0, 0) to (100, 76.2)")
    assert lines[1].startswith("body disk (steel): ")
    # The disk starts 4.1 above the outline of the beam: 4.3 above its seeded top, less round-off.
    assert report.gaps[0].bodies == ("beam", "disk")
    assert report.gaps[0].gap == pytest.approx(report.extents[1].lo[1] - 76.0, abs=1e-12)
    assert report.gaps[0].meet is None and lines[2] == "bodies beam and disk: 4.25 mm apart, not approaching"


def test_the_gap_and_meeting_time_of_two_disks():
    report = setup_report(two_disks())
    (gap,) = report.gaps
    assert gap.bodies == ("left", "right")
    assert gap.gap == pytest.approx(15.25 - 2 * 5.0 - 0.25, abs=1e-12)
    assert gap.closing_speed == pytest.approx(0.25, abs=1e-15)
    assert gap.meet == pytest.approx(20.0, rel=1e-12)
    assert "bodies left and right: 5 apart, approaching at 0.25: they meet at t = 20" in report.lines()
    assert report.warnings == []
    # Ended at t = 10, the run stops before they meet, and the report warns.
    (warning,) = setup_report(two_disks(end=10.0)).warnings
    assert warning.startswith("bodies left and right are 5 apart and meet at t = 20 at their initial speeds,"
                              " after the run ends (t = 10")
    # Moving apart, they never meet.
    away = dataclasses.replace(two_disks(), bodies=tuple(dataclasses.replace(b, velocity=(-b.velocity[0], 0.0))
                                                         for b in two_disks().bodies))
    assert setup_report(away).gaps[0].meet is None


def test_bodies_whose_outlines_are_apart_may_touch_once_seeded():
    """The disk-beam demo's disk starts 0.125 mm above the beam: one spacing at
    h = 0.25, so it meets the beam after 0.125 / 0.02 = 6.25 us; at h = 1 its
    lowest particles' squares reach down to the beam's top, and it touches from the start."""
    path = ROOT / "demos" / "disk_beam.toml"
    fine = setup_report(Scene.from_toml(path))
    assert [(g.bodies, g.gap, g.meet) for g in fine.gaps] == [(("beam", "disk"), pytest.approx(0.125, abs=1e-12),
                                                              pytest.approx(6.25, rel=1e-12))]
    assert fine.touching == []
    coarse = setup_report(Scene.from_toml(path, ["grid.h=1.0", "materials.beam.fracture.l0=2.0",
                                                 "materials.disk.fracture.l0=2.0"]))
    assert coarse.gaps == [] and coarse.touching == [("beam", "disk")]
    assert coarse.extents[1].lo[1] == 10.0 and coarse.extents[1].shape[1] == 10.125
    assert "bodies beam and disk: touching at t = 0" in coarse.lines()


def test_the_bodies_and_material_that_set_the_time_step_are_named():
    """The stiff disk's material has the fastest P wave, the soft disk the fastest
    start: dt = cfl kappa h / (c_stiff + 0.15), each named."""
    scene = two_disks()
    report = setup_report(scene)
    step = report.step
    c = wave_speed(STIFF.E, STIFF.nu, STIFF.density, scene.plane)
    assert (step.wave_body, step.wave_speed, step.speed_body, step.speed) == ("left", c, "right", 0.15)
    # kappa: a lone particle's limit for quadratic B-splines, below the grid's 1.
    assert step.kappa == 0.577 and step.lone and step.side_body is None
    assert step.limit == scene.stable_dt() == scene.time.cfl * (0.577 * 1.0) / (c + 0.15)
    assert report.lines()[-1] == (f"time step dt = {step.limit:.6g} = cfl 0.8 x kappa 0.577 x h 1 / (P-wave"
                                  f" speed {c:.6g} of body left (stiff) + speed 0.15 of body right); kappa:"
                                  " a particle alone on its nodes (a body's corner), below the grid's")
    # A fixed step is given as a share of the default one.
    fixed = setup_report(two_disks(dt=0.5 * step.limit))
    assert fixed.lines()[-1].startswith(f"time step dt = {0.5 * step.limit:.6g} (time.dt), 50 % of the"
                                        f" default step dt = {step.limit:.6g} = ")
    # With cubic B-splines a body within grid.degree cells of a grid side
    # lowers kappa below a lone particle's, and is named.
    low = dataclasses.replace(scene, grid=dataclasses.replace(scene.grid, degree=3),
                              bodies=(scene.bodies[0], dataclasses.replace(
                                  scene.bodies[1], shape=Disk((25.125, 6.25), 5.0))))
    step = setup_report(low).step
    assert (step.side_body, step.kappa, step.lone) == ("right", 0.461, False)
    assert low.stable_dt() == step.limit == low.time.cfl * (0.461 * 1.0) / (c + 0.15)
    assert setup_report(low).lines()[-1].endswith("; kappa < 1: body right starts within grid.degree cells"
                                                  " of a grid side")


def test_snapshots_after_the_end_are_warned_of():
    """Their panels would all show the last state: the report says which they are;
    the end itself (the run's last step, past time.end) is no warning."""
    scene = dataclasses.replace(two_disks(), materials=(
        dataclasses.replace(STIFF, fracture=FractureSpec(Gc=1.0, l0=2.0)), SOFT))
    end = scene.steps() * scene.dt()
    assert end > scene.time.end
    late = dataclasses.replace(scene, output=Output(snapshots=(5.0, end, 31.0, 40.0)))
    assert setup_report(late).warnings == [f"output.snapshots = 31, 40: after the run ends (t = {end:.6g}),"
                                           " so their panels show its last state"]
    assert setup_report(dataclasses.replace(scene, output=Output(snapshots=(5.0, end)))).warnings == []


def test_pfmpm_run_prints_the_report(tmp_path):
    """The report follows the run's first line, then its warnings (on stdout: the
    first line on stderr is what failed, if the run fails)."""
    path = tmp_path / "disks.toml"
    path.write_text(toml_text(two_disks(end=10.0).to_dict()))
    r = subprocess.run([sys.executable, "-m", "pfmpm.cli", "run", str(path), "--out", str(tmp_path / "out"),
                        "--quiet", "--set", "output.every=1000"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert lines[1:5] == ["  " + line for line in setup_report(two_disks(end=10.0)).lines()]
    assert lines[5].startswith("warning: bodies left and right are 5 apart and meet at t = 20") and not r.stderr
    setup = json.loads((tmp_path / "out" / "summary.json").read_text())["setup"]
    assert setup["gaps"][0]["meet"] == pytest.approx(20.0, rel=1e-12)
    assert setup["step"]["wave_body"] == "left" and len(setup["extents"]) == 2
