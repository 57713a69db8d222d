"""turnprint: find where robot paths overlap by the shape of their turns,
whatever their scale, frame and direction of travel.

Paths are numpy arrays of positions, (N, 3) float64 (any array-like works,
and (N, 2) gets z = 0); pose indices are rows of those arrays.

    import turnprint
    gt = turnprint.read_trajectory("00.txt")                # (N, 3)
    for h in turnprint.find_loops(gt):                      # best first
        print(h.query_range, h.match_range, h.score)
    for h in turnprint.match_paths(gt, other):              # other onto gt
        print(h.a_range, h.b_range, h.scale, h.rotation, h.translation)
    fixed = turnprint.correct(drifting)                     # (N, 3)

    detector = turnprint.Detector(wait_for_matching=True)   # online
    for t, (x, y, z) in zip(times, positions):
        detector.push(x, y, z, t=t)
        for c in detector.poll():                           # Candidate
            ...
    rest, summary = detector.finish()

The attributes of `Hypothesis` and `Candidate` are the fields of the
command line's JSON (`turnprint match/loops/stream --json`, docs/cli.md),
with `rotation` a 3x3 and `translation` a (3,) array: the similarity is
`p_A = scale * rotation @ p_B + translation` (loops and candidates: the
match part onto the query part). A path the library cannot use raises
`TurnprintError` with the library's message; an array of the wrong shape
raises `ValueError`.

evo (https://github.com/MichaelGrupp/evo): `from_evo(traj)` takes a
`PoseTrajectory3D`, `to_evo(...)` makes one, and `write_tum` writes the TUM
files evo reads (`evo_ape tum gt.txt corrected.txt`).
"""

from __future__ import annotations

import numpy as _np

from ._turnprint import (  # noqa: F401  (re-exported)
    Candidate,
    Detector,
    Hypothesis,
    TurnprintError,
    __version__,
)
from . import _turnprint as _native

__all__ = [
    "Candidate",
    "Detector",
    "Hypothesis",
    "Trajectory",
    "TurnprintError",
    "as_points",
    "correct",
    "find_loops",
    "from_evo",
    "match_paths",
    "read_trajectory",
    "read_trajectory_full",
    "to_evo",
    "write_tum",
]

FORMATS = ("auto", "tum", "kitti", "euroc", "xyz", "gpx", "csv")


class Trajectory:
    """A trajectory as read from a file (or taken from evo): `positions`
    (N, 3), `times` (N,) in seconds or None, `orientations` (N, 4) as
    (qx, qy, qz, qw) or None, and `source`, where it came from."""

    __slots__ = ("positions", "times", "orientations", "source")

    def __init__(self, positions, times=None, orientations=None, source="points"):
        self.positions = _native.as_points(positions)
        n = len(self.positions)
        self.times = None if times is None else _np.asarray(times, dtype=_np.float64)
        if self.times is not None and self.times.shape != (n,):
            raise ValueError(f"times must have shape ({n},), not {self.times.shape}")
        self.orientations = (None if orientations is None
                             else _np.asarray(orientations, dtype=_np.float64))
        if self.orientations is not None and self.orientations.shape != (n, 4):
            raise ValueError(f"orientations must have shape ({n}, 4), not "
                             f"{self.orientations.shape}")
        self.source = str(source)

    def __len__(self):
        return len(self.positions)

    def __repr__(self):
        return (f"Trajectory({self.source!r}, {len(self)} poses, "
                f"times={'yes' if self.times is not None else 'no'}, "
                f"orientations={'yes' if self.orientations is not None else 'no'})")


def as_points(points) -> _np.ndarray:
    """`points` as the (N, 3) float64 array every function reads it as
    ((N, 2) gets z = 0); ValueError when it is not such an array."""
    return _native.as_points(points)


def read_trajectory(path, format="auto") -> _np.ndarray:
    """The positions of a trajectory file, (N, 3). `format`: one of
    `FORMATS` (`auto`: by extension, then by content), as `--format` of the
    command line."""
    return _native.read_trajectory_arrays(path, format)[0]


def read_trajectory_full(path, format="auto") -> Trajectory:
    """A trajectory file with its timestamps and orientations (where the
    format has them) as a `Trajectory`."""
    positions, times, orientations, source = _native.read_trajectory_arrays(path, format)
    return Trajectory(positions, times, orientations, source)


def match_paths(a, b, top=None) -> list[Hypothesis]:
    """Where path `b` overlaps path `a`, best first (at most `top`,
    default 5). Each `Hypothesis` has `a_range` and `b_range`, and the
    similarity that maps `b` into `a`'s frame."""
    return _native.match_paths(a, b, top)


def find_loops(points, top=None) -> list[Hypothesis]:
    """The places path `points` revisits, best first (at most `top`,
    default 10). Each `Hypothesis` has `query_range` (the later part) and
    `match_range`, and the similarity that maps the match part onto the
    query part."""
    return _native.find_loops(points, top)


def correct(points, times=None, group="auto") -> _np.ndarray:
    """`points` without the drift its loops reveal: the corrected
    positions, (N, 3), row i for row i (as `turnprint correct`). A path
    with no loop kept comes back unchanged. `group`: "auto", "se3" (metric
    odometry) or "sim3" (monocular), as `turnprint correct --group`."""
    return _native.correct(points, times, group)


def write_tum(path, points, times=None, orientations=None) -> None:
    """Writes positions as a TUM file (`t x y z qx qy qz qw`): `times` in
    seconds, else the row index; `orientations` (N, 4) as (qx, qy, qz, qw),
    else the identity. evo and `read_trajectory` read it back."""
    _native.write_tum(path, points, times, orientations)


def from_evo(traj) -> Trajectory:
    """An evo trajectory (`PoseTrajectory3D`, or a `PosePath3D` without
    timestamps) as a `Trajectory`: its `positions_xyz`, `timestamps` and
    orientations (evo's (qw, qx, qy, qz) turned into (qx, qy, qz, qw))."""
    times = getattr(traj, "timestamps", None)
    wxyz = getattr(traj, "orientations_quat_wxyz", None)
    xyzw = None if wxyz is None else _np.roll(_np.asarray(wxyz, dtype=_np.float64), -1, axis=1)
    return Trajectory(traj.positions_xyz, times, xyzw, source="evo")


def to_evo(points, times=None, orientations=None):
    """Positions (a `Trajectory` or an (N, 3) array, with `times` and
    `orientations` (qx, qy, qz, qw) if any: the identity where none) as an
    evo `PoseTrajectory3D`; times default to the row index. Needs evo."""
    from evo.core.trajectory import PoseTrajectory3D

    if isinstance(points, Trajectory):
        points, times, orientations = (points.positions,
                                       points.times if times is None else times,
                                       points.orientations if orientations is None else orientations)
    xyz = _native.as_points(points)
    n = len(xyz)
    t = _np.arange(n, dtype=_np.float64) if times is None else _np.asarray(times, dtype=_np.float64)
    if orientations is None:
        wxyz = _np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    else:
        wxyz = _np.roll(_np.asarray(orientations, dtype=_np.float64), 1, axis=1)
    return PoseTrajectory3D(positions_xyz=xyz, orientations_quat_wxyz=wxyz, timestamps=t)
