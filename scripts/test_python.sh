#!/usr/bin/env bash
# Builds the Python package (crates/turnprint-python, maturin + PyO3) into a
# virtual environment of its own, target/pyvenv-turnprint, and runs its
# pytest suite. The venv and its tools are made once; the package is
# rebuilt and reinstalled on every run (release, in the workspace's target
# directory, so the Rust build is shared with the rest of the workspace).
#
#   scripts/test_python.sh [PYTEST ARGS...]
#
# PYTHON: the interpreter to make the venv with (python3; 3.9 or newer).
# TURNPRINT_PYTHON_EVO=0: leave evo out (its interoperability tests skip).
# TURNPRINT_DATA: where kitti_gt/00.txt is (else ../shared/data, target/data).
# TURNPRINT_PYTHON_TARGET: a cargo target directory other than target/.
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)
venv="$repo/target/pyvenv-turnprint"
export PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_INPUT=1

if [ ! -x "$venv/bin/python" ]; then
    "${PYTHON:-python3}" -m venv "$venv" || {
        echo "cannot make a venv with ${PYTHON:-python3} (Debian: apt-get install python3-venv)" >&2
        exit 1
    }
fi
py="$venv/bin/python"
# The build backend runs the venv's `maturin` by name.
export PATH="$venv/bin:$PATH"
# The tools once per venv; the marker is written only once they are in.
if [ ! -f "$venv/.turnprint-tools" ]; then
    "$py" -m pip install --quiet --upgrade pip
    "$py" -m pip install --quiet "maturin>=1.9,<2" pytest numpy
    if [ "${TURNPRINT_PYTHON_EVO:-1}" != 0 ]; then
        # Optional: without it the evo tests skip, the rest still run.
        "$py" -m pip install --quiet "evo==1.38.1" ||
            echo "note: evo did not install; its interoperability tests will skip" >&2
    fi
    touch "$venv/.turnprint-tools"
fi

# No build isolation: maturin is in the venv already, and an isolated
# build would fetch it again on every run.
echo "building and installing crates/turnprint-python (release)..."
start=$SECONDS
CARGO_TARGET_DIR="${TURNPRINT_PYTHON_TARGET:-$repo/target}" nice -n 10 "$py" -m pip install --quiet \
    --no-build-isolation --no-deps --force-reinstall ./crates/turnprint-python
echo "built and installed in $((SECONDS - start)) s"

# From the tests' folder, so that the installed package is the one imported.
cd crates/turnprint-python/tests
"$py" -m pytest -q "$@" test_turnprint.py
