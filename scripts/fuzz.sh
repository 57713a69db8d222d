#!/usr/bin/env bash
# Fuzzes every reader and the online detector (the targets in fuzz/) for
# SECONDS each, default 20, and fails if any target crashes, hangs (two
# minutes on one input) or breaks a property it checks.
#
#   scripts/fuzz.sh [SECONDS]
#
# Needs the nightly toolchain (libFuzzer's instrumentation); installs
# cargo-fuzz when it is missing. When the shared data is there
# (TURNPRINT_DATA, default ../shared/data) the readers' corpora are seeded
# from the first lines of real files: the seeds are made here, at run time,
# because third-party data is never copied into the repository.
# Crashing inputs are left in fuzz/artifacts/<target>/; replay one with
# `cargo +nightly fuzz run <target> <file>`.
set -euo pipefail
cd "$(dirname "$0")/.."

seconds="${1:-20}"
data="${TURNPRINT_DATA:-../shared/data}"

# Without a nightly toolchain (none installed, none fetchable) there is no
# libFuzzer: say so and stop, unless TURNPRINT_FUZZ_REQUIRED=1. The crashes
# found so far are replayed on stable by tests/fuzz_regressions.rs either way.
if ! rustup toolchain list | grep -q '^nightly' &&
    ! rustup toolchain install nightly --profile minimal; then
    echo "fuzz.sh: skipped: no nightly toolchain and none could be installed" >&2
    [ "${TURNPRINT_FUZZ_REQUIRED:-0}" = 1 ] && exit 1
    exit 0
fi
if ! cargo +nightly fuzz --version >/dev/null 2>&1; then
    cargo install cargo-fuzz
fi

# The first `lines` lines of `$data/$file` as a seed of `target`.
seed() {
    local target="$1" file="$2" lines="${3:-20}"
    [ -f "$data/$file" ] || return 0
    mkdir -p "fuzz/corpus/$target"
    head -n "$lines" "$data/$file" >"fuzz/corpus/$target/$(basename "$file").seed"
}

# The first `points` track points of a multi-line GPX file, closed again so
# that the seed is valid GPX.
seed_gpx() {
    local target="$1" file="$2" points="${3:-5}"
    [ -f "$data/$file" ] || return 0
    mkdir -p "fuzz/corpus/$target"
    awk -v n="$points" '
        { print }
        /<\/trkpt>/ && ++seen >= n { exit }
        END { print "</trkseg></trk></gpx>" }
    ' "$data/$file" >"fuzz/corpus/$target/$(basename "$file").seed"
}

# Positions only, from a KITTI file (whitespace) and a CARMEN log (commas).
seed_xyz() {
    local target="$1"
    [ -f "$data/kitti_gt/00.txt" ] && [ -f "$data/carmen/intel_odom.csv" ] || return 0
    mkdir -p "fuzz/corpus/$target"
    head -n 20 "$data/kitti_gt/00.txt" | awk '{ print $4, $8, $12 }' \
        >"fuzz/corpus/$target/kitti_00.xyz.seed"
    sed -n 2,21p "$data/carmen/intel_odom.csv" | cut -d, -f2,3 \
        >"fuzz/corpus/$target/intel_odom.xyz.seed"
}

seed_readers() {
    local t
    for t in read_tum read_auto; do
        seed "$t" evo/fr2_desk_groundtruth.txt
        seed "$t" euroc/MH_01_easy.txt
        seed "$t" kitti_orbslam2_vio/00_orbslam2_tum.txt
    done
    for t in read_kitti read_auto; do
        seed "$t" kitti_gt/00.txt
        seed "$t" evo/KITTI_00_SPTAM.txt
    done
    for t in read_euroc read_auto; do
        seed "$t" euroc/V102_groundtruth.csv
    done
    for t in read_csv read_auto; do
        seed "$t" carmen/intel_odom.csv
        seed "$t" gtsam_data/KittiGps_converted.txt
    done
    for t in read_xyz read_auto; do
        seed_xyz "$t"
    done
    for t in read_gpx read_auto; do
        seed_gpx "$t" multisession/gpx_same_route/arbatov/Afternoon_Walk_Strava_App.gpx
        seed_gpx "$t" multisession/gpx_same_route/uli_heller_bad_mergentheim/2022-02-06_7x.gpx
        seed_gpx "$t" multisession/gpx_same_route/routage/Guichet_asc_orux.gpx
    done
}

# evo's ROS 2 bag, from the set-up cache (the shared data has none).
seed_mcap() {
    local bag=target/data/evo/nav2_turtlebot.mcap
    mkdir -p fuzz/corpus/read_mcap
    [ -f "$bag" ] && cp "$bag" fuzz/corpus/read_mcap/nav2_turtlebot.mcap.seed
    return 0
}

# The dictionary of a target, if it has one.
dict_for() {
    case "$1" in
    read_gpx) echo fuzz/dict/gpx.dict ;;
    read_auto) echo fuzz/dict/auto.dict ;;
    read_*) echo fuzz/dict/lines.dict ;;
    esac
}

seed_mcap
if [ -d "$data" ]; then
    seed_readers
else
    echo "fuzz.sh: $data is absent (set TURNPRINT_DATA): corpora start empty" >&2
fi

cargo +nightly fuzz build
failed=()
for target in $(cargo +nightly fuzz list); do
    corpus="fuzz/corpus/$target"
    mkdir -p "$corpus"
    # A hang never ends; the slowest honest inputs of detector_stream take
    # tens of seconds instrumented on a loaded machine.
    args=(-max_total_time="$seconds" -timeout=120 -print_final_stats=1)
    dict="$(dict_for "$target")"
    [ -n "$dict" ] && [ -f "$dict" ] && args+=(-dict="$dict")
    echo "== $target ($seconds s)"
    if ! cargo +nightly fuzz run "$target" "$corpus" -- "${args[@]}"; then
        failed+=("$target")
    fi
done
if [ ${#failed[@]} -gt 0 ]; then
    echo "fuzz.sh: failed: ${failed[*]} (inputs in fuzz/artifacts/)" >&2
    exit 1
fi
echo "fuzz.sh: no crash in ${seconds} s per target"
