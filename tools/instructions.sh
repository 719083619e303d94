#!/usr/bin/env bash
# Instructions the step executes, the working tree against revision REV
# (default HEAD): callgrind of Solver::advance (Solver<2>::advance; inclusive) on the bench block
# of 40,000 particles, 20 steps after 2 warm-up steps, one thread, for the
# elastic step, the phase-field step and the damage-gradient partition (a
# fully damaged band along each midline). Instruction counts do not depend
# on the machine's load. Both sides are built for x86-64-v3 (valgrind does not run
# AVX-512) with symbols.
#   bash tools/instructions.sh [REV]
# Builds in /tmp/instructions, or $PFMPM_TOOLS_ROOT/instructions where two
# sessions share /tmp (a few minutes per side); prints M instructions
# per case and side and their ratio.
set -euo pipefail
cd "$(dirname "$0")/.."
rev=${1:-HEAD}
root=${PFMPM_TOOLS_ROOT:-/tmp}/instructions
source tools/two_trees.sh

cat > "$root/step.py" <<'PY'
import sys
import numpy as np
from pfmpm.bench import block_scene
from pfmpm.simulation import Simulation
sim = Simulation(block_scene(40_000, 2, 3, physics=sys.argv[1]))
x = sim.particles.x
s = (x - x.min(axis=0)) / (x.max(axis=0) - x.min(axis=0))
sim.particles.v[:, 0] = 1e-3 * np.sin(np.pi * s[:, 1])
sim.particles.v[:, 1] = 1e-3 * np.sin(np.pi * s[:, 0])
sim.solver.adaptive_threads = False
sim.advance(2)
sim.advance(20)
PY
# The module alone, built by CMake (flags with spaces do not pass through
# setup.py's CMAKE_ARGS), beside a copy of the package.
pybind11_dir=$(/usr/bin/python3 -c "import pybind11; print(pybind11.get_cmake_dir())")
for side in old new; do
  (cd "$root/$side" \
    && cmake -S . -B build/callgrind -DPFMPM_NATIVE=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O3 -g -DNDEBUG" "-DCMAKE_CXX_FLAGS=-march=x86-64-v3" \
      -DPython3_EXECUTABLE=/usr/bin/python3 "-Dpybind11_DIR=$pybind11_dir" > "$root/$side.log" 2>&1 \
    && cmake --build build/callgrind --target _core -j 2 >> "$root/$side.log" 2>&1 \
    && mkdir -p pkg && cp -r src/pfmpm pkg/ && cp build/callgrind/_core*.so pkg/pfmpm/)
done
printf '%-16s %12s %12s %8s\n' case "old (M)" "new (M)" ratio
for physics in elastic phasefield damage_gradient; do
  declare -A count
  for side in old new; do
    out="$root/$side-$physics.callgrind"
    (cd "$root" && OMP_NUM_THREADS=1 PYTHONPATH="$root/$side/pkg" valgrind --tool=callgrind \
      --toggle-collect='pfmpm::Solver*::advance*' --callgrind-out-file="$out" \
      /usr/bin/python3 -P step.py "$physics" > /dev/null 2>&1)
    count[$side]=$(callgrind_annotate --inclusive=yes "$out" 2> /dev/null | awk '/PROGRAM TOTALS/ {gsub(",", "", $1); print $1}')
  done
  awk -v c="$physics" -v o="${count[old]}" -v n="${count[new]}" \
    'BEGIN { printf "%-16s %12.1f %12.1f %8.4f\n", c, o / 1e6, n / 1e6, n / o }'
done
