#!/usr/bin/env python3
"""Solve a 2D g2o pose graph with GTSAM's Levenberg-Marquardt, the way
`fastslam-stack solve` does: the first pose (lowest id) anchored by a tight prior
(sigma 1e-4 on x, y and theta), no robust kernel, default parameters unless --tight.

Prints one line: poses, edges, chi2 = 2 x the graph error over the edges (the prior
excluded) before and after, LM iterations, the wall time of optimize() and of the
optimizer's construction plus optimize() (the constructor computes the ordering); with
--repeat N the times are the fastest of N runs.

GTSAM's own reader (readG2o) takes pose vertices and EDGE_SE2 lines and stops at a line it
does not know. A file with landmarks (VERTEX_XY, EDGE_SE2_XY: the graphs the stack writes)
or FIX lines is read here instead: EDGE_SE2 as BetweenFactorPose2, EDGE_SE2_XY — the
landmark seen at an offset in the pose's frame, R(theta)^T (m - t) - offset — as a
CustomFactor, a Python callback (GTSAM's Python wheel has no factor for it), both with
the file's full information matrix. The callbacks make GTSAM's time on such files a
measure of Python, not of GTSAM's solver: compare the chi2 there, not the time.
"""

import argparse
import gzip
import os
import tempfile
import time

import gtsam
import numpy as np


def information(upper, n):
    """The symmetric n x n matrix of the upper-triangle values `upper`, row by row."""
    m = np.zeros((n, n))
    k = 0
    for i in range(n):
        for j in range(i, n):
            m[i, j] = m[j, i] = upper[k]
            k += 1
    return m


def offset_error(offset):
    """The CustomFactor callback of an EDGE_SE2_XY with measured `offset`."""

    def error(this, values, jacobians):
        pose = values.atPose2(this.keys()[0])
        point = values.atPoint2(this.keys()[1])
        c, s = np.cos(pose.theta()), np.sin(pose.theta())
        d = point - np.array([pose.x(), pose.y()])
        local = np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])
        if jacobians is not None:
            jacobians[0] = np.array([[-1.0, 0.0, local[1]], [0.0, -1.0, -local[0]]])
            jacobians[1] = np.array([[c, s], [-s, c]])
        return local - offset

    return error


def read_with_landmarks(text):
    """The graph and initial values of g2o text with landmarks or FIX lines."""
    graph, initial = gtsam.NonlinearFactorGraph(), gtsam.Values()
    for line in text.splitlines():
        f = line.split()
        if not f or f[0].startswith("#"):
            continue
        if f[0] == "VERTEX_SE2":
            initial.insert(int(f[1]), gtsam.Pose2(*map(float, f[2:5])))
        elif f[0] == "VERTEX_XY":
            initial.insert(int(f[1]), np.array([float(f[2]), float(f[3])]))
        elif f[0] == "EDGE_SE2":
            v = list(map(float, f[3:12]))
            noise = gtsam.noiseModel.Gaussian.Information(information(v[3:], 3))
            graph.add(gtsam.BetweenFactorPose2(int(f[1]), int(f[2]), gtsam.Pose2(*v[:3]), noise))
        elif f[0] == "EDGE_SE2_XY":
            v = list(map(float, f[3:8]))
            noise = gtsam.noiseModel.Gaussian.Information(information(v[2:], 2))
            keys = [int(f[1]), int(f[2])]
            graph.add(gtsam.CustomFactor(noise, keys, offset_error(np.array(v[:2]))))
    return graph, initial


def read(path):
    """The graph and initial values of a 2D g2o file, gzipped or not."""
    with open(path, "rb") as f:
        gzipped = f.read(2) == b"\x1f\x8b"
    opener = gzip.open if gzipped else open
    with opener(path, "rb") as f:
        text = f.read()
    if any(tag in text for tag in (b"VERTEX_XY", b"EDGE_SE2_XY", b"\nFIX")):
        return read_with_landmarks(text.decode())
    if not gzipped:
        return gtsam.readG2o(path, False)
    fd, plain = tempfile.mkstemp(suffix=".g2o")
    try:
        with os.fdopen(fd, "wb") as out:
            out.write(text)
        return gtsam.readG2o(plain, False)
    finally:
        os.remove(plain)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("file")
    parser.add_argument("--repeat", type=int, default=1, help="runs; the fastest is shown")
    parser.add_argument(
        "--tight",
        action="store_true",
        help="relative and absolute error tolerances 1e-12 instead of the defaults (1e-5)",
    )
    args = parser.parse_args()

    graph, initial = read(args.file)
    first = min(initial.keys())
    anchored = gtsam.NonlinearFactorGraph(graph)
    anchored.add(
        gtsam.PriorFactorPose2(
            first,
            initial.atPose2(first),
            gtsam.noiseModel.Diagonal.Sigmas(np.array([1e-4, 1e-4, 1e-4])),
        )
    )
    params = gtsam.LevenbergMarquardtParams()
    if args.tight:
        params.setRelativeErrorTol(1e-12)
        params.setAbsoluteErrorTol(1e-12)
    best_optimize = best_total = float("inf")
    for _ in range(max(1, args.repeat)):
        started = time.perf_counter()
        optimizer = gtsam.LevenbergMarquardtOptimizer(anchored, initial, params)
        constructed = time.perf_counter()
        result = optimizer.optimize()
        done = time.perf_counter()
        best_optimize = min(best_optimize, done - constructed)
        best_total = min(best_total, done - started)
    print(
        f"poses {initial.size()} edges {graph.size()} "
        f"chi2_initial {2.0 * graph.error(initial):.6f} "
        f"chi2_final {2.0 * graph.error(result):.6f} "
        f"iterations {optimizer.iterations()} "
        f"optimize_s {best_optimize:.4f} total_s {best_total:.4f}"
    )


if __name__ == "__main__":
    main()
