"""turnprint's online loop-closure detector and whole-path matching from
Python, through the C ABI's shared library and ctypes (no build step, no
extension module): copy this file next to your node, build the library
once with `cargo build --release -p turnprint-capi`, and

    from turnprint import Detector
    detector = Detector()                     # or Detector(library="path/to/libturnprint_c.so")
    for t, x, y, z in odometry:
        detector.push(x, y, z, t=t, keyframe=None)
        for c in detector.poll():             # Candidate(query=(first, last), match=..., score, ...)
            ...
    rest, summary = detector.finish()

`match_paths(a, b)` and `find_loops(a)` take lists of (x, y, z). Errors
raise `TurnprintError` with the library's message. The structures mirror
capi/include/turnprint.h field for field.
"""

import ctypes as C
import os
from collections import namedtuple

__all__ = ["Detector", "Candidate", "Hypothesis", "TurnprintError", "match_paths",
           "find_loops", "load"]

ACCEPTED, REJECTED_NON_FINITE, REJECTED_OUT_OF_ORDER, REJECTED_DUPLICATE = 0, 1, 2, 3
SOURCES = ("shape", "proximity", "drift-probe", "network")


class TurnprintError(RuntimeError):
    """A call of the library failed; the message says why."""


class _Options(C.Structure):
    _fields_ = [("top_k", C.c_uint32), ("min_score", C.c_double),
                ("drift_probe", C.c_int), ("wait_for_matching", C.c_int),
                ("drift_min_score", C.c_double), ("proximity", C.c_int),
                ("exclusion_turning", C.c_double), ("max_verify", C.c_uint32),
                ("queue_capacity", C.c_uint32), ("jump_factor", C.c_double),
                ("workers", C.c_uint32)]


class _Pose(C.Structure):
    _fields_ = [("t", C.c_double), ("has_time", C.c_int),
                ("position", C.c_double * 3), ("keyframe", C.c_int64)]


class _Candidate(C.Structure):
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


class _Summary(C.Structure):
    _fields_ = [(name, C.c_uint64) for name in (
        "poses", "accepted", "non_finite", "out_of_order", "duplicate",
        "outliers", "jumps", "segments", "candidates", "skipped",
        "history_bytes", "workers_lost", "parallel_batches")]


class _Hypothesis(C.Structure):
    _fields_ = [("a_first", C.c_uint64), ("a_last", C.c_uint64),
                ("b_first", C.c_uint64), ("b_last", C.c_uint64),
                ("score", C.c_double), ("zncc", C.c_double),
                ("reversed", C.c_int), ("scale", C.c_double),
                ("rotation", C.c_double * 9), ("translation", C.c_double * 3),
                ("rmse", C.c_double), ("turning_deg", C.c_double),
                ("length", C.c_double)]


# A loop-closure candidate: the query (later) part revisits the match
# (earlier) part; p_query = scale * rotation * p_match + translation, with
# rotation as 3 rows. keyframes is (query, match) or None.
Candidate = namedtuple("Candidate", "id at_pose query match score zncc reversed source "
                                    "scale rotation translation keyframes")
# A hypothesis of whole paths: p_A = scale * rotation * p_B + translation.
Hypothesis = namedtuple("Hypothesis", "a b score zncc reversed scale rotation translation "
                                      "rmse turning_deg length")

_library = None


def load(path=None):
    """Loads the shared library (once): `path`, else $TURNPRINT_LIBRARY, else
    libturnprint_c.so in target/release or target/dist of the checkout this
    file sits in."""
    global _library
    if _library is not None and path is None:
        return _library
    if path is None:
        path = os.environ.get("TURNPRINT_LIBRARY")
    if path is None:
        target = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "target")
        built = [os.path.join(target, profile, "libturnprint_c.so") for profile in ("release", "dist")]
        path = next((p for p in built if os.path.exists(p)), None)
        if path is None:
            raise OSError("no libturnprint_c.so in target/release or target/dist: build it with "
                          "`cargo build --release -p turnprint-capi`, or set TURNPRINT_LIBRARY")
    lib = C.CDLL(path)
    lib.tp_options_default.argtypes = [C.POINTER(_Options)]
    lib.tp_detector_new.argtypes = [C.POINTER(_Options)]
    lib.tp_detector_new.restype = C.c_void_p
    lib.tp_detector_push.argtypes = [C.c_void_p, C.POINTER(_Pose)]
    lib.tp_detector_poll.argtypes = [C.c_void_p, C.POINTER(_Candidate), C.c_size_t]
    lib.tp_detector_poll.restype = C.c_int64
    lib.tp_detector_finish.argtypes = [C.c_void_p, C.POINTER(_Summary)]
    lib.tp_detector_free.argtypes = [C.c_void_p]
    lib.tp_last_error.restype = C.c_char_p
    for name in ("tp_match_paths", "tp_find_loops"):
        getattr(lib, name).restype = C.c_int64
    lib.tp_match_paths.argtypes = [C.POINTER(C.c_double), C.c_size_t, C.POINTER(C.c_double),
                                   C.c_size_t, C.POINTER(_Hypothesis), C.c_size_t]
    lib.tp_find_loops.argtypes = [C.POINTER(C.c_double), C.c_size_t,
                                  C.POINTER(_Hypothesis), C.c_size_t]
    _library = lib
    return lib


def _error(lib):
    return TurnprintError(lib.tp_last_error().decode())


def _rows(values):
    return tuple(tuple(values[3 * r:3 * r + 3]) for r in range(3))


class Detector:
    """The online detector: push poses one at a time, poll candidates."""

    def __init__(self, wait_for_matching=False, library=None, **settings):
        """settings: any field of tp_options (top_k, min_score, drift_probe,
        drift_min_score, proximity, exclusion_turning, max_verify,
        queue_capacity, jump_factor, workers); the others keep the defaults."""
        self._handle = None
        self._lib = load(library)
        options = _Options()
        self._lib.tp_options_default(C.byref(options))
        names = {name for name, _ in _Options._fields_}
        for name, value in settings.items():
            if name not in names or name == "wait_for_matching":
                raise TypeError(f"Detector() got an unknown setting {name!r}")
            setattr(options, name, int(value) if isinstance(value, bool) else value)
        options.wait_for_matching = int(wait_for_matching)
        self._handle = self._lib.tp_detector_new(C.byref(options))
        if not self._handle:
            raise _error(self._lib)
        self._batch = (_Candidate * 16)()

    def push(self, x, y, z, t=None, keyframe=None):
        """Feeds one pose; returns 0 (accepted) or the code of why it was
        dropped (NaN, time going back, repeated time)."""
        pose = _Pose(0.0 if t is None else t, int(t is not None),
                     (C.c_double * 3)(x, y, z), -1 if keyframe is None else keyframe)
        code = self._lib.tp_detector_push(self._handle, C.byref(pose))
        if code < 0:
            raise _error(self._lib)
        return code

    def poll(self):
        """The candidates that arrived since the last call."""
        out = []
        while True:
            n = self._lib.tp_detector_poll(self._handle, self._batch, len(self._batch))
            if n < 0:
                raise _error(self._lib)
            for c in self._batch[:n]:
                out.append(Candidate(
                    c.id, c.at_pose, (c.query_first, c.query_last),
                    (c.match_first, c.match_last), c.score, c.zncc, bool(c.reversed),
                    SOURCES[c.source], c.scale, _rows(c.rotation), tuple(c.translation),
                    (c.query_keyframe, c.match_keyframe) if c.has_keyframes else None))
            if n < len(self._batch):
                return out

    def finish(self):
        """Ends the stream: the last candidates and the run's counts (dict)."""
        summary = _Summary()
        if self._lib.tp_detector_finish(self._handle, C.byref(summary)) < 0:
            raise _error(self._lib)
        counts = {name: getattr(summary, name) for name, _ in _Summary._fields_}
        return self.poll(), counts

    def close(self):
        if self._handle:
            self._lib.tp_detector_free(self._handle)
            self._handle = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        self.close()


def _path(points):
    flat = [float(v) for p in points for v in p[:3]]
    return (C.c_double * len(flat))(*flat), len(flat) // 3


def _hypotheses(lib, n, out):
    if n < 0:
        raise _error(lib)
    return [Hypothesis((h.a_first, h.a_last), (h.b_first, h.b_last), h.score, h.zncc,
                       bool(h.reversed), h.scale, _rows(h.rotation), tuple(h.translation),
                       h.rmse, h.turning_deg, h.length) for h in out[:n]]


def match_paths(a, b, top=5, library=None):
    """Where path B overlaps path A (lists of (x, y, z)), best first."""
    lib = load(library)
    (pa, na), (pb, nb) = _path(a), _path(b)
    out = (_Hypothesis * top)()
    return _hypotheses(lib, lib.tp_match_paths(pa, na, pb, nb, out, top), out)


def find_loops(a, top=10, library=None):
    """Places path A (list of (x, y, z)) revisits, best first: `a` is the
    later part, `b` the earlier, both pose ranges of A."""
    lib = load(library)
    pa, na = _path(a)
    out = (_Hypothesis * top)()
    return _hypotheses(lib, lib.tp_find_loops(pa, na, out, top), out)
