#!/usr/bin/env bash
# Build the documentation site (docs/, Sphinx with MyST Markdown, the API
# pages from the docstrings of the pfmpm that tools/setup.sh installs) into
# build/docs/html; any warning fails the build.
set -euo pipefail
cd "$(dirname "$0")/.."

bash tools/setup.sh

# -E reads every page again: an incremental build would not repeat the
# warnings of pages unchanged since a failed build.
.venv/bin/python -m sphinx -E -W --keep-going -b html -d build/docs/doctrees docs build/docs/html "$@"
