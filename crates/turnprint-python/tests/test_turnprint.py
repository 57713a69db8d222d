"""The Python package on KITTI 00's ground truth (numpy arrays): loops that
revisit, a scaled and rotated window matched back at its scale, the online
detector's candidates, drift correction, bad input, evo interoperability.

Run by scripts/test_python.sh (which builds the package into a venv of its
own); the data is KITTI's, found where the Rust tests find it."""

import math
import os
import pathlib
import threading

import numpy as np
import pytest

import turnprint

REPO = pathlib.Path(__file__).resolve().parents[3]


def _kitti_gt_00():
    """KITTI 00's ground truth: $TURNPRINT_DATA/kitti_gt, then the shared
    data beside the repository, then target/data."""
    places = []
    if os.environ.get("TURNPRINT_DATA"):
        places.append(pathlib.Path(os.environ["TURNPRINT_DATA"]) / "kitti_gt" / "00.txt")
    places += [REPO.parent / "shared" / "data" / "kitti_gt" / "00.txt",
               REPO / "target" / "data" / "kitti_gt" / "00.txt"]
    return next((p for p in places if p.exists()), None)


@pytest.fixture(scope="module")
def gt_file():
    path = _kitti_gt_00()
    if path is None:
        pytest.skip("no KITTI 00 ground truth (kitti_gt/00.txt under $TURNPRINT_DATA, "
                    "../shared/data or target/data)")
    return path


@pytest.fixture(scope="module")
def gt(gt_file):
    return turnprint.read_trajectory(gt_file)


def median_nearest(part, other):
    """Median distance from each point of `part` to the nearest of `other`."""
    nearest = np.empty(len(part))
    for i in range(0, len(part), 256):
        d = np.linalg.norm(part[i:i + 256, None, :] - other[None, :, :], axis=2)
        nearest[i:i + 256] = d.min(axis=1)
    return float(np.median(nearest))


def revisits(gt, query, match, within=10.0):
    """True when the two ranges (inclusive) are the same road in the ground
    truth's own frame."""
    q = gt[query[0]:query[1] + 1]
    m = gt[match[0]:match[1] + 1]
    return median_nearest(q, m) <= within


def rotation(axis, angle):
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


# --- reading ---------------------------------------------------------------

def test_read_trajectory_gives_the_kitti_positions(gt_file, gt):
    rows = np.loadtxt(gt_file)
    assert gt.shape == (len(rows), 3) and gt.dtype == np.float64
    np.testing.assert_array_equal(gt, rows[:, [3, 7, 11]])
    full = turnprint.read_trajectory_full(gt_file, format="kitti")
    assert full.times is None and len(full) == len(rows)
    assert full.orientations.shape == (len(rows), 4)
    np.testing.assert_array_equal(full.positions, gt)


def test_write_tum_reads_back_the_same_poses(tmp_path, gt):
    times = 0.1 * np.arange(len(gt)) + 17.0
    out = tmp_path / "gt.tum"
    turnprint.write_tum(out, gt, times)
    back = turnprint.read_trajectory_full(out)
    np.testing.assert_array_equal(back.positions, gt)
    np.testing.assert_array_equal(back.times, times)
    np.testing.assert_array_equal(back.orientations, np.tile([0.0, 0.0, 0.0, 1.0], (len(gt), 1)))


# --- whole paths -----------------------------------------------------------

def test_find_loops_finds_the_revisits_of_kitti_00(gt):
    loops = turnprint.find_loops(gt)
    assert 3 <= len(loops) <= 10
    assert [h.rank for h in loops] == list(range(1, len(loops) + 1))
    assert all(a.score >= b.score for a, b in zip(loops, loops[1:]))
    # The best ones are true revisits: the two parts are one road.
    for h in loops[:3]:
        assert h.query_range[0] > h.match_range[0], h
        assert revisits(gt, h.query_range, h.match_range), h
    # The similarity of a ground-truth loop is close to the identity.
    best = loops[0]
    assert abs(best.scale - 1.0) < 0.05, best
    match = gt[best.match_range[0]:best.match_range[1] + 1]
    query = gt[best.query_range[0]:best.query_range[1] + 1]
    assert median_nearest(best.transform(match), query) < 5.0
    assert len(turnprint.find_loops(gt, top=2)) <= 2


def test_match_paths_recovers_the_scale_of_a_transformed_window(gt):
    window = gt[1000:2200]
    r = rotation([0.3, -0.5, 1.0], 2.1)
    scale, shift = 0.037, np.array([120.0, -4.0, 33.0])
    copy = scale * window @ r.T + shift
    found = turnprint.match_paths(gt, copy)
    assert found, "no hypothesis"
    best = found[0]
    # p_gt = best.scale * rotation @ p_copy + translation: the inverse map.
    assert abs(best.scale * scale - 1.0) < 0.01, best
    np.testing.assert_allclose(best.rotation @ r, np.eye(3), atol=0.01)
    assert best.a_range[0] < 2200 and best.a_range[1] > 1000, best
    assert best.b_range[1] - best.b_range[0] > 600, best
    assert not best.reversed
    mapped = best.transform(copy[best.b_range[0]:best.b_range[1] + 1])
    truth = gt[1000 + best.b_range[0]:1000 + best.b_range[1] + 1]
    assert np.median(np.linalg.norm(mapped - truth, axis=1)) < 2.0
    # Travelled backwards, it is found reversed.
    back = turnprint.match_paths(gt, copy[::-1], top=3)
    assert back and back[0].reversed and abs(back[0].scale * scale - 1.0) < 0.01, back


def test_hypotheses_carry_the_json_fields_of_the_command_line(gt):
    loop = turnprint.find_loops(gt, top=1)[0]
    keys = {"rank", "score", "zncc", "reversed", "query_range", "match_range", "scale",
            "rotation", "translation", "rmse", "turning_deg"}
    assert set(loop.to_dict()) == keys
    assert loop.to_dict()["query_range"] == list(loop.query_range)
    assert loop.rotation.shape == (3, 3) and loop.translation.shape == (3,)
    np.testing.assert_allclose(loop.rotation @ loop.rotation.T, np.eye(3), atol=1e-9)
    with pytest.raises(AttributeError, match="query_range and match_range"):
        loop.a_range
    assert "query_range=" in repr(loop) and "score=" in repr(loop)
    h = turnprint.match_paths(gt, gt[2000:3000], top=1)[0]
    assert set(h.to_dict()) == keys - {"query_range", "match_range"} | {"a_range", "b_range"}
    with pytest.raises(AttributeError):
        h.match_range
    assert "a_range=" in repr(h)


def test_two_dimensional_and_list_input_are_taken(gt):
    part = gt[:1500]
    flat = part[:, [0, 2]]  # KITTI drives in x-z
    a = turnprint.as_points(flat)
    assert a.shape == (1500, 3) and not a[:, 2].any()
    found = turnprint.match_paths(flat.tolist(), flat[300:900], top=1)
    assert found and abs(found[0].scale - 1.0) < 0.01


def test_long_calls_let_other_python_threads_run(gt):
    # find_loops detaches from the interpreter: a Python thread counting
    # meanwhile gets far.
    counted, done = [0], threading.Event()

    def count():
        while not done.is_set():
            counted[0] += 1

    counter = threading.Thread(target=count)
    counter.start()
    try:
        before = counted[0]
        turnprint.find_loops(gt, top=1)
        during = counted[0] - before
    finally:
        done.set()
        counter.join()
    assert during > 1000, during


# --- online ----------------------------------------------------------------

def test_the_detector_streamed_over_kitti_00_emits_correct_candidates(gt):
    detector = turnprint.Detector(wait_for_matching=True)
    candidates = []
    for i, (x, y, z) in enumerate(gt):
        assert detector.push(x, y, z, keyframe=i if i % 5 == 0 else None)
        candidates += detector.poll()
    rest, summary = detector.finish()
    candidates += rest
    assert summary["poses"] == summary["accepted"] == len(gt)
    assert summary["candidates"] == len(candidates) > 5
    assert summary["workers_lost"] == 0
    correct = [c for c in candidates if revisits(gt, c.query_range, c.match_range)]
    assert len(correct) >= 0.5 * len(candidates), (len(correct), len(candidates))
    # Ids increase; each candidate is of the past.
    assert [c.id for c in candidates] == sorted(c.id for c in candidates)
    assert all(c.match_range[1] < c.query_range[0] <= c.query_range[1] <= c.at_pose
               for c in candidates)
    assert {c.source for c in candidates} <= {"shape", "proximity", "drift-probe", "network"}
    c = correct[0]
    event = c.to_dict()
    assert event["event"] == "candidate" and event["id"] == c.id
    for key in ("at_pose", "query_range", "match_range", "score", "scale", "rotation",
                "translation", "source", "keyframes", "query_keyframes", "match_keyframes"):
        assert key in event, key
    assert c.rotation.shape == (3, 3) and c.translation.shape == (3,)
    assert c.keyframes is not None and c.keyframes["query_keyframe"] % 5 == 0
    assert "Candidate(id=" in repr(c)
    # The same poses at once: the same candidates (a replay is deterministic).
    again = turnprint.Detector(wait_for_matching=True)
    assert again.push_many(gt) == len(gt)
    rest, _ = again.finish()
    assert [(c.query_range, c.match_range) for c in rest] == \
        [(c.query_range, c.match_range) for c in candidates]


def test_the_detector_drops_bad_poses_and_counts_them(gt):
    detector = turnprint.Detector(wait_for_matching=True, proximity=False, top_k=2)
    assert detector.push(0.0, 0.0, 0.0, t=1.0)
    assert not detector.push(float("nan"), 0.0, 0.0, t=2.0)
    assert not detector.push(1.0, 0.0, 0.0, t=0.5)   # time going back
    assert not detector.push(1.0, 0.0, 0.0, t=1.0)   # repeated time
    assert detector.push(1.0, 0.0, 0.0, t=3.0)
    assert detector.poses == 5
    _, summary = detector.finish()
    assert summary["guards"]["non_finite"] == 1
    assert summary["guards"]["out_of_order"] == 1
    assert summary["guards"]["duplicate"] == 1
    assert detector.finished
    with pytest.raises(turnprint.TurnprintError, match="finished"):
        detector.push(2.0, 0.0, 0.0)
    with pytest.raises(turnprint.TurnprintError, match="finished"):
        detector.finish()


def test_detector_settings_reach_the_detector(gt):
    # The probes off: shape candidates only, and two matching threads give
    # the candidates of one.
    def run(**settings):
        detector = turnprint.Detector(wait_for_matching=True, proximity=False,
                                      drift_probe=False, top_k=2, **settings)
        detector.push_many(gt)
        rest, summary = detector.finish()
        return [(c.query_range, c.match_range, c.source) for c in rest], summary

    one, _ = run(workers=1)
    two, summary = run(workers=2)
    assert one and {source for *_, source in one} == {"shape"}
    assert two == one
    assert summary["worker"]["parallel_batches"] > 0


def test_detector_settings_are_checked():
    with pytest.raises(ValueError, match="min_score"):
        turnprint.Detector(min_score=2.0)
    with pytest.raises(ValueError, match="max_verify"):
        turnprint.Detector(max_verify=0)
    with pytest.raises(ValueError, match="workers"):
        turnprint.Detector(workers=65)
    with pytest.raises(TypeError, match="bogus"):
        turnprint.Detector(bogus=1)


# --- correction ------------------------------------------------------------

def test_correct_returns_one_finite_position_per_pose(gt):
    # Heading drift of 0.3 degrees per 100 poses about the first pose, 13.6
    # degrees over the drive: about what the odometry prior admits (0.2 rad),
    # so the drive's revisits enter the graph. (At 0.5 degrees, 23 in all, its
    # best revisits are turned away and the median error stays at 49 m, a few
    # centimetres either way.)
    angles = np.radians(0.003) * np.arange(len(gt))
    c, s = np.cos(angles), np.sin(angles)
    drifted = gt.copy()
    drifted[:, 0] = c * gt[:, 0] + s * gt[:, 2]
    drifted[:, 2] = -s * gt[:, 0] + c * gt[:, 2]
    fixed = turnprint.correct(drifted)
    assert fixed.shape == gt.shape and fixed.dtype == np.float64
    assert np.isfinite(fixed).all()
    np.testing.assert_allclose(fixed[0], drifted[0], atol=1e-6)
    err = lambda p: float(np.median(np.linalg.norm(p - gt, axis=1)))  # noqa: E731
    # Measured: 29.6 -> 24.2 m.
    assert err(fixed) < 0.9 * err(drifted), (err(fixed), err(drifted))
    # The node group named, in any case; one that is none refused.
    assert turnprint.correct(drifted, group="SE3").shape == gt.shape
    with pytest.raises(ValueError, match="'bogus' is not a group"):
        turnprint.correct(drifted, group="bogus")


# --- bad input -------------------------------------------------------------

def test_bad_input_raises_with_a_clear_message(gt, tmp_path):
    with_nan = gt.copy()
    with_nan[10] = np.nan
    with pytest.raises(turnprint.TurnprintError, match="pose 10 has a non-finite position"):
        turnprint.find_loops(with_nan)
    with pytest.raises(turnprint.TurnprintError, match="non-finite"):
        turnprint.match_paths(gt, with_nan)
    with pytest.raises(turnprint.TurnprintError, match="3 poses; the method needs at least"):
        turnprint.match_paths(gt[:3], gt)
    with pytest.raises(turnprint.TurnprintError, match="does not move"):
        turnprint.find_loops(np.ones((200, 3)))
    with pytest.raises(turnprint.TurnprintError, match="needs at least"):
        turnprint.correct(gt[:2])
    for shape in [(100,), (100, 4), (100, 3, 1), (100, 1)]:
        with pytest.raises(ValueError, match=r"\(N, 3\) array"):
            turnprint.find_loops(np.zeros(shape))
    with pytest.raises(ValueError, match="numbers"):
        turnprint.find_loops([["a", "b", "c"]] * 10)
    with pytest.raises(ValueError, match="numbers"):
        turnprint.find_loops([[1.0, 2.0, 3.0], [1.0, 2.0]])
    with pytest.raises(ValueError, match="top"):
        turnprint.find_loops(gt, top=0)
    with pytest.raises(ValueError, match="timestamps"):
        turnprint.write_tum(tmp_path / "x.tum", gt, times=np.zeros(3))
    with pytest.raises(turnprint.TurnprintError, match="no-such-file"):
        turnprint.read_trajectory(tmp_path / "no-such-file.txt")
    with pytest.raises(ValueError, match="unknown format"):
        turnprint.read_trajectory(tmp_path / "x.txt", format="bogus")
    broken = tmp_path / "broken.txt"
    broken.write_text("1 2 3\n4 5\n")
    with pytest.raises(turnprint.TurnprintError, match=r"broken.txt:2:"):
        turnprint.read_trajectory(broken, format="xyz")
    assert issubclass(turnprint.TurnprintError, Exception)


# --- evo -------------------------------------------------------------------

def test_evo_trajectories_go_in_and_out(gt, tmp_path):
    evo_trajectory = pytest.importorskip("evo.core.trajectory", reason="evo is not installed")
    file_interface = pytest.importorskip("evo.tools.file_interface")
    times = 0.1 * np.arange(len(gt))
    traj = evo_trajectory.PoseTrajectory3D(
        positions_xyz=gt, orientations_quat_wxyz=np.tile([1.0, 0, 0, 0], (len(gt), 1)),
        timestamps=times)
    ours = turnprint.from_evo(traj)
    np.testing.assert_array_equal(ours.positions, gt)
    np.testing.assert_array_equal(ours.times, times)
    np.testing.assert_array_equal(ours.orientations[0], [0.0, 0.0, 0.0, 1.0])
    assert turnprint.find_loops(ours.positions, top=1)
    # A corrected path written as TUM is read by evo, and back by to_evo.
    out = tmp_path / "corrected.tum"
    turnprint.write_tum(out, turnprint.correct(ours.positions), ours.times)
    read = file_interface.read_tum_trajectory_file(str(out))
    assert read.num_poses == len(gt)
    np.testing.assert_allclose(read.timestamps, times)
    back = turnprint.to_evo(ours)
    np.testing.assert_array_equal(back.positions_xyz, gt)
    np.testing.assert_array_equal(back.timestamps, times)
