"""What the figures of a run show: labelled axes with the scene's units, the
phase field without holes inside the body, the crack path, the animation.

Each PNG a run writes is caught as it is saved (``figures`` below), so its
axes, labels and image data can be read.
"""

import math

import numpy as np
import pytest
from matplotlib.figure import Figure
from PIL import Image

from pfmpm import Scene, Simulation, scenes
from pfmpm.animate import animate
from pfmpm.plots import PHASE_FIELD_LABEL
from pfmpm.observe import CRACK_PATH, Snapshots, read_crack_path
from pfmpm.scene import Body, Grid, Material, Rectangle, Time
from pfmpm.scene.units import NO_UNITS, UNIT_SYSTEMS

BORDEN_SMOKE = ["grid.h=1.0", "materials.concrete.fracture.l0=2.0", "bodies.plate.particles_per_cell=2",
                "time.end=12", "output.snapshots=[0.0, 12.0]", "output.every=30", "output.energies_every=5"]


def catch_figures(monkeypatch) -> dict:
    """Catch the figures saved from now on, by file name: each a dict of its
    axes' labels and titles, its images and the figure itself."""
    saved = {}
    original = Figure.savefig

    def catch(fig, path, *args, **kwargs):
        fig.canvas.draw()
        saved[str(path).rsplit("/", 1)[-1]] = {
            "figure": fig,
            "axes": [(ax.get_xlabel(), ax.get_ylabel(), ax.get_title()) for ax in fig.axes],
            "images": [(im.get_array(), im.get_extent()) for ax in fig.axes for im in ax.get_images()],
        }
        return original(fig, path, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", catch)
    return saved


@pytest.fixture
def figures(monkeypatch):
    """The figures saved while the test runs (:func:`catch_figures`)."""
    return catch_figures(monkeypatch)


@pytest.fixture(scope="module")
def borden_run(tmp_path_factory):
    """A short Borden plate run (h = 1, 12 us): its scene, output directory,
    simulation and the figures it saved."""
    out = tmp_path_factory.mktemp("borden")
    scene = Scene.from_toml(scenes.path("borden_plate"), BORDEN_SMOKE)
    sim = Simulation(scene)
    with pytest.MonkeyPatch.context() as monkeypatch:
        saved = catch_figures(monkeypatch)
        assert sim.run(out, progress=False).status == "completed"
    return scene, out, sim, saved


def test_binning_left_holes_that_the_nearest_particle_fills():
    """Issue 21, defect 4: points of spacing s stretched by 3 % about the
    body's centre (up to 1 s at its edges), drawn at one pixel per spacing.
    Binning points into pixels left lines of empty pixels inside the body
    wherever the stretch had added half a spacing (the white lines of the
    main job's figure); the nearest point within one spacing leaves none, and
    fills none outside the stretched outline grown by one spacing."""
    scene = Scene(grid=Grid(size=(20.0, 10.0), h=1.0), time=Time(end=1.0),
                  materials=(Material("m", 1.0, 0.2, 1.0),),
                  bodies=(Body("b", "m", Rectangle((2.0, 2.0), (18.0, 8.0)), particles_per_cell=4),))
    spacing = 0.25
    xy = scene.particles()["x"]
    moved = (10.0, 5.0) + 1.03 * (xy - (10.0, 5.0))
    snapshots = Snapshots(scene, spacing, (0.0, 0.0), (80, 40), reach=spacing)
    image = snapshots.rasterize(moved, np.linspace(0.0, 1.0, len(xy)))
    centres = (np.arange(80) + 0.5) * spacing, (np.arange(40) + 0.5) * spacing
    x, y = np.meshgrid(*centres)
    x0, y0 = (10.0, 5.0) - 1.03 * np.array([8.0, 3.0])
    x1, y1 = (10.0, 5.0) + 1.03 * np.array([8.0, 3.0])
    inside = (x > x0) & (x < x1) & (y > y0) & (y < y1)
    outside = (x < x0 - spacing) | (x > x1 + spacing) | (y < y0 - spacing) | (y > y1 + spacing)
    assert not np.isnan(image[inside]).any()
    assert np.isnan(image[outside]).all()
    # Binning the same points, as before: empty pixels inside.
    ij = np.floor(moved / spacing).astype(int)
    filled = np.zeros((40, 80), dtype=bool)
    filled[ij[:, 1], ij[:, 0]] = True
    assert (~filled[inside]).mean() > 0.02


def test_run_figures_have_units_and_the_phase_field_no_holes(borden_run):
    """Issue 21, defects 4 and 5: every axis of a run's figures carries the
    scene's units, the phase-field panels and colour bar are labelled, the
    balance curve is named for what it is, and the phase field has a value
    at every pixel inside the plate."""
    scene, _, _, figures = borden_run
    assert {"energies.png", "crack_tip.png", "crack_path.png", "phase_field.png"} <= figures.keys()
    for name in ("energies.png", "crack_tip.png", "crack_path.png"):
        for xlabel, ylabel, _ in figures[name]["axes"]:
            if xlabel:  # the colour bar of the crack path has its label on y
                assert xlabel.endswith(("[µs]", "[mm]")), (name, xlabel)
            assert ylabel.endswith(("[N mm]", "[mm]", "[mm/µs]", "[µs]")), (name, ylabel)
    energies = figures["energies.png"]["figure"].axes[0]
    labels = [line.get_label() for line in energies.get_lines()]
    assert "total" not in labels and any(label.startswith("balance residual") for label in labels)
    panels = figures["phase_field.png"]
    *images, colourbar = panels["axes"]
    assert colourbar[1] == PHASE_FIELD_LABEL
    for xlabel, ylabel, title in images:
        assert (xlabel, ylabel) == ("x [mm]", "y [mm]") and title.startswith("phase field c at t = ")
    (x0, y0, x1, y1) = scene.bodies[0].shape.bounds()
    for image, (left, right, bottom, top) in panels["images"]:
        ny, nx = image.shape
        px, py = (right - left) / nx, (top - bottom) / ny
        cx, cy = np.meshgrid(left + (np.arange(nx) + 0.5) * px, bottom + (np.arange(ny) + 0.5) * py)
        inside = (cx > x0) & (cx < x1) & (cy > y0) & (cy < y1)
        values = np.ma.filled(image, np.nan)
        assert inside.sum() > 1000 and not np.isnan(values[inside]).any()
        assert np.nanmin(values) < 0.05 and np.nanmax(values) <= 1.0  # the notch, intact plate


def test_undeclared_units_say_so():
    assert NO_UNITS.label("t", "time") == "t [scene units]"
    mm = UNIT_SYSTEMS["mm-us-MPa"]
    assert (mm.label("v", "speed"), mm.label("E", "energy"), mm.density) == ("v [mm/µs]", "E [N mm]", "µg/mm^3")


def test_the_crack_path_plot_shows_the_cracked_points_by_time(borden_run):
    """Issue 21, defect 12: crack_path.png draws the cracked particles, each
    coloured by when it cracked (the notch at t = 0), in x-y."""
    _, out, sim, figures = borden_run
    xy, times = read_crack_path(out / CRACK_PATH)  # the cracked particles only
    assert len(xy) == len(times) and np.isfinite(times).all()
    # The notch (50 mm along y = 20, the history of B = 1000) cracks at t = 0:
    # every particle along it is there, with time 0.
    notch = lambda x: (np.abs(x[:, 1] - 20.0) < 0.5) & (x[:, 0] < 49.0)  # noqa: E731
    on_notch = notch(xy)
    assert on_notch.sum() == notch(sim.particles.x).sum() > 0
    assert np.all(times[on_notch] == 0.0)
    assert not (np.abs(xy[:, 1] - 20.0) > 6.0).any()
    fig = figures["crack_path.png"]["figure"]
    dots = fig.axes[0].collections[0]
    assert len(dots.get_offsets()) == len(times)
    assert fig.axes[1].get_ylabel() == "time cracked [µs]"


def test_animate_writes_a_frame_per_snapshot(borden_run, tmp_path, monkeypatch):
    """``pfmpm animate``: a GIF with one frame per particle snapshot, its axes
    and colour bar labelled with the run's units."""
    _, out, _, _ = borden_run
    path = animate(out, tmp_path / "c.gif")
    frames = sorted(out.glob("particles_*.vtu"))
    with Image.open(path) as gif:
        assert gif.n_frames == len(frames) >= 3
    saved = catch_figures(monkeypatch)  # each frame is a savefig
    animate(out, tmp_path / "u.gif", field="displacement")
    (x_label, y_label, title), (_, colour_label, _) = next(iter(saved.values()))["axes"]  # the first
    assert (x_label, y_label, colour_label) == ("x [mm]", "y [mm]", "|displacement| [mm]")
    assert title == "displacement at t = 0 µs"
    with pytest.raises(KeyError, match="no field 'nope'"):
        animate(out, tmp_path / "x.gif", field="nope")
    with pytest.raises(ValueError, match="gif"):
        animate(out, tmp_path / "x.avi")


def test_speed_vs_error_labels_of_equal_h_do_not_overlap(figures, tmp_path):
    """Issue 21, defect 6: the two methods' labels of the same h sit on
    opposite sides of their points, even where the points coincide."""
    from pfmpm.compare import _plot_speed_vs_error, reference

    rows = [{"method": m, "h": h, "wall_s": w, "error": e}
            for m in ("mpm", "fem") for h, w, e in ((0.5, 10.0, 0.1), (0.25, 60.0, 0.04))]
    _plot_speed_vs_error(rows, reference({0.5: 1.0, 0.25: 0.9}), tmp_path / "s.png")
    fig = figures["s.png"]["figure"]
    renderer = fig.canvas.get_renderer()
    texts = [t for t in fig.axes[0].texts if t.get_text().startswith("h = ")]
    assert len(texts) == 4
    boxes = [t.get_window_extent(renderer) for t in texts]
    for i in range(4):
        for j in range(i + 1, 4):
            assert not boxes[i].overlaps(boxes[j]), (texts[i].get_text(), texts[j].get_text())
    assert "Richardson" in figures["s.png"]["axes"][0][2]
    assert math.isclose(reference({0.5: 1.0, 0.25: 0.9})["value"], 0.9 - 0.1 / 3)


def test_comparison_overlays_carry_the_scene_units(figures, tmp_path):
    """Issue 21, defect 5: the comparison's overlays had no unit on any axis."""
    from pfmpm.compare import _plot_overlay

    t = np.linspace(0.0, 2.0, 5)
    runs = {(m, 0.5): {"energies": {"t": t, "elastic": t, "fracture": t, "crack_tip_x": t,
                                    "crack_tip_speed": t}} for m in ("mpm", "fem")}
    mm = UNIT_SYSTEMS["mm-us-MPa"]
    _plot_overlay(runs, [0.5], (("elastic", "elastic energy", "energy"), ("fracture", "fracture energy", "energy")),
                  tmp_path / "e.png", mm)
    _plot_overlay(runs, [0.5], (("crack_tip_x", "crack tip x", "length"),
                                ("crack_tip_speed", "crack tip speed", "speed")), tmp_path / "v.png", mm)
    assert figures["e.png"]["axes"] == [("", "elastic energy [N mm]", ""),
                                        ("time t [µs]", "fracture energy [N mm]", "")]
    assert figures["v.png"]["axes"] == [("", "crack tip x [mm]", ""),
                                        ("time t [µs]", "crack tip speed [mm/µs]", "")]


def test_polar_plots_keep_their_scale_off_the_curves_and_say_what_theta_is(figures, tmp_path):
    """The notebook figure pass: the radial tick labels lay on the curves, and
    nothing said whether theta is the crack's direction or its normal."""
    from pfmpm.anisotropy import THETA_CONVENTION, plot_polar, polar_table

    table = polar_table([[1, 0, 0], [0, 80, 0], [0, 0, 74]], 0.002121, 30.0)
    plot_polar(table, tmp_path / "polar.png")
    fig = figures["polar.png"]["figure"]
    assert THETA_CONVENTION in [t.get_text() for t in fig.texts]
    for ax, column in zip(fig.axes, (1, 2)):
        assert all(not label.get_text() for label in ax.get_yticklabels())
        assert ax.get_ylim()[1] == pytest.approx(1.1 * table[:, column].max())
        assert f"outer ring {1.1 * table[:, column].max():.3g}" in ax.get_title()
