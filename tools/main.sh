#!/usr/bin/env bash
# Set up, then run the main job: a fixed-free bar under a traction step, with
# its energy plot (the PF-MPM vs PF-FEM Borden comparison replaces it later).
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
.venv/bin/pfmpm run demos/vibrating_bar.toml --out out/vibrating_bar "$@"
echo "plots and data: out/vibrating_bar/ (energies.png, energies.csv, particles.pvd for ParaView)"
