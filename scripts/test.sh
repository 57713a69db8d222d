#!/usr/bin/env bash
# The whole test suite on a fresh Debian/Ubuntu machine with Rust:
# installs the system packages it needs, then builds and runs every test.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo test --workspace --all-features --release 2>&1
