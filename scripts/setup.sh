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
# Python with evo and GTSAM for the cross-checks (tests/crosscheck_*.rs,
# scripts/crosscheck/): a venv at target/pyenv, made once.
root="$(cd "$(dirname "$0")/.." && pwd)"
venv="$root/target/pyenv"
if ! "$venv/bin/python" - >/dev/null 2>&1 <<'PY'
import importlib.metadata as m
assert m.version("evo") == "1.38.1" and m.version("gtsam") == "4.3.0"
import evo.core.metrics, gtsam
PY
then
  if ! python3 -c 'import ensurepip' >/dev/null 2>&1; then
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends python3-venv >/dev/null
  fi
  mkdir -p "$root/target"
  python3 -m venv "$venv"
  PIP_ROOT_USER_ACTION=ignore "$venv/bin/pip" install -q --no-input --disable-pip-version-check \
    evo==1.38.1 gtsam==4.3.0
fi
# Real data from the package registries (evo's source distribution, the
# gtsam wheel) into target/data, for the demo on a machine without the
# project's shared data and for the tests of files the shared data lacks
# (the ROS 2 bag). Idempotent: a second run checks and skips.
bash "$root/scripts/fetch_data.sh" "$root/target/data"
