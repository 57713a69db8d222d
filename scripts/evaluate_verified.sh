#!/usr/bin/env bash
# Confirmation on rendered runs: the detector streams the monocular ORB-SLAM2
# estimate of KITTI 00, 05, 06 and 08, keyframes are rendered from the ground
# truth with each camera pairing, and the sidecar verifies every candidate.
# Prints one summary line per run and a per-pairing table (precision is
# confirmed true revisits over all confirmed; recall is confirmed true
# candidates over true candidates; truth by the 10 m criterion).
set -euo pipefail
cd "$(dirname "$0")/.."
data=${DATA:-../shared/data}
bin=target/release/turnprint
out=${OUT:-out/verified}
mkdir -p "$out"
for seq in 00 05 06 08; do
  for cams in pinhole pinhole,fisheye pinhole,omni fisheye,omni; do
    $bin stream "$data/kitti_orbslam2_vio/${seq}_orbslam2_tum.txt" --verify \
      --truth "$data/kitti_gt/$seq.txt" --cameras "$cams" --json > "$out/${seq}_${cams/,/-}.jsonl"
    tail -n 1 "$out/${seq}_${cams/,/-}.jsonl" | python3 -c "
import json,sys; s=json.load(sys.stdin)
print('$seq', '$cams', 'candidates', s['candidates'], 'confirmed', s['confirmed'], 'rejected', s['rejected'], 'expired', s['expired'], 'pairings', s['pairings'], 'seconds', round(s['seconds'],1))"
  done
done
python3 - "$out" <<'PY'
import json, sys, glob, collections
rows = collections.defaultdict(lambda: [0, 0, 0, 0, 0])
for f in glob.glob(sys.argv[1] + '/*.jsonl'):
    s = json.loads(open(f).read().strip().splitlines()[-1])
    for k, v in s['pairings'].items():
        rows[k] = [a + b for a, b in zip(rows[k], v)]
print('| pairing | candidates | true candidates | confirmed | confirmed true | confirmed false | precision | recall of true |')
print('|---|--:|--:|--:|--:|--:|--:|--:|')
for k in sorted(rows):
    c, conf, t, tc, fc = rows[k]
    prec = tc / conf if conf else float('nan')
    rec = tc / t if t else float('nan')
    print(f'| {k} | {c} | {t} | {conf} | {tc} | {fc} | {prec:.3f} | {rec:.3f} |')
PY
