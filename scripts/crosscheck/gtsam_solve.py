"""Pose graphs solved by GTSAM's Levenberg-Marquardt, for
tests/crosscheck_gtsam.rs, examples/solve_g2o.rs and tools/solver-compare
to compare with.

    gtsam_solve.py data                      # the wheel's gtsam/Data folder
    gtsam_solve.py convert NAME OUT.g2o      # sphere2500, w10000, city10000
    gtsam_solve.py solve FILE.g2o [--2d] [--lift] [--max-iterations N]

`convert` writes one of the wheel's benchmark graphs as a standard g2o file
(GTSAM's writeG2o) so that every solver reads the same graph:

- sphere2500 (TORO EDGE3, edges only): read with load3D, which takes the
  21 numbers after the pose as information in GTSAM's order (rotation
  first); the start is the odometry chain (edge i -> i + 1) composed from
  the identity.
- w10000 (TORO VERTEX2/EDGE2): load2D, vertices as the start; its EQUIV
  lines are ignored, as load2D does.
- city10000 (T1_city10000_04.txt, odometry and loop closures of which 200
  carry two hypotheses): the first hypothesis of each line, sigmas 1/30 m,
  1/30 m, 1/100 rad as GTSAM's City10000 examples use; the start is the
  odometry chain.

`solve` reads FILE.g2o with readG2o, holds the first node with a prior of
sigma 1e-8 (excluded from the costs), runs LevenbergMarquardtOptimizer
(maximum iterations as given, GTSAM's default tolerances otherwise) and
prints JSON: initial and final cost as `graph.error(values)` = 0.5 * sum of
whitened squared residuals, iterations, the optimiser's wall time. `--lift`
solves a 2D graph as a 3D one (z = 0, rotation about z; the out-of-plane
sigmas equal to the in-plane ones, which requires equal x and y sigmas), as
turnprint reads 2D g2o files.
"""

import argparse
import json
import os
import sys
import time

import numpy as np

import gtsam


def data_dir():
    return os.path.join(os.path.dirname(gtsam.__file__), "Data")


def chain_start(graph, is3d):
    """Start values composed along the edges i -> i + 1 from the identity."""
    odometry = {}
    for i in range(graph.size()):
        f = graph.at(i)
        k1, k2 = f.keys()
        if k2 == k1 + 1 and k1 not in odometry:
            odometry[k1] = f.measured()
    values = gtsam.Values()
    pose = gtsam.Pose3() if is3d else gtsam.Pose2()
    values.insert(0, pose)
    k = 0
    while k in odometry:
        pose = pose.compose(odometry[k])
        values.insert(k + 1, pose)
        k += 1
    return values


def convert(name, out):
    d = data_dir()
    if name == "sphere2500":
        graph, _ = gtsam.load3D(os.path.join(d, "sphere2500.txt"))
        values = chain_start(graph, True)
    elif name == "w10000":
        graph, values = gtsam.load2D(os.path.join(d, "w10000.graph"))
    elif name == "city10000":
        noise = gtsam.noiseModel.Diagonal.Sigmas(
            np.array([1.0 / 30.0, 1.0 / 30.0, 1.0 / 100.0])
        )
        graph = gtsam.NonlinearFactorGraph()
        with open(os.path.join(d, "T1_city10000_04.txt")) as f:
            for line in f:
                p = line.split()
                if not p:
                    continue
                s, t = int(p[1]), int(p[3])
                x, y, th = (float(v) for v in p[6:9])
                graph.add(gtsam.BetweenFactorPose2(s, t, gtsam.Pose2(x, y, th), noise))
        values = chain_start(graph, False)
    else:
        sys.exit(f"unknown graph {name}")
    gtsam.writeG2o(graph, values, out)
    json.dump({"graph": name, "nodes": values.size(), "edges": graph.size(), "file": out},
              sys.stdout)
    print()


def lift(graph, values):
    """The 2D graph as a 3D one: z = 0, rotation about z."""
    def pose3(p):
        return gtsam.Pose3(gtsam.Rot3.Rz(p.theta()), gtsam.Point3(p.x(), p.y(), 0.0))

    g3 = gtsam.NonlinearFactorGraph()
    for i in range(graph.size()):
        f = graph.at(i)
        sx, sy, sth = f.noiseModel().sigmas()
        if abs(sx - sy) > 1e-12 * max(sx, sy):
            sys.exit(f"edge {i}: x and y sigmas differ ({sx}, {sy}): cannot lift")
        noise = gtsam.noiseModel.Diagonal.Sigmas(np.array([sth, sth, sth, sx, sx, sx]))
        k1, k2 = f.keys()
        g3.add(gtsam.BetweenFactorPose3(k1, k2, pose3(f.measured()), noise))
    v3 = gtsam.Values()
    for k in values.keys():
        v3.insert(k, pose3(values.atPose2(k)))
    return g3, v3


def solve(path, is3d, lifted, max_iterations):
    graph, values = gtsam.readG2o(path, is3d)
    if lifted and not is3d:
        graph, values = lift(graph, values)
        is3d = True
    first = min(values.keys())
    anchored = gtsam.NonlinearFactorGraph(graph)
    if is3d:
        prior = gtsam.PriorFactorPose3(
            first, values.atPose3(first), gtsam.noiseModel.Isotropic.Sigma(6, 1e-8))
    else:
        prior = gtsam.PriorFactorPose2(
            first, values.atPose2(first), gtsam.noiseModel.Isotropic.Sigma(3, 1e-8))
    anchored.add(prior)
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(max_iterations)
    optimizer = gtsam.LevenbergMarquardtOptimizer(anchored, values, params)
    start = time.perf_counter()
    result = optimizer.optimize()
    elapsed = time.perf_counter() - start
    json.dump({
        "solver": "gtsam",
        "file": path,
        "group": "SE3" if is3d else "SE2",
        "nodes": values.size(),
        "edges": graph.size(),
        "initial_cost": graph.error(values),
        "final_cost": graph.error(result),
        "iterations": optimizer.iterations(),
        "time_s": elapsed,
        "max_iterations": max_iterations,
        "relative_error_tol": params.getRelativeErrorTol(),
        "absolute_error_tol": params.getAbsoluteErrorTol(),
    }, sys.stdout)
    print()


def main():
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("data")
    c = sub.add_parser("convert")
    c.add_argument("name", choices=("sphere2500", "w10000", "city10000"))
    c.add_argument("out")
    s = sub.add_parser("solve")
    s.add_argument("file")
    s.add_argument("--2d", dest="two_d", action="store_true")
    s.add_argument("--lift", action="store_true")
    s.add_argument("--max-iterations", type=int, default=100)
    args = parser.parse_args()
    if args.command == "data":
        print(data_dir())
    elif args.command == "convert":
        convert(args.name, args.out)
    else:
        solve(args.file, not args.two_d, args.lift, args.max_iterations)


if __name__ == "__main__":
    main()
