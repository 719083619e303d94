#!/usr/bin/env bash
# Set up, then run the main job: the Borden plate with PF-MPM and PF-FEM at
# h = 0.5 and 0.25 mm (l0 = 0.5 mm), compared: about 8 minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
.venv/bin/pfmpm compare borden --out out/compare_borden "$@"
