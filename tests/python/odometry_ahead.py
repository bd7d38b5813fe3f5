#!/usr/bin/env python3
"""The Python example's robot with its odometry sent well ahead of its scans.

It drives the circle of examples/python/publisher.py among the same landmarks, and
publishes (no ground truth) the first `--ahead` odometry messages before its first scan;
from then on each scan goes out `--ahead` odometry messages after its own stamp — a
publisher that reads its odometry ahead, as one reading two files would. It joins the stack
named by FASTSLAM_PREFIX and FASTSLAM_IOX_ROOT, once the service and the client subscribed.

    python3 tests/python/odometry_ahead.py --ahead 600
"""

import argparse
import math
import os
import random
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples/python"))
import publisher as example  # noqa: E402  (its ports, robot and landmarks)

iox, fp = example.iox, example.fp


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--ahead", type=int, required=True,
                        help="odometry messages sent before the scan of the same time")
    parser.add_argument("--duration-s", type=float, default=60.0, help="simulated time")
    args = parser.parse_args()
    random.seed(1)

    prefix = os.environ["FASTSLAM_PREFIX"]
    config = iox.config.default()
    config.global_cfg.prefix = iox.FileName.new(prefix)
    config.global_cfg.root_path = iox.Path.new(os.environ["FASTSLAM_IOX_ROOT"])
    node = (iox.NodeBuilder.new().name(iox.NodeName.new("odometry-ahead")).config(config)
            .create(iox.ServiceType.Ipc))
    odometry = example.Port(node, prefix, fp.ODOMETRY, fp.Odometry)
    observations = example.Port(node, prefix, fp.OBSERVATIONS, iox.Slice[fp.Observation],
                                fp.ObservationsHeader)
    eos = example.Port(node, prefix, fp.END_OF_STREAM, fp.EndOfStream)
    while odometry.subscribers() < 2 or observations.subscribers() < 2:
        node.wait(iox.Duration.from_millis(5))

    dt = 1.0 / example.ODOMETRY_HZ
    omega = example.SPEED_MPS / example.RADIUS_M
    steps = int(args.duration_s * example.ODOMETRY_HZ)

    def pose(k):
        """The robot's exact pose after k odometry periods."""
        theta = omega * k * dt
        return (example.RADIUS_M * math.sin(theta),
                example.RADIUS_M * (1 - math.cos(theta)), theta)

    def send_odometry(k):
        x, y, theta = pose(k)
        v, w = (example.SPEED_MPS, omega) if k > 0 else (0.0, 0.0)
        odometry.send(fp.Odometry(header=fp.Header(round(k * dt * 1e9), k), v=v, omega=w,
                                  steering=0.0, x=x, y=y, theta=theta))

    def send_scan(k):
        seen = example.observe(*pose(k), True)
        header = fp.ObservationsHeader(
            header=fp.Header(round(k * dt * 1e9), k // example.OBSERVE_EVERY - 1),
            count=len(seen), max_range=example.MAX_RANGE_M, min_bearing=-example.HALF_FOV,
            max_bearing=example.HALF_FOV)
        observations.send_slice(header, seen)

    for k in range(min(args.ahead, steps + 1)):
        send_odometry(k)
    for k in range(steps + 1):
        if k + args.ahead <= steps:
            send_odometry(k + args.ahead)
        if k > 0 and k % example.OBSERVE_EVERY == 0:
            send_scan(k)
    for port, stream in [(odometry, fp.STREAM_ODOMETRY), (observations, fp.STREAM_OBSERVATIONS)]:
        eos.send(fp.EndOfStream(header=port.last, stream=stream))
    # The scans live in this process's shared memory until they are received.
    for _ in range(12000):
        if observations.subscribers() == 0:
            break
        node.wait(iox.Duration.from_millis(5))


if __name__ == "__main__":
    main()
