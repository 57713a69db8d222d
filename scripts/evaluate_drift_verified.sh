#!/usr/bin/env bash
# The drift probe's candidates checked by the verifier: KITTI 00, 02, 05, 06
# and 08 ground truth through the strong drift model (seeds 1 and 2), streamed
# with (the default) and without the drift probe; keyframes are rendered from the ground
# truth (pinhole cameras) and the sidecar decides every candidate. Prints per
# run: candidates, confirmed, true candidates (10 m criterion), confirmed
# true, confirmed false. FACTOR=f scales the drift (default 1), CAMERAS=list
# sets the cameras (default pinhole).
set -euo pipefail
cd "$(dirname "$0")/.."
data=${DATA:-../shared/data}
out=${OUT:-out/drift_verified}
factor=${FACTOR:-1}
cameras=${CAMERAS:-pinhole}
mkdir -p "$out"
cargo build --release --workspace --all-features --bins
cargo build --release -p turnprint-eval --example drifted
for seq in 00 02 05 06 08; do
  for seed in 1 2; do
    input="$out/${seq}_s$seed.tum"
    target/release/examples/drifted "$data/kitti_gt/$seq.txt" "$seed" "$input" "$factor"
    for probe in --no-drift-probe ""; do
      target/release/turnprint stream "$input" --verify --truth "$data/kitti_gt/$seq.txt" \
        --cameras "$cameras" --json $probe | tail -n 1 | python3 -c "
import json, sys
s = json.load(sys.stdin)
t = [sum(v[i] for v in s['pairings'].values()) for i in range(5)]
print('$seq', 'seed $seed', '${probe:-default}', 'candidates', t[0], 'confirmed', t[1], 'true', t[2], 'confirmed true', t[3], 'confirmed false', t[4])"
    done
  done
done
