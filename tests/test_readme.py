"""The README's commands, run as written from a copy of the repository root.

Each command of README.md's shell blocks runs in a directory that mirrors
the repository root (every top-level entry linked, ``out/`` its own), so a
source folder at the root that hid the installed package would break them as
it would for a user.  Long commands get smoke arguments appended (the
benchmark's smoke ``--set``s for a scene, fewer particles for the bench); a
command with no rule here fails the suite, so the README cannot drift from
what is tested.  Commands that share an output folder run in README order as
one test, each such chain in its own mirror, so the workers share them.  ``bash tools/main.sh`` and ``bash tools/test.sh`` are not
run from inside the suite.
"""

import json
import os
import re
import shlex
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def smoke(benchmark: str) -> list[str]:
    """``--set`` arguments of a benchmark's smoke overrides."""
    manifest = tomllib.loads((ROOT / "benchmarks" / benchmark / "benchmark.toml").read_text())
    return [arg for s in manifest["smoke"] for arg in ("--set", s)]


# (pattern of a command, arguments appended to it); None: not run here.
RULES = [
    (r"^bash tools/(main|test)\.sh$", None),
    # tools/setup.sh, then the build of tests/test_docs_site.py.
    (r"^bash tools/docs\.sh$", None),
    (r"pfmpm --version$", []),
    (r"pfmpm compare borden --h ", ["--h", "1.0", "--l0", "2.0", "--end", "0.5", "--set",
                                    "bodies.plate.particles_per_cell=1", "--quiet"]),
    (r"pfmpm compare notched_beam3d --out out/cmp_beam3d$", ["--h", "1.0", "--end", "1", "--quiet"]),
    # The study above is complete: its runs are kept.
    (r"pfmpm compare borden --resume --out out/study$", ["--quiet"]),
    (r"pfmpm animate out/borden$", []),
    (r"pfmpm fem demos/borden_plate\.toml --out out/borden_fem1$",
     ["--set", "grid.h=1.0", "--set", "materials.concrete.fracture.l0=2.0", "--set", "time.end=1", "--quiet"]),
    # PFMPM_SMOKE=1 (set for every command here) makes the notebook short.
    (r"python -m nbconvert --to html --execute docs/notebooks/phase_field_profiles\.ipynb", []),
    (r"pfmpm run demos/borden_plate\.toml --out out/borden$", smoke("borden_plate") + ["--quiet"]),
    # More than 500 steps, so that the checkpoint the next command resumes from is written.
    (r"pfmpm run demos/borden_plate\.toml --out out/borden --checkpoint-every 500 --overwrite$",
     smoke("borden_plate") + ["--set", "time.dt=0.04", "--set", "time.end=21", "--quiet"]),
    (r"pfmpm run --resume out/borden$", ["--quiet"]),
    (r"mpirun -n 2 \.venv/bin/python -m pfmpm\.fem demos/borden_plate\.toml --out out/borden_fem$",
     ["--set", "grid.h=1.0", "--set", "materials.concrete.fracture.l0=2.0", "--set", "time.end=1",
      "--quiet"]),
    (r"pfmpm post crack-tip out/borden$", []),
    (r"pfmpm run demos/vibrating_bar\.toml --out out/bar --set time\.end=20$", ["--quiet"]),
    (r"mpirun -n 2 \.venv/bin/pfmpm run demos/vibrating_bar\.toml --out out/bar_2ranks$", ["--set", "time.end=20", "--quiet"]),
    (r"pfmpm run demos/bar3d\.toml --out out/bar3d$", ["--quiet"]),
    (r"pfmpm animate out/bar3d --field velocity --output out/bar3d/speed\.png$", []),
    (r"pfmpm run demos/borden_slab\.toml --set time\.end=10 --out out/borden_slab$", smoke("borden_slab") + ["--quiet"]),
    (r"pfmpm post forces out/bar$", []),
    (r"pfmpm run demos/three_point_bending\.toml --out out/bending$", ["--set", "time.end=30", "--quiet"]),
    (r"pfmpm post load-displacement out/bending --region striker$", []),
    (r"pfmpm bench ", ["--particles", "2000", "--steps", "2", "--repeats", "1"]),
    (r"pfmpm polar ", []),
    (r"pfmpm run demos/borden_cubic\.toml --out out/borden_cubic$",
     smoke("borden_cubic") + ["--set", "time.end=5", "--quiet"]),
]


def readme_commands() -> list[list[str]]:
    """The commands of README.md's ``bash`` blocks, as argument lists (comments dropped)."""
    blocks = re.findall(r"```bash\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)
    commands = []
    for block in blocks:
        for line in block.replace("\\\n", " ").splitlines():
            words = shlex.split(line, comments=True)
            if words:
                commands.append(words)
    return commands


def program(words: list[str]) -> str:
    """A command without its leading environment assignments."""
    start = next(i for i, w in enumerate(words) if not re.match(r"[A-Z_][A-Z0-9_]*=", w))
    return " ".join(words[start:])


def rules(text: str) -> list:
    """The smoke arguments of every rule that matches the command ``text``."""
    return [extra for pattern, extra in RULES if re.search(pattern, text)]


def chains() -> dict[str, list[list[str]]]:
    """The README commands that run here, in README order, grouped by the
    output folder they name (``out/NAME``): a command that reads a folder runs
    after the one that wrote it, in the same mirror. A command that names none
    is a chain of its own, named by its subcommand and line. Commands without exactly one
    rule are left to test_every_readme_command_has_one_rule."""
    found = {}
    for line, words in enumerate(readme_commands()):
        matched = rules(program(words))
        if len(matched) != 1 or matched[0] is None:
            continue
        folder = re.search(r"\bout/(\w+)", program(words))
        name = folder.group(1) if folder else f"{program(words).split()[1].lstrip('-')}@{line}"
        found.setdefault(name, []).append(words)
    return found


# What a chain leaves in its out/, beyond exit status 0: (path, text it holds).
LEAVES = {
    "borden": [("borden/summary.json", '"resumed_from"'), ("borden/summary.json", "step_000000500.h5"),
               ("borden/c.gif", "")],
    "borden_fem": [("borden_fem/summary.json", "")],
    "borden_fem1": [("borden_fem1/summary.json", "")],
    "bar_2ranks": [("bar_2ranks/summary.json", '"ranks": 2'), ("bar_2ranks/particles.pvd", "")],
    "notebooks": [("notebooks/phase_field_profiles.html", "")],
    "polar": [("polar.png", "")],
}


@pytest.fixture
def mirror(tmp_path):
    """A directory whose top-level entries are links to the repository root's, but ``out``."""
    root = tmp_path / "root"
    root.mkdir()
    for entry in ROOT.iterdir():
        if entry.name not in ("out", ".pytest_cache"):
            (root / entry.name).symlink_to(entry)
    return root


def run(words: list[str], cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, OMP_NUM_THREADS="1", PFMPM_SMOKE="1",
               PFMPM_NOTEBOOK_OUT=str(cwd / "out" / "notebook_runs"))
    return subprocess.run(shlex.join(words), shell=True, executable="/bin/bash", cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


def test_every_readme_command_has_one_rule():
    """A README command with no rule here, or with two, fails the suite, so the
    README cannot drift from what is tested."""
    commands = readme_commands()
    assert len(commands) >= 10
    for words in commands:
        assert len(rules(program(words))) == 1, f"README command without one rule in tests/test_readme.py: {program(words)}"
    assert set(LEAVES) <= set(chains())


@pytest.mark.parametrize("chain", list(chains()))
def test_every_readme_command_runs_as_written(chain, mirror):
    assert (ROOT / ".venv" / "bin" / "pfmpm").exists(), "the README's commands use .venv: run tools/setup.sh"
    for words in chains()[chain]:
        extra = rules(program(words))[0]
        r = run(words + extra, mirror)
        assert r.returncode == 0, f"{shlex.join(words + extra)}\n{r.stderr[-3000:]}"
        assert "Traceback" not in r.stderr, r.stderr
        # Quiet kernels and JIT: debugpy's warning that frozen modules may hide
        # breakpoints, and FFCx's log of each compiler command, are gone.
        assert "frozen modules" not in r.stderr and "ffcx" not in r.stderr.lower(), r.stderr
    for path, text in LEAVES.get(chain, []):
        assert text in (mirror / "out" / path).read_text(errors="replace"), path


def test_the_python_quickstart_runs_as_written(mirror):
    """The README's ``python`` block, run from the repository root."""
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)
    assert len(blocks) == 1
    r = run([str(ROOT / ".venv" / "bin" / "python"), "-c", blocks[0]], mirror)
    assert r.returncode == 0, r.stderr
    assert "completed at step 521 -> out/quickstart" in r.stdout
    assert (mirror / "out" / "quickstart" / "energies.png").exists()


def test_the_package_imported_at_the_root_is_the_installed_one(mirror):
    """``import pfmpm`` and ``python -m pytest`` in the repository root find the
    installed package with its compiled core, not a source folder there."""
    python = str(Path(sys.executable))
    r = run([python, "-c", "import pfmpm, pfmpm._core; print(pfmpm.__file__)"], mirror)
    assert r.returncode == 0, r.stderr
    assert Path(r.stdout.strip()).parent.parent != mirror, r.stdout
    r = run([python, "-m", "pytest", "-p", "no:cacheprovider", "--collect-only", "-q",
             "tests/test_post.py"], mirror)
    assert r.returncode == 0, r.stdout + r.stderr


def test_jupyter_and_the_kernel_are_installed(mirror):
    """``tools/setup.sh`` installs Jupyter (``python -m notebook``, ``python -m
    nbconvert``) and the ``pfmpm`` kernel the notebooks name, which runs the
    venv's Python without debugpy's warning."""
    python = ROOT / ".venv" / "bin" / "python"
    for module in ("notebook", "nbconvert"):
        r = run([str(python), "-m", module, "--version"], mirror)
        assert r.returncode == 0 and r.stdout.strip()[0].isdigit(), (module, r.stdout, r.stderr)
    spec = json.loads((ROOT / ".venv" / "share" / "jupyter" / "kernels" / "pfmpm" / "kernel.json").read_text())
    assert spec["argv"][0] == str(python) and spec["env"] == {"PYDEVD_DISABLE_FILE_VALIDATION": "1"}
