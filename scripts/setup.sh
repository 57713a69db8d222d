#!/usr/bin/env bash
# System packages for the verifier sidecar (OpenCV), the opencv crate's
# binding generator (libclang) and the tests of the C ABI from C++ (g++),
# Python (python3), CMake (cmake, make) and pkg-config.
# Idempotent and quiet when already installed.
set -euo pipefail
need=()
for p in libopencv-dev clang libclang-dev g++ python3 cmake make pkg-config; do
  dpkg -s "$p" >/dev/null 2>&1 || need+=("$p")
done
if [ ${#need[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null
fi
