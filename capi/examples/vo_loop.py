"""A visual-odometry loop in Python with turnprint's online detector
(capi/python/turnprint.py: ctypes on the C ABI's shared library, no build
step): the same loop as vo_loop.cpp, for a Python or ROS node.

    cargo build --release -p turnprint-capi
    python3 capi/examples/vo_loop.py tests/data/00_orbslam2_tum.txt [--wait] \
        [--lib target/release/libturnprint_c.so] [--set NAME=VALUE ...]

--set changes one of the detector's settings (a field of tp_options, e.g.
--set proximity=0 --set exclusion_turning=3.14).

Prints the same lines as vo_loop.cpp.
"""

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python"))
import turnprint  # noqa: E402


def show(candidates):
    for c in candidates:
        keyframes = c.keyframes or (-1, -1)
        print(f"candidate id={c.id} at_pose={c.at_pose} query={c.query[0]}-{c.query[1]} "
              f"match={c.match[0]}-{c.match[1]} score={c.score:.4f} "
              f"source={turnprint.SOURCES.index(c.source)} reversed={int(c.reversed)} "
              f"keyframes={keyframes[0]}-{keyframes[1]}")


def main(argv):
    if len(argv) < 2:
        sys.exit("usage: vo_loop.py POSES.tum [--wait] [--lib LIBRARY] [--set NAME=VALUE ...]")
    library = argv[argv.index("--lib") + 1] if "--lib" in argv else None
    settings = {}
    for i, arg in enumerate(argv):
        if arg == "--set":
            name, value = argv[i + 1].split("=", 1)
            settings[name] = float(value) if "." in value else int(value)
    with turnprint.Detector(wait_for_matching="--wait" in argv, library=library,
                            **settings) as detector, open(argv[1]) as poses:
        index = 0
        for line in poses:
            fields = line.split()
            if not fields or fields[0].startswith("#"):
                continue
            t, x, y, z = map(float, fields[:4])
            # every fifth pose a keyframe
            detector.push(x, y, z, t=t, keyframe=index if index % 5 == 0 else None)
            index += 1
            show(detector.poll())
        rest, summary = detector.finish()
        show(rest)
    print(f"summary poses={summary['poses']} accepted={summary['accepted']} "
          f"segments={summary['segments']} candidates={summary['candidates']} "
          f"skipped={summary['skipped']} history_bytes={summary['history_bytes']} "
          f"parallel_batches={summary['parallel_batches']}")


if __name__ == "__main__":
    main(sys.argv)
