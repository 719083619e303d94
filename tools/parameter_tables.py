"""Write the reference tables of the parameters the core declares (the
material models', the fracture table's, the phase-field solve's and the
damage-gradient partition's)
into docs/scenes.md, from the declarations (pfmpm.scene.declared), between
the lines ``<!-- declared parameters -->`` and ``<!-- /declared parameters -->``.

    .venv/bin/python tools/parameter_tables.py          # rewrite the section
    .venv/bin/python tools/parameter_tables.py --check  # exit 1 if it is stale

tests/test_material_declarations.py runs the check.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

from pfmpm import _core
from pfmpm.scene.declared import (damage_gradient_parameters, declaration, fracture_parameters,
                                  parameter_table, phase_field_parameters)

PAGE = Path(__file__).resolve().parents[1] / "docs" / "scenes.md"
START, END = "<!-- declared parameters -->", "<!-- /declared parameters -->"


def section() -> str:
    """The generated section: per core model, its description and its table."""
    parts = [START, "", "*Generated from the core's declarations by `tools/parameter_tables.py`;"
             " do not edit by hand.*"]
    for model in _core.material_models():
        d = declaration(model)
        crack = ("A `fracture` table lets the phase field crack it." if d["phase_field"]
                 else "It takes no `fracture` table.")
        parts += ["", f"### `{model}`", "", f"{d['doc']} {crack}", "", parameter_table(d["parameters"])]
    parts += ["", "### `fracture`", "", "The phase-field table of a material that can crack (also"
              " `split`, from the model's declaration, `anisotropy` and `bound`, above).", "",
              parameter_table(fracture_parameters())]
    parts += ["", "### `[phase_field]`", "", "The phase-field solve's settings.", "",
              parameter_table(phase_field_parameters())]
    parts += ["", '### `[contact]` with `partition = "damage_gradient"`', "", "The damage-gradient"
              " partition's own keys (besides `groups`, `surface_detection`, `surface_threshold` and"
              " `surfaces`, above; docs/contact.md).", "", parameter_table(damage_gradient_parameters())]
    return "\n".join(parts + ["", END])


def updated(text: str) -> str:
    """``text`` with its section replaced by :func:`section`."""
    pattern = re.compile(re.escape(START) + ".*?" + re.escape(END), re.S)
    if not pattern.search(text):
        raise SystemExit(f"{PAGE}: no {START} ... {END} section")
    return pattern.sub(lambda _: section(), text)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if the page is stale")
    args = parser.parse_args()
    text = PAGE.read_text()
    new = updated(text)
    if args.check:
        if new != text:
            print(f"{PAGE} is stale: run .venv/bin/python tools/parameter_tables.py", file=sys.stderr)
            return 1
        return 0
    PAGE.write_text(new)
    return 0


if __name__ == "__main__":
    sys.exit(main())
