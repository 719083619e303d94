"""Input hardening: generated scene files, valid and invalid, either run or
fail with a one-line error naming the offending key.

Each example is a small scene written as a TOML file (grid of at most 8 x 8
cells, a few particles per cell, a few steps), optionally with one mutation:
a value replaced by one of the wrong type or out of range, a key deleted, an
unknown key added. The file is loaded as ``pfmpm run`` loads it; a valid one
is set up on the C++ core and stepped. Whatever the file, the outcome is one
of: a run, a :class:`~pfmpm.SceneError` (one line, naming the mutated key),
or a :class:`~pfmpm.SimulationError` from the run (one line). Any other
exception, and any crash of the process, fails the test.
"""

import json
import math
import os
import re
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from pfmpm import Scene, SceneError, Simulation, SimulationError
from pfmpm.cli import main
from pfmpm.scene import CRITICAL_FACTOR, SIDES, SPLITS, wave_speed

FUZZ = settings(deadline=None, database=None, suppress_health_check=list(HealthCheck))
"""Settings shared by the generators here: no deadline (a run takes a few
ms, but the machine is shared), no example database left in the tree."""

BAD_VALUES = [-1, 0, -0.0, 1e-300, 1e300, 2**62, -(2**62), math.nan, math.inf, -math.inf, "", "x",
              True, False, [], [1.0], [1.0, 2.0, 3.0], ["a", "b"], [[1.0, 2.0], [3.0]], {}, {"a": 1}]
"""Replacement values of a mutation: wrong types, empty and nested lists,
non-finite, zero, negative, tiny and huge numbers."""
NUMBERS = st.floats() | st.integers(-(2**63), 2**63 - 1)
"""Any TOML number."""


# -- a minimal TOML writer: inline tables and arrays are enough for any scene --

def toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):  # JSON escapes all TOML needs escaped but DEL
        return json.dumps(v, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return "{" + ", ".join(f"{toml_key(k)} = {toml_value(x)}" for k, x in v.items()) + "}"


def toml_key(k):
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else toml_value(k)


def to_toml(d):
    return "".join(f"{toml_key(k)} = {toml_value(v)}\n" for k, v in d.items())


# -- generators ---------------------------------------------------------------

def coordinate(draw, lo, hi, h):
    """A coordinate on the quarter-cell lattice in [lo, hi]."""
    n = int(round((hi - lo) / (0.25 * h)))
    return lo + 0.25 * h * draw(st.integers(0, n))


@st.composite
def valid_ish_scenes(draw):
    """A small scene dict, mostly valid (bodies may stick out of the grid)."""
    h = draw(st.sampled_from([0.5, 1.0, 2.0]))
    degree = draw(st.integers(1, 3))
    nx, ny = draw(st.integers(degree, 8)), draw(st.integers(degree, 8))
    origin = [draw(st.sampled_from([0.0, -1.0, 2.5])), draw(st.sampled_from([0.0, -3.0]))]
    x0, y0, x1, y1 = origin[0], origin[1], origin[0] + nx * h, origin[1] + ny * h
    plane = draw(st.sampled_from(["strain", "stress"]))
    E = draw(st.sampled_from([1.0, 100.0, 3.2e4]))
    nu = draw(st.sampled_from([0.0, 0.2, 0.3, 0.45]))
    density = draw(st.sampled_from([1.0, 2450.0]))
    material = {"name": "m", "E": E, "nu": nu, "density": density}
    cracks = draw(st.booleans())
    if cracks:
        material["fracture"] = {"Gc": draw(st.sampled_from([1e-3, 1.0])), "l0": draw(st.sampled_from([h, 2 * h])),
                                "k_f": draw(st.sampled_from([0.0, 1e-6])), "split": draw(st.sampled_from(SPLITS))}
    # Mostly inside the grid; one body in five may stick out of it.
    m = h if draw(st.integers(0, 4)) == 0 else 0.0
    if draw(st.booleans()):
        bx0 = coordinate(draw, x0 - m, x1 - 0.25 * h, h)
        by0 = coordinate(draw, y0 - m, y1 - 0.25 * h, h)
        shape = {"type": "rectangle", "min": [bx0, by0],
                 "max": [coordinate(draw, bx0 + 0.25 * h, x1 + m, h), coordinate(draw, by0 + 0.25 * h, y1 + m, h)]}
    else:
        r = min(draw(st.sampled_from([0.3, 0.5, 1.0])), 0.5 * min(nx, ny)) * h
        shape = {"type": "disk", "center": [coordinate(draw, x0 + r - m, x1 - r + m, h),
                                            coordinate(draw, y0 + r - m, y1 - r + m, h)], "radius": r}
    speed = draw(st.sampled_from([0.0, 0.1, 1.0]))
    body = {"name": "b", "material": "m", "shape": shape,
            "particles_per_cell": draw(st.integers(1, 3)), "velocity": [speed, -speed]}
    c = wave_speed(E, nu, density, plane)
    cfl = draw(st.sampled_from([0.3, 0.8, 1.0]))
    limit = cfl * min(CRITICAL_FACTOR[degree]) * h / (c + math.hypot(speed, speed))
    d = {
        "name": draw(st.sampled_from(["fuzz", "a b", "ü"])),
        "plane": plane,
        "grid": {"size": [nx * h, ny * h], "h": h, "degree": degree, "origin": origin},
        "time": {"end": draw(st.sampled_from([1.0, 2.5, 4.0])) * limit, "cfl": cfl},
        "output": {"every": draw(st.integers(1, 3)), "energies_every": draw(st.integers(1, 2)),
                   "particles": False},
        "materials": [material],
        "bodies": [body],
    }
    if draw(st.booleans()):
        d["walls"] = [{"side": s, "type": draw(st.sampled_from(["fixed", "slip"]))}
                      for s in draw(st.lists(st.sampled_from(SIDES), max_size=2, unique=True))]
    loads = []
    if draw(st.booleans()):
        loads.append({"type": "traction", "body": "b", "edge": draw(st.sampled_from(SIDES)),
                      "traction": [draw(st.sampled_from([0.0, 1.0])), -1.0]})
    if draw(st.booleans()):
        loads.append({"type": "body_force", "acceleration": [0.0, -9.81]})
    if loads:
        d["loads"] = loads
    if cracks and draw(st.booleans()):
        y = coordinate(draw, y0, y1, h)
        d["cracks"] = [{"points": [[x0, y], [coordinate(draw, x0 + 0.25 * h, x1, h), y]], "B": 1000.0}]
    if draw(st.booleans()):
        d["phase_field"] = {"tol": draw(st.sampled_from([1e-6, 1e-3])), "max_iterations": draw(st.sampled_from([1, 1000]))}
    return d


def paths(node, prefix=""):
    """(path, parent, key) of every entry of nested dicts and lists, in scene-error notation."""
    items = node.items() if isinstance(node, dict) else enumerate(node)
    for key, value in items:
        path = f"{prefix}[{key}]" if isinstance(key, int) else f"{prefix}.{key}" if prefix else key
        yield path, node, key
        if isinstance(value, (dict, list)):
            yield from paths(value, path)


def kind_of(value):
    """The TOML type class of a value: numbers are one class."""
    if isinstance(value, bool):
        return "bool"
    if isinstance(value, (int, float)):
        return "number"
    return type(value).__name__


@st.composite
def scene_files(draw):
    """(TOML text, mutated key path, what must be named).

    The path is None for an unmutated scene. The last item says how exact an
    error must be: "exact" (the value has the wrong type or is not finite, or
    a key is misspelt: the message must name that key), "any" (the base scene
    did not fit, or the new value clashes with another: any key path).
    """
    d = draw(valid_ish_scenes())
    try:
        Scene.from_dict(d)
        fits = True
    except SceneError:
        fits = False
    if draw(st.integers(0, 9)) < 3:
        return to_toml(d), None, "any"
    if draw(st.integers(0, 19)) == 0:  # a file cut short: TOML errors name the file
        text = to_toml(d)
        return text[: draw(st.integers(0, len(text) - 1))], None, "any"
    path, parent, key = draw(st.sampled_from(list(paths(d))))
    kind = draw(st.sampled_from(["replace", "replace", "replace", "delete", "unknown"]))
    if kind == "delete":
        del parent[key]
        return to_toml(d), path, "any"
    if kind == "unknown" and isinstance(parent, dict):
        parent[key + "_typo"] = parent[key]
        return to_toml(d), f"{path}_typo", "exact" if fits else "any"
    old, new = parent[key], draw(st.sampled_from(BAD_VALUES) | NUMBERS | st.text(max_size=4))
    parent[key] = new
    exact = kind_of(old) != kind_of(new) or (isinstance(new, float) and not math.isfinite(new))
    return to_toml(d), path, "exact" if exact and fits else "any"


def named(message, path):
    """Whether an error message names ``path`` (quoted segments as the scene prints them)."""
    return path in message or path.replace("ü", "'ü'") in message


KEY_PATH = re.compile(r"^(scene|[A-Za-z_][\w]*(\[\d+\])*(\.[A-Za-z_][\w]*(\[\d+\])*)*)( = |: )")
"""The start of a scene error: the key path, then its value or the reason."""


def particle_bound(scene):
    """An upper bound of the scene's particle count: bounding-box cells times n^2."""
    h = scene.grid.h
    total = 0
    for body in scene.bodies:
        xmin, ymin, xmax, ymax = body.shape.bounds()
        cells = (math.ceil((xmax - xmin) / h) + 1) * (math.ceil((ymax - ymin) / h) + 1)
        total += cells * body.particles_per_cell ** 2
    return total


def check_file(text):
    """Load and run one scene file; return "ran", "scene error" or "run error"."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "scene.toml"
        path.write_text(text, encoding="utf-8")
        try:
            scene = Scene.from_toml(path)
        except SceneError as err:
            return "scene error", str(err)
    # A mutation can leave a valid scene of millions of particles
    # (particles_per_cell = 1000), or of a grid of many GB that fits the
    # machine only alone (grid.size = [1, 1e7]): those are not set up here.
    assume(particle_bound(scene) <= 100_000 and sum(scene.memory_estimate()[:2]) <= 1e9)
    try:
        sim = Simulation(scene)  # solves the phase field of initial cracks
        sim.advance(min(scene.steps(), 3))
    except SimulationError as err:
        return "run error", str(err)
    return "ran", None


@settings(FUZZ, max_examples=1000)
@given(scene_files())
def test_generated_scene_files_run_or_name_the_key(case):
    text, mutated, must = case
    outcome, message = check_file(text)
    if outcome == "ran":
        return
    assert "\n" not in message, message
    if outcome == "run error":
        assert re.search(r"step \d+ \(t = ", message), message
        return
    assert KEY_PATH.match(message) or re.match(r"^/\S*/scene.toml: invalid TOML: ", message), message
    if must == "exact":
        assert named(message, mutated), (mutated, message)


@settings(FUZZ, max_examples=40)
@given(scene_files())
def test_generated_scene_files_through_the_command_line(tmp_path_factory, capsys, case):
    text, _, _ = case
    tmp = tmp_path_factory.mktemp("cli")
    path = tmp / "scene.toml"
    path.write_text(text, encoding="utf-8")
    try:
        # A mutation can leave a valid scene of many steps (time.end = 1e5):
        # those are not run whole here.
        assume(Scene.from_toml(path).steps() <= 50)
    except SceneError:
        pass
    code = main(["run", str(path), "--out", str(tmp / "out"), "--quiet"])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    if code == 2:
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error: "), err
        assert KEY_PATH.match(lines[0][len("error: "):]) or lines[0].startswith(f"error: {path}"), err
    elif code == 1:
        assert err.startswith("error: ") and "step" in err.splitlines()[0], err
    else:
        assert code == 0, err
        assert json.loads((tmp / "out" / "summary.json").read_text())["status"] == "completed"


def test_the_generator_covers_valid_and_invalid_scenes():
    # Deterministic over the first examples: both outcomes occur, and runs
    # happen on every degree.
    seen = {"ran": set(), "scene error": 0}

    @settings(FUZZ, max_examples=150, derandomize=True)
    @given(scene_files())
    def collect(case):
        outcome, _ = check_file(case[0])
        if outcome == "ran":
            seen["ran"].add(Scene.from_dict(tomllib.loads(case[0])).grid.degree)
        elif outcome == "scene error":
            seen["scene error"] += 1

    collect()
    assert seen["ran"] == {1, 2, 3} and seen["scene error"] >= 30


TINY = {
    "grid": {"size": [4.0, 4.0], "h": 1.0, "degree": 2},
    "time": {"end": 0.05},
    "output": {"particles": False},
    "materials": [{"name": "m", "E": 100.0, "nu": 0.3, "density": 1.0,
                   "fracture": {"Gc": 1.0, "l0": 1.0}}],
    "bodies": [{"name": "b", "material": "m", "particles_per_cell": 2,
                "shape": {"type": "rectangle", "min": [1.0, 1.0], "max": [3.0, 3.0]}}],
}


def tiny(**changes):
    """TINY with entries replaced: ``grid__size=[...]`` sets ``grid.size``."""
    d = json.loads(json.dumps(TINY))
    for key, value in changes.items():
        *parents, last = key.split("__")
        node = d
        for part in parents:
            node = node[int(part)] if part.isdigit() else node[part]
        node[last] = value
    return d


@pytest.mark.parametrize("d, message", [
    # Each of these once reached the C++ core or numpy and raised there.
    (tiny(grid__size=[1.0, 4.0]), "grid.size = [1.0, 4.0]: 1 x 4 cells of h = 1: degree 2 B-splines need at least 2 cells a side"),
    ({**TINY, "cracks": [{"points": [[1.0, 2.0], [1.0, 2.0]]}]}, "cracks[0].points[1] = [1.0, 2.0]: segment from points[0]"),
    ({**TINY, "cracks": [{"points": [[1e300, 2.0], [2.0, 2.0]]}]}, "cracks[0].points[0] = [1e+300, 2.0]: lies farther from the grid"),
    ({**TINY, "phase_field": {"max_iterations": 2**62}}, "phase_field.max_iterations = 4611686018427387904: must be <= 2147483647"),
    # Within the int32 cell limit, but over 300 GB of grid storage.
    (tiny(grid__size=[2147483000.0, 1.0], grid__degree=1, bodies__0__shape__min=[0.0, 0.0],
          bodies__0__shape__max=[1.0, 1.0]), "grid.size: 2147483000 x 1 cells and up to 4 particles need about"),
], ids=["cells-below-degree", "zero-length-crack-segment", "crack-point-far-away", "max-iterations-overflow",
        "grid-beyond-memory"])
def test_holes_the_generator_found(tmp_path, d, message):
    path = tmp_path / "scene.toml"
    path.write_text(to_toml(d))
    outcome, text = check_file(path.read_text())
    assert outcome == "scene error" and text.startswith(message), text


_PEAK = """
import os, sys
from pfmpm.scene import Scene
from pfmpm.simulation import Simulation

def resident():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")

scene = Scene.from_toml(sys.argv[1])
before = resident()
sim = Simulation(scene)
sim.advance(1)
print(resident() - before, sum(scene.memory_estimate()[:2]))
"""
"""What a run adds to the resident memory of a fresh process (the imports'
transient peak, which ``ru_maxrss`` would report, left out), and the
scene's estimate."""


@pytest.mark.parametrize("cracks", [False, True])
def test_the_memory_estimate_bounds_a_tall_grids_peak(tmp_path, cracks):
    """A grid of 2 x 1.5e6 cells with one small body (the generator's
    grid.size = [1, 1e7] once passed the check at 16.8 GB and took more than
    the machine's 24 GB): what a run adds to the resident memory of the
    process stays below the scene's estimate, with and without a phase field.
    The numbers are in the test's comment."""
    d = tiny(grid__size=[2.0, 1.5e6], bodies__0__shape__max=[2.0, 3.0], bodies__0__shape__min=[1.0, 1.0])
    if not cracks:
        del d["materials"][0]["fracture"]
    path = tmp_path / "scene.toml"
    path.write_text(to_toml(d))
    done = subprocess.run([sys.executable, "-c", _PEAK, str(path)], capture_output=True, text=True,
                          env={**os.environ, "OMP_NUM_THREADS": "1"})
    assert done.returncode == 0, done.stderr
    # Measured 2026-12-07: 0.27 and 1.92 GB against estimates of 0.53 and
    # 2.37 GB; the estimate before this test gave 1.45 GB with the phase field.
    peak, estimate = map(float, done.stdout.split())
    assert peak > 0.1e9  # the grid's storage, not the interpreter's
    assert estimate >= peak, (peak, estimate)


def test_failed_initial_phase_field_is_an_error_line(tmp_path, capsys):
    # One CG iteration cannot solve the phase field of the initial crack (nor
    # one MPRGP iteration, which the bounded solve hands it to): the run fails
    # before its first step, with an error line, not a traceback.
    d = {**TINY, "cracks": [{"points": [[0.0, 2.0], [2.0, 2.0]]}], "phase_field": {"max_iterations": 1}}
    path = tmp_path / "scene.toml"
    path.write_text(to_toml(d))
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: phase field: the bounded solve (MPRGP after the"
                                               " active-set passes) stopped at relative residual"), err
