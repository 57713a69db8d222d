"""Whole paths from Python (capi/python/turnprint.py), run by
tests/c_abi.rs: prints the same lines as merge_paths.c, after checking that
bad input raises TurnprintError.

    merge_paths.py A.kitti B.tum LIBRARY
"""

import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python"))
import turnprint  # noqa: E402


def read(path, kitti):
    columns = (3, 7, 11) if kitti else (1, 2, 3)
    with open(path) as f:
        return [tuple(float(line.split()[c]) for c in columns) for line in f if line.strip()]


def raises(call, words):
    try:
        call()
    except turnprint.TurnprintError as e:
        assert words in str(e), f"{words!r} not in {e}"
        return
    raise AssertionError(f"no error (expected {words!r})")


def main(argv):
    a, b, library = read(argv[1], True), read(argv[2], False), argv[3]
    turnprint.load(library)
    raises(lambda: turnprint.match_paths(a[:3], b), "poses")
    raises(lambda: turnprint.match_paths(a, b[:10] + [(math.nan, 0, 0)] + b[11:]), "non-finite")
    raises(lambda: turnprint.find_loops([(1.0, 1.0, 1.0)] * 200), "does not move")
    # The detector's settings: out of range, or not one.
    raises(lambda: turnprint.Detector(min_score=2.0, library=library), "min_score")
    raises(lambda: turnprint.Detector(max_verify=0, library=library), "max_verify")
    try:
        turnprint.Detector(bogus=1, library=library)
    except TypeError as e:
        assert "bogus" in str(e), e
    else:
        raise AssertionError("an unknown setting was taken")
    for what, found in (("match", turnprint.match_paths(a, b, top=5)),
                        ("loop", turnprint.find_loops(b, top=5))):
        for h in found:
            print(f"{what} a={h.a[0]}-{h.a[1]} b={h.b[0]}-{h.b[1]} score={h.score:.4f} "
                  f"scale={h.scale:.4f} reversed={int(h.reversed)}")


if __name__ == "__main__":
    main(sys.argv)
