#!/usr/bin/env bash
# The main demo on a fresh Debian/Ubuntu machine with Rust: installs what it
# needs, fetches real data from PyPI (scripts/fetch_data.sh), then runs
# turnprint on it:
#   1. map merging: a hand-held camera's monocular ORB-SLAM2 keyframes
#      (unknown scale, own frame) into the frame of its motion capture;
#   2. loops of a drifting stereo odometry of KITTI 00 (S-PTAM, no loop
#      closure), with a figure;
#   3. its drift corrected by those loops, against the ground truth;
#   4. the online detector streaming it, with the visual verifier sidecar
#      confirming candidates on rendered keyframes (pinhole/fisheye/omni).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo build --release --workspace --all-features --bins 2>&1 | grep -vE '^\s*(Compiling|Downloaded|Downloading)' || true
bin=target/release
# Real data: $TURNPRINT_DATA, the project's shared data beside the
# repository, or the registry cache setup.sh filled.
data() {
  for d in ${TURNPRINT_DATA:-} ../shared/data target/data; do
    [ -f "$d/$1" ] && { echo "$d/$1"; return; }
  done
  echo "missing data file $1 (run scripts/fetch_data.sh)" >&2; exit 1
}
gt=$(data kitti_gt/00.txt)
sptam=$(data evo/KITTI_00_SPTAM.txt)
mkdir -p out
echo "== 1. merge: monocular keyframes of a hand-held camera (unknown scale) onto its motion capture"
$bin/turnprint match "$(data evo/fr2_desk_groundtruth.txt)" "$(data evo/fr2_desk_ORB_kf_mono.txt)" --top 3
$bin/turnprint merge "$(data evo/fr2_desk_groundtruth.txt)" "$(data evo/fr2_desk_ORB_kf_mono.txt)" -o out/fr2_merged.tum --plot out/fr2_merged.png
echo
echo "== 2. loops of S-PTAM's drifting stereo odometry of KITTI 00 (no images, no GPS)"
$bin/turnprint loops "$sptam" --top 5 --plot out/loops_00.png
echo
echo "== 3. its drift corrected by those loops (APE against the ground truth in the JSON)"
$bin/turnprint correct "$sptam" -o out/corrected_00.tum --plot out/corrected_00.png
echo
echo "== 4. online: stream it pose by pose, candidates verified by the sidecar on rendered keyframes"
$bin/turnprint stream "$sptam" --verify --truth "$gt" --plot out/stream_00.png
echo
echo "figures, merged and corrected paths in out/"
