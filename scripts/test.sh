#!/usr/bin/env bash
# The whole test suite on a fresh Debian/Ubuntu machine with Rust:
# installs the system packages it needs, then builds and runs every test.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
# The library, the CLI, the verifier sidecar and the evaluation.
cargo test --all-features --release 2>&1
# The C ABI, built as a C or C++ caller builds it (no OpenCV in it); its
# verifier test runs the sidecar the line above built.
cargo test --release -p turnprint-capi 2>&1
