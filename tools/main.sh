#!/usr/bin/env bash
# Set up, then run the main job: the Borden plate with PF-MPM at its default
# resolution (h = 0.25 mm, l0 = 0.5 mm), a few minutes on 2 cores. The
# PF-MPM vs PF-FEM comparison replaces it when the FEM reference lands.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
.venv/bin/pfmpm run demos/borden_plate.toml --out out/borden_plate "$@"
echo "plots and data: out/borden_plate/ (phase_field.png, crack_tip.png, energies.png, energies.csv, particles.pvd for ParaView)"
