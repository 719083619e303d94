"""Cell-crossing error under large deformation, for the record: the bar of
``tests/test_neo_hookean.py`` between stiff grips stretched to twice its
length (uniaxial stress in its middle, a closed form), with single-point
degree-1 B-splines, CPDI1 on the degree-1 grid and quadratic B-splines, at 2
and 4 particles per cell a direction. Prints a Markdown table of the middle's
mean stretch and the largest relative error of sigma_xx there.

    OMP_NUM_THREADS=1 .venv/bin/python tools/cpdi_comparison.py [--length 16]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from test_cpdi import stretched_bar  # noqa: E402 (the tests' bar, not a copy)

from pfmpm import SimulationError  # noqa: E402

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--length", type=float, default=16.0, help="bar length in cells")
    a = parser.parse_args()
    print("| shape functions | particles per cell | F_xx (middle) | max error of sigma_xx |")
    print("|---|---|---|---|")
    for ppc in (2, 4):
        for degree, shape, name in ((1, "bspline", "degree 1, single point"), (1, "cpdi", "CPDI1, degree 1"),
                                    (2, "bspline", "quadratic B-splines")):
            try:
                l1, error = stretched_bar(degree, shape, ppc, a.length)
                print(f"| {name} | {ppc} x {ppc} | {l1:.4f} | {100 * error:.3g} % |", flush=True)
            except SimulationError as err:
                print(f"| {name} | {ppc} x {ppc} | stopped: {str(err)[:60]}... | - |", flush=True)
