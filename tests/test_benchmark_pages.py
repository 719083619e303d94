"""Each benchmark page's generated section is the rendering of its results file
(benchmarks/<name>/results.json, tools/benchmark_pages.py), so a page cannot
drift from its results; a results file holds what a driver writes; and the
drivers' tables render."""

import json
import re
import runpy
from pathlib import Path

import pytest

from benchmarks.common import results

ROOT = Path(__file__).resolve().parents[1]
TOOL = runpy.run_path(str(ROOT / "tools" / "benchmark_pages.py"))
FILES = TOOL["results_files"]()
KEYS = {"benchmark", "page", "commands", "date", "commit", "tables"}
"""What every results file holds (a transcribed one also its ``source``)."""


def test_every_driver_with_a_table_has_a_results_file():
    assert set(FILES) == {"kalthoff_winkler", "billet", "wedge_disk_block", "charpy", "brazilian", "efficiency", "sphere_disk",
                          "notched_beam3d", "borden_slab"}


@pytest.mark.parametrize("name", sorted(FILES))
def test_results_file_is_complete(name):
    r = FILES[name]
    assert KEYS <= set(r) <= KEYS | {"source"} and r["benchmark"] == name
    assert (ROOT / r["page"]).exists() and r["commands"] and r["tables"]
    for command in r["commands"]:  # the commands name files that exist
        for word in command.split():
            if re.fullmatch(r"[\w/.]+\.(toml|py)", word):
                assert (ROOT / word).exists(), command
    for t in r["tables"].values():
        assert all(len(row) == len(t["columns"]) and all(isinstance(c, str) for c in row) for row in t["rows"])
    # As written: each list of strings on one line.
    assert (ROOT / "benchmarks" / name / "results.json").read_text() == results.dumps(r)


@pytest.mark.parametrize("page", sorted({r["page"] for r in FILES.values()}))
def test_page_is_its_results_rendered(page):
    text, rendered = TOOL["pages"](FILES)[ROOT / page]
    assert text == rendered, (f"{page} differs from its results file: "
                              "run .venv/bin/python tools/benchmark_pages.py")


def test_render_puts_commands_and_tables_between_the_markers(tmp_path):
    r = {"benchmark": "x", "page": "p.md", "commands": ["python a.py --out o"], "date": "2026-01-02",
         "commit": "abc1234", "tables": {"t": results.table(["check", "value"], [["a|b", ""], ["c", 1.5]])}}
    text = TOOL["render"]("x", r, [])
    assert "```bash\npython a.py --out o\n```" in text and "Made on 2026-01-02 at abc1234." in text
    assert "| check | value |\n|---|---|\n| a\\|b | |\n| c | 1.5 |\n" in text
    assert TOOL["render"]("x", r, ["t"]).count("```") == 0
    with pytest.raises(KeyError):
        TOOL["render"]("x", r, ["u"])


def test_a_page_must_show_every_table_once(tmp_path, monkeypatch):
    page = tmp_path / "p.md"
    page.write_text("intro\n\n<!-- results: x commands -->\n<!-- /results -->\n\nmore\n")
    r = {"benchmark": "x", "page": str(page), "commands": ["c"], "date": None, "commit": None,
         "tables": {"t": results.table(["a"], [["1"]])}}
    with pytest.raises(ValueError, match="once"):
        TOOL["pages"]({"x": r})
    page.write_text("intro\n\n<!-- results: x -->\nold\n<!-- /results -->\n\nmore\n")
    text, new = TOOL["pages"]({"x": r})[page]
    assert "old" not in new and new.startswith("intro\n\n<!-- results: x -->\n") and new.endswith("\nmore\n")
    assert "| a |\n|---|\n| 1 |\n" in new


def test_write_records_the_command_and_the_commit(tmp_path):
    script = ROOT / "benchmarks" / "billet" / "compare.py"
    r = results.write(tmp_path, "billet", "docs/verification/billet.md", script, ["--out", "out/b c"],
                      {"checks": results.table(["check"], [["B1"]])})
    assert r["commands"][0].endswith("benchmarks/billet/compare.py --out 'out/b c'")
    assert json.loads((tmp_path / results.FILE).read_text()) == r
    assert r["commit"] is None or re.fullmatch(r"[0-9a-f]{7,}(-dirty)?", r["commit"])


def test_driver_tables_render():
    """The drivers' table functions on reports of the shape their runs make."""
    billet = runpy.run_path(str(ROOT / "benchmarks" / "billet" / "compare.py"))["table"]({
        "times": [0.25, 0.5, 1.0],
        "B1": {"single_field": [0.3, 0.6, 0.8], "damage_gradient": [1.7e-4, 3e-4, 6.3e-4]},
        "B2": {"single_field": [0.0, 1e-6, 2e-6], "multi_field": [5e-4, 1e-3, 1.2e-3],
               "damage_gradient": [5e-4, 1e-3, 1.2e-3]},
        "B3": {"multi_field": {"C1": 0, "C2": 0, "C3": 0, "C4": 0},
               "damage_gradient": {"C1": 0, "C2": 0, "C3": 0, "C4": 0}},
        "B4": {"single_field": 0.0, "multi_field": -0.034, "damage_gradient": -0.034},
        "B4_closest": {"single_field": 0.995, "multi_field": 0.964, "damage_gradient": 0.964}})
    assert billet["columns"][1] == "t = 0.25 / 0.5 / 1 us"
    assert [row[-1] for row in billet["rows"]] == ["", "pass", "", "pass", "pass", "pass", "pass"]
    wedge = runpy.run_path(str(ROOT / "benchmarks" / "wedge_disk_block" / "compare.py"))["table"]({
        "W1": {"single_field": -0.554, "multi_field": -0.170, "damage_gradient": -0.177,
               "dfg_over_sf": 0.020, "dfg_over_mf": 0.045},
        "W2": {"single_field": 0.175, "damage_gradient": 0.0072},
        "W3": {"single_field": 0.26, "multi_field": 0.045, "damage_gradient": 0.060},
        "W3_closest": {"single_field": 1.25, "multi_field": 1.02, "damage_gradient": 1.08},
        "W4": {"single_field": 4.6e-14, "multi_field": 2.3e-12, "damage_gradient": 4.6e-14},
        "contact": {"multi_field": {"C1": 0, "C2": 0, "C3": 0, "C4": 0}}})
    assert wedge["rows"][0][1] == "-0.554 / -0.170 / -0.177"
    assert all(row[-1] in ("", "pass") for row in wedge["rows"])
    TOOL["table"](billet), TOOL["table"](wedge)


def test_kalthoff_winkler_table_renders():
    def run(angle, separable=None):
        contact = {"violations": {"C1": 0, "C2": 0, "C3": 0, "C4": 0}}
        if separable is not None:
            contact["separable_nodes_last_step"] = separable
        return {"angle": angle, "line": 60.4, "angle_time": 42.9, "angle_end": 60.5, "line_end": 69.1,
                "speed": 1.63, "initiation": {"t": 21.43, "distance": 0.32}, "single_until": 87.2,
                "momentum_drift": 2.1e-13, "contact": contact}

    table = runpy.run_path(str(ROOT / "benchmarks" / "kalthoff_winkler" / "compare.py"))["table"]({
        "damage_gradient": run(67.8, 398), "single_field": run(67.8), "damage_gradient_Gf_22.3": run(67.809),
        "K5_angle_change": 0.009, "t_end": 90.0})
    assert table["columns"] == ["check", "DFG", "SF", "paper (DFG / SF)", "required"]
    rows = {row[0]: row[1:] for row in table["rows"]}
    assert rows["K1: angle, bearing from the tip (at 42.9 / 42.9 us)"][:2] == ["67.8", "67.8"]
    assert rows["K2: tip speed over 40-50 us"][0] == "1.63 km/s"
    assert rows["K3: first failure"][0] == "21.43 us, 0.32 mm from the notch's tip face"
    assert rows["K5: angle with G_f = 22.3"][:2] == ["67.8 (changes by 0.009)", ""]
    assert rows["separable nodes at the end"][:2] == ["398", ""]
    TOOL["table"](table)
