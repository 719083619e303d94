#!/usr/bin/env bash
# Set up, then run the main job: a vibrating elastic bar, with energy plot.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
.venv/bin/pfmpm run demos/vibrating_bar.toml --out out/vibrating_bar "$@"
echo "plots and data: out/vibrating_bar/ (energies.png, energies.csv, particles.pvd for ParaView)"
