#!/usr/bin/env bash
# Install pfmpm's Debian packages (if missing) and build pfmpm into ./.venv.
# Idempotent; used by tools/main.sh and tools/test.sh.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  cmake g++ make libeigen3-dev pybind11-dev python3-pybind11 libgtest-dev
  python3-venv python3-pip python3-setuptools python3-wheel
  python3-numpy python3-scipy python3-matplotlib python3-tqdm python3-h5py
  python3-meshio python3-pytest python3-pytest-xdist python3-hypothesis
  # The notebooks in docs/notebooks, the test that runs them, and Jupyter
  # itself (jupyter notebook, jupyter nbconvert --execute).
  python3-nbclient python3-nbformat python3-ipykernel jupyter-notebook jupyter-nbconvert
  # pfmpm animate: GIFs through Pillow (MP4s need ffmpeg, which is not installed).
  python3-pil
  # The documentation site (tools/docs.sh, tests/test_docs_site.py): Sphinx
  # with MyST for the Markdown pages in docs/.
  python3-sphinx python3-myst-parser
  # The phase-field FEM reference (pfmpm.fem): DOLFINx 0.5 and PETSc built on
  # Open MPI, whose mpirun runs it in parallel; gcc compiles its JIT forms.
  python3-dolfinx python3-petsc4py python3-mpi4py openmpi-bin gcc python3-dev
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "installing Debian packages: ${missing[*]}"
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# Debian's interpreter has DOLFINx and the numeric stack; the venv sees them.
[ -x .venv/bin/python ] || /usr/bin/python3 -m venv --system-site-packages .venv
echo "building pfmpm into .venv"
# setuptools copies the package through build/lib.*: clear it, or a module
# moved or deleted since the last build would be installed again.
rm -rf build/lib.*
.venv/bin/python -m pip install --quiet --no-build-isolation --no-deps --no-index .
# A Jupyter kernel that runs this venv's Python, for docs/notebooks (whose
# metadata name it). debugpy warns on stderr, whenever it is imported, that
# Python's frozen modules may hide breakpoints: the kernel turns that check
# off. It is not named python3: for that name Jupyter imports ipykernel, and
# with it debugpy, in its own process too, which would warn.
PYDEVD_DISABLE_FILE_VALIDATION=1 .venv/bin/python -Xfrozen_modules=off -m ipykernel install --sys-prefix \
  --name pfmpm --display-name "pfmpm (.venv)" --env PYDEVD_DISABLE_FILE_VALIDATION 1 > /dev/null
