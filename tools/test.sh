#!/usr/bin/env bash
# Set up, then run every test: the C++ unit tests (GoogleTest via ctest) and
# pytest on 2 workers.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh

cmake -S . -B build/tests -DPFMPM_TESTS=ON -DPFMPM_PYTHON=OFF -DCMAKE_BUILD_TYPE=Release > build-tests.log
cmake --build build/tests -j 2 >> build-tests.log
(cd build/tests && OMP_NUM_THREADS=2 ctest --output-on-failure)

# One OpenMP thread per pytest worker: 2 workers fill the 2 cores.
OMP_NUM_THREADS=1 .venv/bin/python -m pytest -n 2 tests "$@"
