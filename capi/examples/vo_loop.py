"""A visual-odometry loop in Python with turnprint's online detector, through
the C ABI's shared library and ctypes (no build step, no extension module):
the same calls as examples/vo_loop.cpp, for a Python or ROS node.

    cargo build --release -p turnprint-capi
    python3 capi/examples/vo_loop.py tests/data/00_orbslam2_tum.txt [--wait] \
        [--lib target/release/libturnprint_c.so]

Prints the same lines as vo_loop.cpp.
"""

import ctypes as C
import sys

# The structures of capi/include/turnprint.h, field for field.
class Options(C.Structure):
    _fields_ = [("top_k", C.c_uint32), ("min_score", C.c_double),
                ("drift_probe", C.c_int), ("wait_for_matching", C.c_int)]


class Pose(C.Structure):
    _fields_ = [("t", C.c_double), ("has_time", C.c_int),
                ("position", C.c_double * 3), ("keyframe", C.c_int64)]


class Candidate(C.Structure):
    _fields_ = [("id", C.c_uint64), ("at_pose", C.c_uint64),
                ("query_first", C.c_uint64), ("query_last", C.c_uint64),
                ("match_first", C.c_uint64), ("match_last", C.c_uint64),
                ("score", C.c_double), ("zncc", C.c_double),
                ("reversed", C.c_int), ("source", C.c_int),
                ("scale", C.c_double), ("rotation", C.c_double * 9),
                ("translation", C.c_double * 3), ("has_keyframes", C.c_int),
                ("query_keyframe", C.c_int64), ("match_keyframe", C.c_int64),
                ("query_keyframe_pose", C.c_uint64),
                ("match_keyframe_pose", C.c_uint64)]


class Summary(C.Structure):
    _fields_ = [(name, C.c_uint64) for name in (
        "poses", "accepted", "non_finite", "out_of_order", "duplicate",
        "outliers", "jumps", "segments", "candidates", "skipped",
        "history_bytes")]


def load(path):
    lib = C.CDLL(path)
    lib.tp_options_default.argtypes = [C.POINTER(Options)]
    lib.tp_detector_new.argtypes = [C.POINTER(Options)]
    lib.tp_detector_new.restype = C.c_void_p
    lib.tp_detector_push.argtypes = [C.c_void_p, C.POINTER(Pose)]
    lib.tp_detector_poll.argtypes = [C.c_void_p, C.POINTER(Candidate), C.c_size_t]
    lib.tp_detector_poll.restype = C.c_int64
    lib.tp_detector_finish.argtypes = [C.c_void_p, C.POINTER(Summary)]
    lib.tp_detector_free.argtypes = [C.c_void_p]
    lib.tp_last_error.restype = C.c_char_p
    return lib


def drain(lib, detector, batch):
    while True:
        n = lib.tp_detector_poll(detector, batch, len(batch))
        for c in batch[:max(n, 0)]:
            print(f"candidate id={c.id} at_pose={c.at_pose} "
                  f"query={c.query_first}-{c.query_last} "
                  f"match={c.match_first}-{c.match_last} score={c.score:.4f} "
                  f"source={c.source} reversed={c.reversed} "
                  f"keyframes={c.query_keyframe}-{c.match_keyframe}")
        if n <= 0:
            return


def main(argv):
    if len(argv) < 2:
        sys.exit("usage: vo_loop.py POSES.tum [--wait] [--lib LIBRARY]")
    lib = load(argv[argv.index("--lib") + 1] if "--lib" in argv
               else "target/release/libturnprint_c.so")
    options = Options()
    lib.tp_options_default(C.byref(options))
    options.wait_for_matching = int("--wait" in argv)
    detector = lib.tp_detector_new(C.byref(options))
    if not detector:
        sys.exit(f"vo_loop.py: {lib.tp_last_error().decode()}")
    batch = (Candidate * 8)()
    index = 0
    with open(argv[1]) as poses:
        for line in poses:
            fields = line.split()
            if not fields or fields[0].startswith("#"):
                continue
            t, x, y, z = map(float, fields[:4])
            pose = Pose(t, 1, (C.c_double * 3)(x, y, z),
                        index if index % 5 == 0 else -1)  # every fifth a keyframe
            index += 1
            if lib.tp_detector_push(detector, C.byref(pose)) < 0:
                sys.exit(f"vo_loop.py: {lib.tp_last_error().decode()}")
            drain(lib, detector, batch)
    summary = Summary()
    lib.tp_detector_finish(detector, C.byref(summary))
    drain(lib, detector, batch)
    print(f"summary poses={summary.poses} accepted={summary.accepted} "
          f"segments={summary.segments} candidates={summary.candidates} "
          f"skipped={summary.skipped} history_bytes={summary.history_bytes}")
    lib.tp_detector_free(detector)


if __name__ == "__main__":
    main(sys.argv)
