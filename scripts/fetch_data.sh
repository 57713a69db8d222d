#!/usr/bin/env bash
# Real data for the tests and examples on a machine without the shared data
# folder (../shared/data), from the Python package index: the test data that
# evo 1.38.1's source distribution ships (test/data/) and the data that the
# gtsam 4.3.0 wheel ships (gtsam/Data/), laid out like ../shared/data.
#
#   scripts/fetch_data.sh [DIR]     DIR defaults to <repo>/target/data
#
# Then point the tests at it: TURNPRINT_DATA=DIR cargo test ...
#
# Idempotent: files already in DIR are kept, and nothing is downloaded when
# all are there. The two archives are kept in DIR/.downloads and checked
# against the sha256 recorded below before anything is taken from them.
# Needs python3 with pip (downloads only: nothing is installed), as root or
# as a user. One line per file says what it is, its size and whether it is
# byte-identical to the shared folder's copy, when there is one.
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
dir="${1:-$root/target/data}"
shared="$root/../shared/data"

# The evo source distribution (any platform).
EVO_ARCHIVE=evo-1.38.1.tar.gz
EVO_SHA256=1d63faeeb37604641db65bdd08b0e83e71884071de368058a9c45bdcac3fc3f7
# One fixed gtsam wheel, whatever this machine is: its gtsam/Data files are
# the same in every wheel, and a fixed file has a sha256 to check.
GTSAM_ARCHIVE=gtsam-4.3.0-cp311-cp311-manylinux2014_x86_64.manylinux_2_17_x86_64.whl
GTSAM_SHA256=63cae1c925f0094832b7f8d629951d4631cac57c6d7faba140c8ecc9f3c57752

# archive-member destination (relative to DIR)
EVO_FILES=(
  "evo-1.38.1/test/data/KITTI_00_gt.txt kitti_gt/00.txt"
  "evo-1.38.1/test/data/KITTI_00_gt_times.txt kitti_gt/00_times.txt"
  "evo-1.38.1/test/data/KITTI_00_ORB.txt evo/KITTI_00_ORB.txt"
  "evo-1.38.1/test/data/KITTI_00_SPTAM.txt evo/KITTI_00_SPTAM.txt"
  "evo-1.38.1/test/data/fr2_desk_groundtruth.txt evo/fr2_desk_groundtruth.txt"
  "evo-1.38.1/test/data/fr2_desk_ORB_kf_mono.txt evo/fr2_desk_ORB_kf_mono.txt"
  "evo-1.38.1/test/data/georeferenced.tum evo/georeferenced.tum"
  "evo-1.38.1/test/data/V102_groundtruth.csv euroc/V102_groundtruth.csv"
  "evo-1.38.1/test/data/nav2_turtlebot.mcap evo/nav2_turtlebot.mcap"
)
GTSAM_FILES=(
  "gtsam/Data/KittiGps_converted.txt gtsam_data/KittiGps_converted.txt"
  "gtsam/Data/sphere2500.txt gtsam_data/sphere2500.txt"
  "gtsam/Data/sphere2500_groundtruth.txt gtsam_data/sphere2500_groundtruth.txt"
  "gtsam/Data/w10000.graph gtsam_data/w10000.graph"
  "gtsam/Data/ISAM2_GT_city10000.txt gtsam_data/ISAM2_GT_city10000.txt"
  "gtsam/Data/T1_city10000_04.txt gtsam_data/T1_city10000_04.txt"
  "gtsam/Data/victoriaPark_reduced_1k.g2o gtsam_data/victoriaPark_reduced_1k.g2o"
  "gtsam/Data/cityTrees_reduced_1k.g2o gtsam_data/cityTrees_reduced_1k.g2o"
)

die() {
  echo "fetch_data.sh: $*" >&2
  exit 1
}

# Whether any destination of the list named $1 is missing.
missing() {
  local -n list="$1"
  local entry
  for entry in "${list[@]}"; do
    [ -s "$dir/${entry#* }" ] || return 0
  done
  return 1
}

python_with_pip() {
  command -v python3 >/dev/null 2>&1 ||
    die "python3 is missing (Debian/Ubuntu: apt-get install python3 python3-pip)"
  python3 -m pip --version >/dev/null 2>&1 ||
    die "pip is missing for python3 (Debian/Ubuntu: apt-get install python3-pip)"
}

sha256_of() {
  sha256sum "$1" | cut -d' ' -f1
}

# Downloads archive $1 (pip arguments after it) into DIR/.downloads unless
# it is there already, and checks its sha256 against $2.
fetch_archive() {
  local name="$1" sha="$2"
  shift 2
  local file="$dir/.downloads/$name"
  if [ -f "$file" ] && [ "$(sha256_of "$file")" = "$sha" ]; then
    return
  fi
  python_with_pip
  mkdir -p "$dir/.downloads"
  local tmp log
  tmp="$(mktemp -d "$dir/.downloads/tmp.XXXXXX")"
  log="$tmp/pip.log"
  echo "downloading $name ..." >&2
  # Downloads only, so no virtual environment is needed and an externally
  # managed system Python (PEP 668) does not object.
  if ! PIP_ROOT_USER_ACTION=ignore PIP_NO_INPUT=1 python3 -m pip download \
    --disable-pip-version-check -q --no-deps --timeout 30 --retries 2 \
    -d "$tmp" "$@" >"$log" 2>&1; then
    if grep -qiE 'NewConnectionError|Name or service not known|Temporary failure in name resolution|Network is unreachable|ConnectTimeout|Connection refused|ProxyError|Max retries exceeded|ReadTimeout|No route to host' "$log"; then
      tail -n 3 "$log" >&2
      rm -rf "$tmp"
      die "cannot reach the Python package index: no network? ($name not downloaded)"
    fi
    tail -n 15 "$log" >&2
    rm -rf "$tmp"
    die "pip could not download $name (its output is above)"
  fi
  [ -f "$tmp/$name" ] || {
    ls "$tmp" >&2
    rm -rf "$tmp"
    die "pip downloaded something other than $name"
  }
  local got
  got="$(sha256_of "$tmp/$name")"
  if [ "$got" != "$sha" ]; then
    rm -rf "$tmp"
    die "sha256 of $name is $got, expected $sha: not the archive this script knows"
  fi
  mv -f "$tmp/$name" "$file"
  rm -rf "$tmp"
}

# Extracts the missing files of list $2 from archive $1 (tar.gz or zip).
extract() {
  local archive="$dir/.downloads/$1"
  local -n list="$2"
  local entry todo=()
  for entry in "${list[@]}"; do
    [ -s "$dir/${entry#* }" ] || todo+=("$entry")
  done
  [ ${#todo[@]} -gt 0 ] || return 0
  command -v python3 >/dev/null 2>&1 || die "python3 is missing (Debian/Ubuntu: apt-get install python3)"
  # Each member is read by its exact name and written to its destination
  # (through a temporary name, so an interrupted run leaves no half file):
  # no path from the archive is ever used as a path here.
  python3 - "$archive" "$dir" "${todo[@]}" <<'PY'
import os, sys, tarfile, zipfile
archive, out, entries = sys.argv[1], sys.argv[2], sys.argv[3:]
if archive.endswith(".tar.gz"):
    tar = tarfile.open(archive, "r:gz")
    def read(member):
        f = tar.extractfile(member)
        if f is None:
            raise KeyError(member)
        return f.read()
else:
    zf = zipfile.ZipFile(archive)
    read = zf.read
for entry in entries:
    member, dest = entry.split(" ", 1)
    try:
        data = read(member)
    except KeyError:
        sys.exit(f"fetch_data.sh: {os.path.basename(archive)} has no {member}")
    path = os.path.join(out, dest)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path + ".part", "wb") as f:
        f.write(data)
    os.replace(path + ".part", path)
PY
}

mkdir -p "$dir" || die "cannot create $dir"
dir="$(cd "$dir" && pwd)"

declare -A fetched=()
for pair in "EVO_FILES $EVO_ARCHIVE $EVO_SHA256" "GTSAM_FILES $GTSAM_ARCHIVE $GTSAM_SHA256"; do
  read -r list archive sha <<<"$pair"
  missing "$list" || continue
  declare -n entries="$list"
  for entry in "${entries[@]}"; do
    [ -s "$dir/${entry#* }" ] || fetched["${entry#* }"]=1
  done
  unset -n entries
  if [ "$list" = EVO_FILES ]; then
    fetch_archive "$archive" "$sha" evo==1.38.1 --no-binary :all:
  else
    fetch_archive "$archive" "$sha" gtsam==4.3.0 --only-binary :all: \
      --platform manylinux2014_x86_64 --python-version 3.11 --implementation cp --abi cp311
  fi
  extract "$archive" "$list"
done

same_dir=0
if [ -d "$shared" ]; then
  shared="$(cd "$shared" && pwd)"
  [ "$shared" = "$dir" ] && same_dir=1
fi
identical=0 differ=0
for entry in "${EVO_FILES[@]}" "${GTSAM_FILES[@]}"; do
  rel="${entry#* }"
  size="$(stat -c %s "$dir/$rel")"
  state="kept"
  [ -n "${fetched[$rel]:-}" ] && state="fetched"
  if [ "$same_dir" = 1 ]; then
    note=""
  elif [ -f "$shared/$rel" ]; then
    if cmp -s "$dir/$rel" "$shared/$rel"; then
      note="identical to the shared copy"
      identical=$((identical + 1))
    else
      note="DIFFERS from the shared copy"
      differ=$((differ + 1))
    fi
  else
    note="no shared copy"
  fi
  printf '%-7s %-38s %9s bytes  %s\n' "$state" "$rel" "$size" "$note"
done
if [ "$same_dir" = 1 ]; then
  echo "data in $dir (the shared folder itself)"
elif [ -d "$shared" ]; then
  echo "data in $dir ($identical files identical to $shared, $differ different); tests and the demo look there after \$TURNPRINT_DATA and ../shared/data"
else
  echo "data in $dir (no shared folder at $shared to compare with); tests and the demo look there after \$TURNPRINT_DATA and ../shared/data"
fi
