"""APE and RPE of an estimate against ground truth computed by evo's Python
API, printed as JSON, for tests/crosscheck_evo.rs to compare with
turnprint::eval::ape.

Usage: evo_ape.py ESTIMATE GROUND_TRUTH [--format kitti|tum] [--delta N]

KITTI files pair pose i with pose i; TUM files are associated by timestamp
with evo.core.sync (nearest time, max_diff 0.01 s). For each alignment
(SE(3) and Sim(3), Umeyama as `evo_ape -a` / `-as`) the output holds:

- `ape`: evo's APE of the translation part (rmse, mean, median, max);
- `rpe_positions`: the positions-only RPE that turnprint defines (the
  length of the difference of each `delta`-step displacement, estimate
  aligned by the same Umeyama fit), computed with numpy on evo's aligned
  trajectory;
- `rpe_evo`: evo's own RPE (translation part, delta in frames), which
  expresses each step in its own pose frame and so is a different measure.
"""

import argparse
import copy
import json
import sys

import numpy as np
from evo.core import metrics, sync
from evo.tools import file_interface


def stats(errors):
    errors = np.asarray(errors, dtype=float)
    return {
        "rmse": float(np.sqrt(np.mean(errors**2))),
        "mean": float(np.mean(errors)),
        "median": float(np.median(errors)),
        "max": float(np.max(errors)),
    }


def ape_stats(ref, est):
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((ref, est))
    s = ape.get_all_statistics()
    return {k: float(s[k]) for k in ("rmse", "mean", "median", "max")}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("estimate")
    parser.add_argument("ground_truth")
    parser.add_argument("--format", choices=("kitti", "tum"), default="kitti")
    parser.add_argument("--delta", type=int, default=1)
    args = parser.parse_args()

    if args.format == "kitti":
        est = file_interface.read_kitti_poses_file(args.estimate)
        ref = file_interface.read_kitti_poses_file(args.ground_truth)
        n = min(est.num_poses, ref.num_poses)
        est.reduce_to_ids(np.arange(n))
        ref.reduce_to_ids(np.arange(n))
    else:
        est = file_interface.read_tum_trajectory_file(args.estimate)
        ref = file_interface.read_tum_trajectory_file(args.ground_truth)
        ref, est = sync.associate_trajectories(ref, est, max_diff=0.01)

    out = {"poses": int(est.num_poses)}
    for name, scale in (("se3", False), ("sim3", True)):
        aligned = copy.deepcopy(est)
        aligned.align(ref, correct_scale=scale)
        d = args.delta
        steps_est = aligned.positions_xyz[d:] - aligned.positions_xyz[:-d]
        steps_ref = ref.positions_xyz[d:] - ref.positions_xyz[:-d]
        rpe = metrics.RPE(
            metrics.PoseRelation.translation_part,
            delta=d,
            delta_unit=metrics.Unit.frames,
            all_pairs=False,
        )
        rpe.process_data((ref, aligned))
        s = rpe.get_all_statistics()
        out[name] = {
            "ape": ape_stats(ref, aligned),
            "rpe_positions": stats(np.linalg.norm(steps_est - steps_ref, axis=1)),
            "rpe_evo": {k: float(s[k]) for k in ("rmse", "mean", "median", "max")},
        }
    json.dump(out, sys.stdout)
    print()


if __name__ == "__main__":
    main()
