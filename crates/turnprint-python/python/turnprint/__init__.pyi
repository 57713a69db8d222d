"""Type stubs of turnprint (the classes live in the Rust extension
turnprint._turnprint; see __init__.py for the overview)."""

from os import PathLike
from typing import Any, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str
FORMATS: Tuple[str, ...]

ArrayLike = npt.ArrayLike
StrPath = Union[str, "PathLike[str]"]
F64Array = npt.NDArray[np.float64]

class TurnprintError(Exception):
    """A call failed on its input; the message is the library's."""

class Hypothesis:
    """One ranked hypothesis of `match_paths` (`a_range`, `b_range`) or
    `find_loops` (`query_range`, `match_range`); reading the other kind's
    range names raises AttributeError."""

    @property
    def rank(self) -> int: ...
    @property
    def score(self) -> float: ...
    @property
    def zncc(self) -> float: ...
    @property
    def reversed(self) -> bool: ...
    @property
    def a_range(self) -> Tuple[int, int]: ...
    @property
    def b_range(self) -> Tuple[int, int]: ...
    @property
    def query_range(self) -> Tuple[int, int]: ...
    @property
    def match_range(self) -> Tuple[int, int]: ...
    @property
    def scale(self) -> float: ...
    @property
    def rotation(self) -> F64Array:
        """3x3, row-major: p_A = scale * rotation @ p_B + translation."""
    @property
    def translation(self) -> F64Array:
        """(3,)."""
    @property
    def rmse(self) -> float: ...
    @property
    def turning_deg(self) -> float: ...
    @property
    def length(self) -> float: ...
    def transform(self, points: ArrayLike) -> F64Array:
        """Points of B (loops: of the match part) in A's frame, (N, 3)."""
    def to_dict(self) -> dict[str, Any]:
        """The command line's JSON object of this hypothesis."""

class Candidate:
    """A loop-closure candidate of the `Detector`: the fields of
    `turnprint stream --json`'s candidate events."""

    @property
    def id(self) -> int: ...
    @property
    def at_pose(self) -> int: ...
    @property
    def rank(self) -> int: ...
    @property
    def score(self) -> float: ...
    @property
    def zncc(self) -> float: ...
    @property
    def reversed(self) -> bool: ...
    @property
    def query_range(self) -> Tuple[int, int]: ...
    @property
    def match_range(self) -> Tuple[int, int]: ...
    @property
    def scale(self) -> float: ...
    @property
    def rotation(self) -> F64Array: ...
    @property
    def translation(self) -> F64Array: ...
    @property
    def rmse(self) -> float: ...
    @property
    def turning_deg(self) -> float: ...
    @property
    def source(self) -> str:
        """'shape', 'proximity', 'drift-probe' or 'network'."""
    @property
    def keyframes(self) -> Optional[dict[str, int]]: ...
    @property
    def query_keyframes(self) -> list[int]: ...
    @property
    def match_keyframes(self) -> list[int]: ...
    def transform(self, points: ArrayLike) -> F64Array: ...
    def to_dict(self) -> dict[str, Any]: ...

class Detector:
    """The online loop-closure detector."""

    def __init__(
        self,
        *,
        top_k: Optional[int] = None,
        min_score: Optional[float] = None,
        drift_probe: Optional[bool] = None,
        drift_min_score: Optional[float] = None,
        proximity: Optional[bool] = None,
        exclusion_turning: Optional[float] = None,
        max_verify: Optional[int] = None,
        queue_capacity: Optional[int] = None,
        jump_factor: Optional[float] = None,
        workers: Optional[int] = None,
        wait_for_matching: bool = False,
    ) -> None: ...
    def push(
        self,
        x: float,
        y: float,
        z: float = 0.0,
        t: Optional[float] = None,
        keyframe: Optional[int] = None,
    ) -> bool:
        """True when the pose was taken, False when a guard dropped it."""
    def push_many(self, points: ArrayLike, times: Optional[ArrayLike] = None) -> int:
        """Pushes every row; returns how many were taken."""
    def poll(self) -> list[Candidate]: ...
    def finish(self) -> Tuple[list[Candidate], dict[str, Any]]: ...
    @property
    def poses(self) -> int: ...
    @property
    def finished(self) -> bool: ...

class Trajectory:
    positions: F64Array
    times: Optional[F64Array]
    orientations: Optional[F64Array]
    source: str
    def __init__(
        self,
        positions: ArrayLike,
        times: Optional[ArrayLike] = None,
        orientations: Optional[ArrayLike] = None,
        source: str = "points",
    ) -> None: ...
    def __len__(self) -> int: ...

def as_points(points: ArrayLike) -> F64Array: ...
def read_trajectory(path: StrPath, format: str = "auto") -> F64Array: ...
def read_trajectory_full(path: StrPath, format: str = "auto") -> Trajectory: ...
def match_paths(a: ArrayLike, b: ArrayLike, top: Optional[int] = None) -> list[Hypothesis]: ...
def find_loops(points: ArrayLike, top: Optional[int] = None) -> list[Hypothesis]: ...
def correct(
    points: ArrayLike, times: Optional[ArrayLike] = None, group: str = "auto"
) -> F64Array: ...
def write_tum(
    path: StrPath,
    points: ArrayLike,
    times: Optional[ArrayLike] = None,
    orientations: Optional[ArrayLike] = None,
) -> None: ...
def from_evo(traj: Any) -> Trajectory: ...
def to_evo(
    points: Union[Trajectory, ArrayLike],
    times: Optional[ArrayLike] = None,
    orientations: Optional[ArrayLike] = None,
) -> Any: ...
