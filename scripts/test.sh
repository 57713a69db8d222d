#!/usr/bin/env bash
# The whole test suite on a fresh Debian/Ubuntu machine with Rust: installs
# the system packages and fetches the registry data it needs, then builds
# and runs every test of every crate.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
# The binaries first: the CLI's and the C ABI's tests start the verifier
# sidecar, a binary of another crate.
cargo build --release --workspace --all-features --bins 2>&1
cargo test --release --workspace --all-features 2>&1
