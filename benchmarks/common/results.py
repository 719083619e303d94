"""A benchmark's results file: the command that made it, the date, the git
commit and the rows of its tables.

A driver that prints a table of checks also writes it, as
:data:`FILE` in its ``--out`` folder (:func:`write`)::

    {"benchmark": "billet", "page": "docs/verification/billet.md",
     "commands": [".venv/bin/python benchmarks/billet/compare.py --out out/billet_A"],
     "date": "2026-12-10", "commit": "07ddbad",
     "tables": {"reading_A": {"columns": ["check", ...], "rows": [["B1: ...", ...], ...]}}}

``benchmarks/<name>/results.json`` is the one kept in git, the numbers the
benchmark's page shows: ``tools/benchmark_pages.py --take OUT/benchmark_results.json``
copies a run's file there and renders the page's section between
``<!-- results: <name> -->`` and ``<!-- /results -->``. A file not made by a
run (transcribed from a page) says so in ``source``.
"""

from __future__ import annotations

import datetime
import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

__all__ = ["FILE", "ROOT", "command", "commit", "table", "dumps", "write"]

FILE = "benchmark_results.json"
"""The name of a run's results file in its ``--out`` folder."""
ROOT = Path(__file__).resolve().parents[2]
"""The repository root, from which the commands run."""


def command(script: str | Path, argv: list[str] | None) -> str:
    """The command line that ran ``script`` with ``argv`` (default: this
    process's arguments), as from the repository root: ``OMP_NUM_THREADS``
    when set, the interpreter, the script and its arguments."""
    argv = sys.argv[1:] if argv is None else list(argv)
    python, path = Path(sys.executable), Path(script).resolve()
    words = [str(python.relative_to(ROOT)) if python.is_relative_to(ROOT) else "python",
             str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path), *argv]
    threads = os.environ.get("OMP_NUM_THREADS")
    return (f"OMP_NUM_THREADS={threads} " if threads else "") + shlex.join(words)


def commit() -> str | None:
    """The short hash of the repository's HEAD, with ``-dirty`` when tracked
    files differ from it; None outside a git checkout."""
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                              text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT,
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return None
    return head + ("-dirty" if dirty else "")


def table(columns: list[str], rows: list[list]) -> dict:
    """A table: its column headers and its rows, each cell as text."""
    assert all(len(r) == len(columns) for r in rows), "every row has a cell per column"
    return {"columns": list(columns), "rows": [[str(c) for c in r] for r in rows]}


def dumps(record: dict) -> str:
    """``record`` as JSON, each list of strings (a table's columns, a row, the
    commands) on one line."""
    text = json.dumps(record, indent=1, ensure_ascii=False)
    strings = r'"(?:[^"\\]|\\.)*"'
    return re.sub(rf"\[\n\s+({strings}(?:,\n\s+{strings})*)\n\s+\]",
                  lambda m: "[" + re.sub(r",\n\s+", ", ", m[1]) + "]", text) + "\n"


def write(out: str | Path, benchmark: str, page: str, script: str | Path, argv: list[str] | None,
          tables: dict[str, dict]) -> dict:
    """Write ``out/``:data:`FILE` for the tables of ``benchmark`` (each from
    :func:`table`, by name), made by ``script`` with ``argv``; return it."""
    record = {"benchmark": benchmark, "page": page, "commands": [command(script, argv)],
              "date": datetime.date.today().isoformat(), "commit": commit(), "tables": tables}
    Path(out, FILE).write_text(dumps(record))
    return record
