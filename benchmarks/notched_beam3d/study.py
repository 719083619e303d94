"""PF-MPM against PF-FEM on the free 3D notched beam struck at mid-span
(issue 51, "MPM against FEM in 3D"), at h = 1 and 0.5 mm.

Runs ``pfmpm compare notched_beam3d`` (:func:`pfmpm.compare.compare` on
src/pfmpm/scenes/notched_beam3d.toml, l0 = 1 mm, to 50 us) into ``OUT``,
continuing the comparison there if it has one (its completed runs are
kept), then measures the two methods' agreement at each ``h``
(:mod:`benchmarks.notched_beam3d.measure`): initiation within one output
row, end fracture energy within 5 %; and writes
``OUT/benchmark_results.json`` with the table of the runs
(``speed_vs_error.csv``) and the checks. The comparison itself writes the
overlays, ``speed_vs_error.csv`` and ``.png``, ``comparison.md`` and the
phase field of the finest runs side by side.

    OMP_NUM_THREADS=2 .venv/bin/python benchmarks/notched_beam3d/study.py --out out/notched_beam3d
    .venv/bin/python tools/benchmark_pages.py --take out/notched_beam3d/benchmark_results.json
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from pathlib import Path

if str(Path(__file__).resolve().parents[2]) not in sys.path:  # run as a file: the root holds ``benchmarks``
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks.common import results as results_file  # noqa: E402
from benchmarks.notched_beam3d.measure import (  # noqa: E402
    FRACTURE, MOMENTUM, ROWS, ZONES, area_initiation, checks, cracked_reach, fem_crack_area, history, load_impulse,
    local_crack_area, momentum_error)
from pfmpm.compare import PROBLEMS, STUDY, compare  # noqa: E402

PROBLEM = PROBLEMS["notched_beam3d"]


def fmt(value: float, spec: str) -> str:
    return "NaN" if not math.isfinite(value) else format(value, spec)


def tables(out: Path, hs) -> dict:
    """The results file's tables: the runs and the checks at each h."""
    with open(out / "speed_vs_error.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    runs = results_file.table(
        ["method", "h (mm)", "particles / dofs", "steps", "wall (s)", "initiation (us)",
         "fracture energy at the end (mJ)", "crack area at the end (mm^2)", "error against the reference"],
        [[r["method"], r["h"], r["particles"] or r["dofs"], r["steps"], fmt(float(r["wall_s"]), ".1f"),
          fmt(float(r["initiation_us"]), ".2f"), fmt(float(r["fracture_energy_end"]), ".4f"),
          fmt(float(r["crack_area_end"]), ".2f"), fmt(100 * float(r["error"]), ".2f") + " %"] for r in rows])
    lines = []
    for c in checks(out, hs):
        row = fmt(c["record_interval_us"], ".3f")
        a_mpm, a_fem = (area_initiation(out / f"{m}_h{c['h']:g}" / "energies.csv") for m in ("mpm", "fem"))
        lines += [
            [f"h = {c['h']:g}: initiation, the front 0.5 mm past its start (us; one row = {row} us)",
             fmt(c["initiation_mpm_us"], ".2f"), fmt(c["initiation_fem_us"], ".2f"),
             f"{fmt(c['initiation_diff_us'], '+.2f')} ({fmt(c['initiation_rows'], '.1f')} rows)",
             f"<= {ROWS:g} row", "pass" if c["initiation_ok"] else "**fails**"],
            [f"h = {c['h']:g}: initiation, the crack area 0.5 mm x the thickness past its start (us)",
             fmt(a_mpm, ".2f"), fmt(a_fem, ".2f"),
             f"{fmt(a_mpm - a_fem, '+.2f')} ({fmt(abs(a_mpm - a_fem) / c['record_interval_us'], '.1f')} rows)",
             "reported", ""],
            [f"h = {c['h']:g}: fracture energy at {c['t_end']:.2f} us (mJ)", fmt(c["fracture_end_mpm"], ".4f"),
             fmt(c["fracture_end_fem"], ".4f"), fmt(100 * c["fracture_end_rel_diff"], "+.2f") + " %",
             f"<= {100 * FRACTURE:g} %", "pass" if c["fracture_ok"] else "**fails**"],
            [f"h = {c['h']:g}: fracture energy gained since t = 0", "", "",
             fmt(100 * c["fracture_gain_rel_diff"], "+.2f") + " %", "reported", ""],
            [f"h = {c['h']:g}: elastic energy to the first initiation, RMS difference / peak", "", "",
             fmt(100 * c["elastic_rms_rel"], ".2f") + " %", "reported", ""],
        ]
        folders = [out / f"{m}_h{c['h']:g}" for m in ("mpm", "fem")]
        impulse = load_impulse(folders[1])[-1, 1]
        errors = [momentum_error(folder) for folder in folders]
        lines.append([f"h = {c['h']:g}: the beam's momentum less the load's impulse ({impulse:.0f} N us at the end),"
                      " largest over the rows, x / y / z, over the impulse at the end",
                      *(" / ".join(f"{x:.1e}" for x in error) for error in errors), "", f"<= {MOMENTUM:g}",
                      "pass" if max(error.max() for error in errors) <= MOMENTUM else "**fails**"])
        reach = [cracked_reach(out / f"{m}_h{c['h']:g}") for m in ("mpm", "fem")]
        lines.append([f"h = {c['h']:g}: the cracked points' (c < 0.2) farthest distance from the notch's plane at"
                      " the end (mm)", f"{reach[0]:.2f}", f"{reach[1]:.2f}", "", "reported", ""])
        split = fem_crack_area(out / f"fem_h{c['h']:g}")
        lines.append([f"h = {c['h']:g}: FEM crack area (mm^2) within 8 mm of the notch / elsewhere", "",
                      f"{split['near']:.2f} / {split['elsewhere']:.2f}", "", "reported", ""])
        local = [local_crack_area(out / f"{m}_h{c['h']:g}") for m in ("mpm", "fem")]
        zones = ("band", "flanks", "ends")
        lines.append([f"h = {c['h']:g}: int (1 - c)^2 / (4 l0) dV at the end (mm^2) within {ZONES[0]:g} l0 of the"
                      f" notch's plane / {ZONES[0]:g}-{ZONES[1]:g} l0 / beyond",
                      *(" / ".join(f"{x[z]:.2f}" for z in zones) for x in local),
                      " / ".join(fmt(100 * (local[0][z] - local[1][z]) / local[1][z], "+.1f") + " %" for z in zones),
                      "reported", ""])
        medians = [history(out / f"{m}_h{c['h']:g}") for m in ("mpm", "fem")]
        lines.append([f"h = {c['h']:g}: history field at the end, median {ZONES[0]:g}-{ZONES[1]:g} l0 from the notch's"
                      " plane / beyond (J/m^3)",
                      *(" / ".join(f"{1e6 * x[z]:.1f}" for z in zones[1:]) for x in medians),
                      " / ".join(fmt(100 * (medians[0][z] - medians[1][z]) / medians[1][z], "+.1f") + " %"
                                 for z in zones[1:]),
                      "reported", ""])
    agreement = results_file.table(["check", "PF-MPM", "PF-FEM", "MPM - FEM", "required", "verdict"], lines)
    return {"runs": runs, "agreement": agreement}


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--h", type=float, action="append", help="grid.h of a run pair (repeat; default 1 and 0.5)")
    parser.add_argument("--out", type=Path, default=Path("out/notched_beam3d"))
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="override a scene value for both methods (as pfmpm compare --set)")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    args = parser.parse_args(argv)
    hs = args.h or list(PROBLEM.h)
    resume = (args.out / STUDY).is_file()
    compare(args.out, hs, PROBLEM.l0, PROBLEM.end, scene_path=PROBLEM.path, overrides=args.set,
            progress=not args.quiet, resume=resume, title=PROBLEM.title)
    record = results_file.write(args.out, "notched_beam3d", "docs/verification/notched-beam3d.md", __file__,
                                argv, tables(args.out, hs))
    for t in record["tables"].values():
        print(" | ".join(t["columns"]))
        for row in t["rows"]:
            print(" | ".join(row))
    print(f"wrote {args.out / results_file.FILE}")
    return record


if __name__ == "__main__":
    main()
