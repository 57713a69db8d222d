#!/usr/bin/env bash
# The main demo on a fresh Debian/Ubuntu machine with Rust: installs what it
# needs, then runs turnprint on real KITTI data shipped in tests/data:
#   1. map merging: monocular ORB-SLAM2 (unknown scale, own frame) onto the
#      ground truth of KITTI 00, with a figure;
#   2. loop closures of the monocular path, with a figure;
#   3. the online detector streaming it, with the visual verifier sidecar
#      confirming candidates on rendered keyframes (pinhole/fisheye/omni).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo build --release --all-features --bins 2>&1 | grep -vE '^\s*(Compiling|Downloaded|Downloading)' || true
bin=target/release
mkdir -p out
echo "== 1. merge: monocular ORB-SLAM2 estimate of KITTI 00 onto its ground truth"
$bin/turnprint match tests/data/00.txt tests/data/00_orbslam2_tum.txt --top 3
$bin/turnprint merge tests/data/00.txt tests/data/00_orbslam2_tum.txt -o out/merged_00.tum --plot out/merged_00.png
echo
echo "== 2. loops of the monocular path (no scale, no GPS, no images)"
$bin/turnprint loops tests/data/00_orbslam2_tum.txt --top 5 --plot out/loops_00.png
if [ -x "$bin/turnprint" ] && $bin/turnprint stream --help >/dev/null 2>&1; then
  echo
  echo "== 3. online: stream the monocular path, verify candidates with the sidecar"
  if $bin/turnprint stream --help 2>/dev/null | grep -q -- '--verify'; then
    $bin/turnprint stream tests/data/00_orbslam2_tum.txt --verify --truth tests/data/00.txt --plot out/stream_00.png
  else
    $bin/turnprint stream tests/data/00_orbslam2_tum.txt
  fi
fi
echo
echo "figures and merged path in out/"
