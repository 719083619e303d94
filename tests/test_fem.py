"""The phase-field FEM reference (pfmpm.fem) against analytic solutions.

Checks the phase-field solve on the 1D crack profile, the lumped mass and the
load vectors, a fixed wall, an elastic P-wave between slip walls, the output
of a failed run, the scene checks, and that two MPI ranks reproduce one.
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
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc

from pfmpm import SceneError
from pfmpm.fem import FemSimulation
from pfmpm.output import read_csv
from pfmpm.scene import (
    Body,
    BodyForce,
    Crack,
    Disk,
    Fracture,
    Grid,
    Material,
    NeoHookeanSpec,
    Output,
    PhaseField,
    RankineSpec,
    Rectangle,
    Scene,
    Time,
    Traction,
    Wall,
    wave_speed,
)

DEMOS = Path(__file__).resolve().parents[1] / "demos"


def plate(shape=Rectangle((0.0, 0.0), (3.0, 2.0)), h=0.25, **kwargs):
    """A single-body scene on a grid with one cell of margin around the plate."""
    material = kwargs.pop("material", Material(name="m", E=100.0, nu=0.25, density=7.0))
    bodies = kwargs.pop("bodies", (Body(name="p", material=material.name, shape=shape),))
    return Scene(grid=Grid(size=(5.0, 4.0), h=h, origin=(-1.0, -1.0)),
                 time=kwargs.pop("time", Time(end=1.0)), materials=(material,),
                 bodies=bodies, **kwargs)


def test_crack_profile_and_density_match_the_1d_solution():
    """A straight crack imposed at x = 0 across a strip |x| <= L, 4 cells high.

    With c(0) = 0 and no flux at x = +-L the exact profile is
    ``1 - c = cosh((L - |x|) / (2 l0)) / cosh(L / (2 l0))`` (on an infinite
    strip ``exp(-|x| / (2 l0))``), and the crack density functional
    integrates to ``tanh(L / (2 l0))`` per unit crack area (1 when infinite).
    Here L = 6 l0, h = l0 / 40, and the history band is half a cell wide
    with B = 1e6, so c(0) is nearly 0 (4.7e-4).  The error is the L2 norm of
    ``c_h - c`` over the strip relative to that of ``1 - c`` (lumped-mass
    quadrature); the crack density is the fracture energy over
    ``G_c * crack length * thickness``.  G_c, l0 and the thickness are not
    1, so that a misplaced factor shows.
    """
    l0, gc, thickness = 0.5, 0.003, 2.0
    h, half_length = l0 / 40, 6 * l0
    height = 4 * h
    material = Material(name="m", E=1.0, nu=0.0, density=1.0, fracture=Fracture(Gc=gc, l0=l0))
    scene = Scene(
        grid=Grid(size=(2 * half_length + 2 * h, height + 2 * h), h=h, origin=(-half_length - h, -h)),
        time=Time(end=1.0), materials=(material,), thickness=thickness,
        bodies=(Body(name="strip", material="m", particles_per_cell=1,
                     shape=Rectangle((-half_length, 0.0), (half_length, height))),),
        cracks=(Crack(points=((0.0, -1.0), (0.0, height + 1.0)), B=1e6, half_width=0.5 * h),),
        phase_field=PhaseField(tol=1e-10, max_iterations=5000),
    )
    sim = FemSimulation(scene)  # solves the phase field of the initial crack
    x = sim.vertices[: sim.owned, 0]
    c = sim.c.x.array[: sim.owned]
    m = sim.lumped_mass
    a = half_length / (2 * l0)
    exact = 1.0 - np.cosh(a - np.abs(x) / (2 * l0)) / np.cosh(a)
    error = math.sqrt((m @ (c - exact) ** 2) / (m @ (1 - exact) ** 2))
    # Measured 4.8e-4, -0.09 % and 1.8e-4; with the history at the cell
    # centroids the band held the cells beside the crack too: 0.0089, +0.74 %
    # and 3.3e-3 (0.0024, -0.29 % and 9e-4 with B = 1e5, which held them less).
    assert error < 0.002
    density = sim.energies()["fracture"] / (gc * height * thickness)
    assert density == pytest.approx(math.tanh(a), rel=0.002)
    # Away from the band the discrete profile follows the exact one closely.
    far = np.abs(x) > 2 * l0
    assert np.max(np.abs(c[far] - exact[far])) < 5e-4
    assert c.min() >= 0.0 and c.max() <= 1.0  # the bound



def strip_1d(l0, h, model, crack_at=0.0, half_width=None, half_length=None):
    """A strip |x| <= half_length (default 6 l0), two cells high, cut across
    by a crack on x = crack_at: a history band of half-width h/2 (unless
    given) with B = 1e4 l0 / w, the band of docs/notebooks/phase_field_profiles.ipynb.
    G_c and the thickness are not 1, so that a misplaced factor shows."""
    w = 0.5 * h if half_width is None else half_width
    half = 6 * l0 if half_length is None else half_length
    height = 2 * h
    material = Material(name="m", E=1.0, nu=0.0, density=1.0,
                        fracture=Fracture(Gc=0.003, l0=l0, model=model))
    return Scene(
        grid=Grid(size=(2 * half + 2 * h, height + 2 * h), h=h, origin=(-half - h, -h)),
        time=Time(end=1.0), materials=(material,), thickness=2.0,
        bodies=(Body(name="strip", material="m", shape=Rectangle((-half, 0.0), (half, height))),),
        cracks=(Crack(points=((crack_at, -1.0), (crack_at, height + 1.0)), B=1e4 * l0 / w,
                      half_width=w),),
        phase_field=PhaseField(tol=1e-10, max_iterations=5000),
    )


def exact_1d(x, l0, model, half_length):
    """The phase field across a crack at x = 0 on a strip |x| <= half_length
    with no flux at its ends: AT2 ``1 - cosh((L - |x|) / (2 l0)) / cosh(L / (2 l0))``,
    AT1 ``1 - (1 - |x| / (4 l0))^2`` within 4 l0 (docs/method.md)."""
    if model == "AT1":
        return 1.0 - np.where(np.abs(x) <= 4 * l0, (1 - np.abs(x) / (4 * l0)) ** 2, 0.0)
    a = half_length / (2 * l0)
    return 1.0 - np.cosh(a - np.abs(x) / (2 * l0)) / np.cosh(a)


@pytest.mark.parametrize("model", ["AT2", "AT1"])
@pytest.mark.parametrize("division", [4, 8])
def test_crack_profile_within_a_quarter_cell_of_the_exact_one(model, division):
    """The 1D profile across an initial crack at l0 / h = 4 and 8, within
    0.25 h / l0 of the exact one in the max norm over the vertices (issue 49).

    The history lives at the edge midpoints, and the band (half-width h/2)
    holds only the midpoints of the edges on the crack line x = 0: the
    vertices there go to c = 0 and the next ones keep the free profile.
    Measured: 0.012-0.024 times the bound, nearly all of it c(0) = 5e-4 to
    1.2e-3 on the crack line. With the history on the cells, sampled at their
    centroids, the band also held the cells beside the line, so the vertices
    at x = +-h went to c = 0 too: 1.82-1.90 times the bound (the MPM's
    particles, band h/4, are at 0.76-0.79 times on the profile notebook's strip).
    """
    l0 = 0.5
    h = l0 / division
    half = 6 * l0
    sim = FemSimulation(strip_1d(l0, h, model))
    x = sim.vertices[: sim.owned, 0]
    c = sim.c.x.array[: sim.owned]
    error = np.max(np.abs(c - exact_1d(x, l0, model, half)))
    assert error <= 0.25 * h / l0, error
    # The next vertices are free: each within a tenth of the bound.
    beside = np.abs(np.abs(x) - h) < 1e-9
    assert np.max(np.abs(c[beside] - exact_1d(x[beside], l0, model, half))) < 0.025 * h / l0


def test_cellwise_history_is_integrated_exactly():
    """While a cell's three history points agree (no initial crack), the
    midpoint rule integrates the reaction ``(F c, q)`` exactly: the phase-field
    matrix is that of a cell-wise F integrated exactly, to round-off."""
    material = Material(name="m", E=100.0, nu=0.25, density=7.0,
                        fracture=Fracture(Gc=0.01, l0=0.5))
    sim = FemSimulation(plate(material=material))
    cells = len(sim.history)
    rng = np.random.default_rng(7)
    sim.history[:] = rng.uniform(0.0, 1.0, cells)[:, None]
    sim._solve_phase_field()
    W = fem.FunctionSpace(sim.mesh, ("DG", 0))
    F = fem.Function(W)
    F.x.array[W.dofmap.list.array[:cells]] = 4 * 0.5 * sim.history[:, 0] / 0.01 + 1.0  # eq. (49)
    p, q = ufl.TrialFunction(sim.V), ufl.TestFunction(sim.V)
    exact = fem_petsc.assemble_matrix(fem.form(F * p * q * ufl.dx))
    exact.assemble()
    difference = sim._pf._M.copy()
    difference.axpy(-1.0, exact)
    assert difference.norm() <= 1e-14 * exact.norm()
    # The reaction's dof k of a cell sits at the cell's history point k.
    dofs = sim._pf._reaction.function_space.tabulate_dof_coordinates()[:, :2]
    np.testing.assert_allclose(dofs[sim._pf._point_dof], sim._midpoints, rtol=0, atol=1e-12)
    # A cell whose points differ is not integrated as its mean: the rule weighs
    # each point by the basis functions there.
    sim.history[0] = [1.0, 0.0, 0.0]
    sim._solve_phase_field()
    difference = sim._pf._M.copy()
    difference.axpy(-1.0, exact)
    assert difference.norm() > 1e-3 * exact.norm()


def test_crack_band_that_misses_the_mesh_is_refused():
    """A band that holds no edge midpoint would leave the crack out: a one-line error."""
    l0, h = 0.5, 0.125
    with pytest.raises(SceneError) as err:  # midpoints on x = k h / 2; the line is h/4 from them
        FemSimulation(strip_1d(l0, h, "AT2", crack_at=0.25 * h, half_width=0.2 * h))
    assert err.value.path == "cracks[0].half_width"
    assert str(err.value) == ("cracks[0].half_width = 0.025: the crack's band holds no edge"
                              " midpoint of the FEM mesh (h = 0.125), so it would not be imposed:"
                              " widen it or move the crack onto the body")
    # A crack between vertex lines is seeded at the midpoints on both sides of it.
    sim = FemSimulation(strip_1d(l0, h, "AT2", crack_at=0.25 * h, half_width=0.3 * h))
    assert sim.c.x.array[: sim.owned].min() < 0.01

def test_lumped_mass_and_loads_add_up():
    """Lumped mass = rho * area * thickness; tractions and body forces give the exact momentum.

    With the ``left/right`` diagonals every interior vertex has 4 or 8
    triangles, so its mass is 2/3 or 4/3 of rho h^2 thickness.  A free plate
    under constant loads gains momentum (total force) * t whatever the
    internal forces do, since they sum to zero.
    """
    rho, thickness, h = 7.0, 2.5, 0.25
    traction, gravity = (0.3, -0.7), (0.0, -9.81)
    scene = plate(h=h, thickness=thickness,
                  loads=(Traction(body="p", edge="top", traction=traction), BodyForce(gravity)))
    sim = FemSimulation(scene)
    mass = sim.lumped_mass
    total_mass = rho * 3.0 * 2.0 * thickness
    assert mass.sum() == pytest.approx(total_mass, rel=1e-13)
    x = sim.vertices[: sim.owned]
    interior = (x[:, 0] > 1e-9) & (x[:, 0] < 3 - 1e-9) & (x[:, 1] > 1e-9) & (x[:, 1] < 2 - 1e-9)
    ratios = np.unique(np.round(mass[interior] / (rho * h * h * thickness), 12))
    np.testing.assert_allclose(ratios, [2 / 3, 4 / 3], rtol=1e-12)

    force = np.array(traction) * 3.0 * thickness + total_mass * np.array(gravity)
    sim.advance(20)
    e = sim.energies()
    assert e["momentum_x"] == pytest.approx(force[0] * sim.time, rel=1e-10)
    assert e["momentum_y"] == pytest.approx(force[1] * sim.time, rel=1e-10)


def test_fixed_wall_holds_a_block_under_gravity():
    """A block standing on a fixed wall: its base stays put, gravity's work is balanced.

    The wall is the grid's bottom side, which the block touches; the top
    edge sinks on average, the block does not fall, and kinetic + elastic
    energy equals the work of gravity within 3 % (the wall does no work; the
    mismatch is the O(dt) offset of velocities taken at half steps, 1.5 %
    here and 6 % at h = 0.25).
    """
    material = Material(name="m", E=100.0, nu=0.25, density=7.0)
    scene = Scene(grid=Grid(size=(3.0, 3.0), h=0.0625, origin=(-0.5, 0.0)), time=Time(end=1.0),
                  materials=(material,), bodies=(Body(name="b", material="m",
                                                      shape=Rectangle((0.0, 0.0), (2.0, 1.0))),),
                  loads=(BodyForce((0.0, -9.81)),), walls=(Wall(side="bottom", type="fixed"),))
    sim = FemSimulation(scene)
    x = sim.vertices[: sim.owned]
    base, top = x[:, 1] < 1e-9, x[:, 1] > 1 - 1e-9
    sag = []
    while sim.step < scene.steps():
        sim.advance(1)
        sag.append(sim.displacement[: sim.owned][top, 1].mean())
    assert np.all(sim.displacement[: sim.owned][base] == 0.0)
    assert np.mean(sag) < 0  # it oscillates about the static sag
    mass = 7.0 * 2.0 * 1.0
    assert abs(sim.energies()["momentum_y"]) < 0.1 * mass * 9.81 * sim.time  # no free fall
    e = sim.energies()
    assert e["external_work"] > 0
    assert abs(e["total"]) < 0.03 * e["external_work"]


def test_p_wave_from_a_traction_step_arrives_on_time():
    """A column between slip walls pulled on its top edge: a 1D P-wave.

    Uniaxial strain, so the front moves at the plane-strain c_p and the
    material behind it at sigma / (rho c_p).  Half the plateau velocity
    must reach depth D within 2 h / c_p of D / c_p; the mean velocity there
    until the bottom reflection returns must be the plateau within 3 %;
    and kinetic + elastic energy must equal the work of the traction within
    1 %.
    """
    h, width, height, depth, sigma = 0.1, 2.0, 20.0, 10.0, 1.0
    material = Material(name="m", E=100.0, nu=0.25, density=1.0)
    cp = wave_speed(100.0, 0.25, 1.0, "strain")
    end = (2 * height - depth) / cp * 0.9  # before the reflection from the bottom is back
    scene = Scene(
        grid=Grid(size=(width, height + 1.0), h=h, origin=(0.0, -0.5)), time=Time(end=end),
        materials=(material,), thickness=1.5,
        bodies=(Body(name="col", material="m", particles_per_cell=1,
                     shape=Rectangle((0.0, 0.0), (width, height))),),
        loads=(Traction(body="col", edge="top", traction=(0.0, sigma)),),
        walls=(Wall(side="left", type="slip"), Wall(side="right", type="slip")),
    )
    sim = FemSimulation(scene)
    x = sim.vertices[: sim.owned]
    line = np.abs(x[:, 1] - (height - depth)) < 1e-9
    t, v, balance = [], [], []
    while sim.step < scene.steps():
        sim.advance(1)
        e = sim.energies()
        t.append(sim.time)
        v.append(sim.velocity[line, 1].mean())
        balance.append(abs(e["total"]) / e["external_work"])
    t, v = np.array(t), np.array(v)
    plateau = sigma / (1.0 * cp)
    arrival = t[np.argmax(v >= 0.5 * plateau)]
    assert abs(arrival - depth / cp) < 2 * h / cp
    behind = t > depth / cp + 30 * h / cp
    assert v[behind].mean() == pytest.approx(plateau, rel=0.03)
    assert np.all(np.abs(sim.velocity[:, 0][np.abs(x[:, 0]) < 1e-9]) == 0.0)  # slip wall
    assert max(balance[len(balance) // 2:]) < 0.01


def test_non_finite_energy_stops_the_run_and_keeps_the_output(tmp_path):
    """A NaN force: the run fails naming the step and time, with the output so far intact."""
    scene = plate(output=Output(every=5, energies_every=1),
                  loads=(Traction(body="p", edge="top", traction=(0.0, 1.0)),))
    sim = FemSimulation(scene)
    sim.external_force[0, 1] = np.nan
    result = sim.run(tmp_path, progress=False)
    assert result.status == "failed"
    assert "not finite at step 1 (t = " in result.error
    assert read_csv(tmp_path / "energies.csv")["step"].tolist() == [0.0]
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert (summary["method"], summary["status"], summary["steps"]) == ("fem", "failed", 1)
    assert (tmp_path / "fields.xdmf").exists()


@pytest.mark.parametrize("change, path", [
    ({"shape": Disk((1.0, 1.0), 0.8)}, "bodies[0].shape"),
    ({"shape": Rectangle((0.0, 0.0), (3.0, 1.9))}, "bodies[0].shape"),
    ({"holes": (Disk((1.0, 1.0), 0.3),)}, "bodies[0].holes"),
])
def test_unsupported_scenes_are_named(change, path):
    body = Body(**{"name": "p", "material": "m", "shape": Rectangle((0.0, 0.0), (3.0, 2.0)), **change})
    with pytest.raises(SceneError) as err:
        FemSimulation(plate(bodies=(body,)))
    assert err.value.path == path
    assert "FEM" in str(err.value)


def test_finite_strain_and_damage_models_are_refused():
    # The FEM path is small-strain linear elasticity: a neo-Hookean material,
    # with or without damage, is refused by one line naming its key.
    for damage in (None, RankineSpec(sigma_f=1.0, Gf=1.0)):
        material = NeoHookeanSpec(name="m", E=100.0, nu=0.25, density=7.0, damage=damage)
        with pytest.raises(SceneError) as err:
            FemSimulation(plate(material=material))
        assert str(err.value) == ("materials[0].model = 'neo_hookean': the FEM path solves"
                                  " small-strain linear elasticity only")


def test_two_bodies_are_refused():
    bodies = (Body(name="a", material="m", shape=Rectangle((0.0, 0.0), (1.0, 1.0))),
              Body(name="b", material="m", shape=Rectangle((2.0, 0.0), (3.0, 1.0))))
    with pytest.raises(SceneError, match="^bodies: the FEM path needs exactly one body"):
        FemSimulation(plate(bodies=bodies))


def _mpirun() -> list[str]:
    """``mpirun -n 2`` with the flags this MPI and this user need."""
    exe = shutil.which("mpirun")
    if exe is None:
        pytest.fail("mpirun not found: tools/setup.sh installs openmpi-bin for the FEM path")
    version = subprocess.run([exe, "--version"], capture_output=True, text=True).stdout
    cmd = [exe, "-n", "2"]
    if "Open MPI" in version or "OpenRTE" in version:
        cmd.append("--oversubscribe")
    return cmd


def xdmf_fields(out: Path) -> dict:
    """Each field of a FEM run's ``fields.xdmf``: its times, the points it lives
    on (vertices, or cell centres for cell fields) and its values (times, points, components)."""
    import h5py
    from xml.etree import ElementTree

    grids = ElementTree.parse(out / "fields.xdmf").getroot().find("Domain").findall("Grid")
    mesh = next(g for g in grids if g.get("GridType") == "Uniform")
    with h5py.File(out / "fields.h5", "r") as f:
        read = lambda item: f[item.text.strip().split(":")[1]][()]  # noqa: E731
        xy = read(mesh.find("Geometry/DataItem"))[:, :2]
        centres = xy[read(mesh.find("Topology/DataItem"))].mean(axis=1)
        fields = {}
        for grid in grids:
            if grid.get("CollectionType") != "Temporal":
                continue
            steps = grid.findall("Grid")
            cell = steps[0].find("Attribute").get("Center") == "Cell"
            values = np.array([read(step.find("Attribute/DataItem")) for step in steps])
            fields[grid.get("Name")] = ([float(step.find("Time").get("Value")) for step in steps],
                                        centres if cell else xy, values)
    return fields


@pytest.mark.parametrize("model, end", [("AT2", 4.2), ("AT1", 16.0)])
def test_two_ranks_reproduce_one(tmp_path, model, end):
    """``mpirun -n 2 python -m pfmpm.fem`` gives the serial energies to 1e-8.

    The Borden plate at h = 0.5, l0 = 1: AT2 for 70 steps (the wave reaches
    the notch and the history grows there), AT1 for 265 (its bounded solve,
    PETSc's vinewtonrsls, through the crack's start at about 12 us).
    Energies are compared relative to the largest value of their column,
    momentum relative to sqrt(2 M K) (it is zero up to round-off by
    symmetry), the tip to the plate size.
    """
    env = dict(os.environ, OMP_NUM_THREADS="1")
    if os.geteuid() == 0:
        env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    # The solves to 1e-10: the ranks' partial sums reach the Krylov and Newton
    # iterates in another order, so the runs agree to the solver tolerance
    # (at the default 1e-6, 1.7e-8 of the fracture energy was seen once).
    sets = ["grid.h=0.5", "materials.concrete.fracture.l0=1.0", f"time.end={end}",
            "output.energies_every=1", "output.every=20", "output.snapshots=[]",
            f"materials.concrete.fracture.model={model}", "phase_field.tol=1e-10"]
    args = ["-m", "pfmpm.fem", str(DEMOS / "borden_plate.toml"), "--quiet"]
    args += [item for s in sets for item in ("--set", s)]
    runs = {"serial": [sys.executable], "mpi": _mpirun() + [sys.executable]}
    energies, fields = {}, {}
    for name, launcher in runs.items():
        out = tmp_path / name
        proc = subprocess.run(launcher + args + ["--out", str(out)], env=env, capture_output=True,
                              text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr[-2000:]
        summary = json.loads((out / "summary.json").read_text())
        assert summary["status"] == "completed"
        assert summary["ranks"] == (1 if name == "serial" else 2)
        assert summary["substeps"] == 1  # the MPM step 0.8 x 0.577 h/c_p is below the P1 limit
        energies[name] = read_csv(out / "energies.csv")
        fields[name] = xdmf_fields(out)
    serial, mpi = energies["serial"], energies["mpi"]
    assert len(serial["step"]) == {"AT2": 71, "AT1": 266}[model]
    assert serial["fracture"][-1] > serial["fracture"][0]  # the history grew near the notch
    for key in ("kinetic", "elastic", "fracture", "external_work", "total"):
        scale = np.max(np.abs(serial[key]))
        np.testing.assert_allclose(mpi[key], serial[key], rtol=0, atol=1e-8 * scale, err_msg=key)
    scale = math.sqrt(2 * 2450.0 * 100.0 * 40.0 * np.max(serial["kinetic"]))
    for key in ("momentum_x", "momentum_y"):
        np.testing.assert_allclose(mpi[key], serial[key], rtol=0, atol=1e-8 * scale, err_msg=key)
    for key in ("crack_tip_x", "crack_tip_y"):
        np.testing.assert_allclose(mpi[key], serial[key], rtol=0, atol=1e-8 * 100.0, err_msg=key)
    # The frames (issue 21, defect 9): every 20 steps and at the end, in both
    # runs, each field of fields.xdmf at the same points, the vertices or the
    # cell centres.
    assert fields["serial"].keys() == fields["mpi"].keys() == {
        "c", "displacement", "velocity", "stress", "stress_zz", "history"}
    last = len(serial["t"]) - 1
    frame_times = [serial["t"][k] for k in sorted(set(range(0, last, 20)) | {last})]
    assert len(frame_times) == {"AT2": 5, "AT1": 15}[model]
    for key, (times, xy, values) in fields["serial"].items():
        other_times, other_xy, other_values = fields["mpi"][key]
        assert times == other_times == pytest.approx(frame_times, abs=1e-12)
        mine, theirs = np.lexsort(xy.T[::-1]), np.lexsort(other_xy.T[::-1])
        np.testing.assert_allclose(other_xy[theirs], xy[mine], rtol=0, atol=1e-12)
        scale = np.max(np.abs(values))
        assert scale > 0, key
        np.testing.assert_allclose(other_values[:, theirs], values[:, mine], rtol=0, atol=1e-8 * scale,
                                   err_msg=key)
    (_, _, u), (_, _, sigma) = fields["serial"]["displacement"], fields["serial"]["stress"]
    assert u.shape[2] == 3 and sigma.shape[2] == 9
    np.testing.assert_array_equal(sigma[..., [2, 5, 6, 7, 8]], 0.0)  # in-plane, padded
    np.testing.assert_array_equal(sigma[..., 1], sigma[..., 3])  # symmetric
    # Plane strain, nu = 0.2: sigma_zz = nu (sigma_xx + sigma_yy) where intact (AT2's c
    # is a little below 1 everywhere, so not to round-off), at 4.2 us (the third
    # frame, before either model's crack starts).
    zz, trace = fields["serial"]["stress_zz"][2][2, :, 0], sigma[2, :, 0] + sigma[2, :, 4]
    np.testing.assert_allclose(zz, 0.2 * trace, rtol=0.05, atol=1e-3 * np.abs(trace).max())
    # Energy balance of the run: the work goes into kinetic, elastic and fracture energy.
    growth = serial["total"] - serial["total"][0]
    assert np.max(np.abs(growth)) < 0.02 * serial["external_work"][-1]
