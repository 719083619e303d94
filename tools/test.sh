#!/usr/bin/env bash
# Set up, then run every test: the C++ unit tests (GoogleTest via ctest) and
# pytest on 2 workers.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh

# The unit tests in the tree setup.py built the module in (build/cmake), so
# that the library's objects are compiled once.
cmake -S . -B build/cmake -DPFMPM_TESTS=ON > build-tests.log
cmake --build build/cmake --target pfmpm_tests -j 2 >> build-tests.log
(cd build/cmake && OMP_NUM_THREADS=2 ctest --output-on-failure)

# One OpenMP thread per pytest worker: 2 workers fill the 2 cores.
OMP_NUM_THREADS=1 .venv/bin/python -m pytest -n 2 tests "$@"
