#!/usr/bin/env python3
"""Write a synthetic 2D pose graph of N poses as g2o, for solve time against graph size.

A robot walks a grid city (blocks of 1 m, 50 x 50 intersections) one unit step a pose,
turning at intersections at random; odometry edges carry noise (sigma 0.05 m, 0.05 m,
0.01 rad), and each time it comes within half a metre of a pose at least 50 poses older
(the first such), a loop-closure edge with the same noise ties the two. Vertices start at
the dead-reckoned poses. Deterministic for a seed (Python's own generator, no numpy).

Usage: city.py N OUT.g2o [--seed S]
"""

import argparse
import math
import random


def compose(a, b):
    """a o b for poses (x, y, theta)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2])


def between(a, b):
    """a^-1 o b, the heading wrapped."""
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    t = b[2] - a[2]
    return (c * dx + s * dy, -s * dx + c * dy, math.atan2(math.sin(t), math.cos(t)))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("n", type=int)
    parser.add_argument("out")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    rng = random.Random(args.seed)
    sigma = (0.05, 0.05, 0.01)
    info = " ".join(
        str(v) for v in (1 / sigma[0] ** 2, 0, 0, 1 / sigma[1] ** 2, 0, 1 / sigma[2] ** 2)
    )
    noisy = lambda d: tuple(v + rng.gauss(0.0, s) for v, s in zip(d, sigma))
    truth, estimate, edges = [(0.0, 0.0, 0.0)], [(0.0, 0.0, 0.0)], []
    cells = {}
    for i in range(1, args.n):
        x, y, t = truth[-1]
        turn = rng.choice((0.0, 0.0, math.pi / 2, -math.pi / 2))
        ahead = compose((x, y, t), (0.0, 0.0, turn))
        nx, ny = ahead[0] + math.cos(ahead[2]), ahead[1] + math.sin(ahead[2])
        if not (0 <= round(nx) < 50 and 0 <= round(ny) < 50):
            turn += math.pi
        step = (0.0, 0.0, turn)
        pose = compose(compose((x, y, t), step), (1.0, 0.0, 0.0))
        pose = (round(pose[0]), round(pose[1]), math.atan2(math.sin(pose[2]), math.cos(pose[2])))
        measured = noisy(between(truth[-1], pose))
        truth.append(pose)
        estimate.append(compose(estimate[-1], measured))
        edges.append((i - 1, i, measured))
        key = (pose[0], pose[1])
        older = [j for j in cells.get(key, []) if j < i - 50]
        if older:
            edges.append((older[0], i, noisy(between(truth[older[0]], pose))))
        cells.setdefault(key, []).append(i)
    with open(args.out, "w") as out:
        for i, p in enumerate(estimate):
            out.write(f"VERTEX_SE2 {i} {p[0]!r} {p[1]!r} {p[2]!r}\n")
        for a, b, d in edges:
            out.write(f"EDGE_SE2 {a} {b} {d[0]!r} {d[1]!r} {d[2]!r} {info}\n")


if __name__ == "__main__":
    main()
