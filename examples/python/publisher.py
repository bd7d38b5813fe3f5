#!/usr/bin/env python3
"""A robot simulated in Python, published to the FastSLAM stack over iceoryx2.

Shows that a sensor written in another language plugs into the stack: it publishes
odometry and landmark observations (and, for the metrics client, ground truth and the
true landmarks) with the protocol's type names and layouts as ctypes structures, on the
stack's topics with the stack's service settings, and notifies each topic's event service
after every send so the service wakes up.

The robot drives a circle of radius 10 m at 1 m/s among 12 landmarks; odometry at 20 Hz
with noise, range-bearing observations at 5 Hz of the landmarks within 15 m in front,
with their ids (run the service with known association). Needs the iceoryx2 wheel 0.10
(`pip install "iceoryx2>=0.10,<0.11"`) and the generated module
`services/protocol/python/fastslam_protocol.py`.

    python3 examples/python/publisher.py --prefix fastslam

then start the service and a client under the same prefix, or let the script wait for
them: it starts publishing once `--wait-subscribers` processes subscribed. The stack's
prefix and iceoryx2 root default to FASTSLAM_PREFIX and FASTSLAM_IOX_ROOT, which
`fastslam-stack test` sets:

    fastslam-stack test --config examples/python/service.toml \
        --publisher "python3 examples/python/publisher.py" --expect "estimate.ate_rmse_m < 0.5"
"""

import argparse
import math
import os
import random
import sys
from pathlib import Path

import iceoryx2 as iox

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "services/protocol/python"))
import fastslam_protocol as fp  # noqa: E402  (found through the path above)

ODOMETRY_HZ = 20
OBSERVE_EVERY = 4  # odometry periods per observation (5 Hz)
SPEED_MPS, RADIUS_M = 1.0, 10.0
SIGMA_V, SIGMA_OMEGA = 0.05, 0.02  # odometry noise (m/s, rad/s)
SIGMA_RANGE, SIGMA_BEARING = 0.1, 0.01  # observation noise (m, rad)
MAX_RANGE_M, HALF_FOV = 15.0, math.pi / 2
LANDMARKS = [(14.0 * math.cos(a) + 0.0, 14.0 * math.sin(a) + RADIUS_M)
             for a in (2 * math.pi * k / 12 for k in range(12))]


class Port:
    """A publisher on one topic plus the notifier of its event service."""

    def __init__(self, node, prefix, topic, payload, user_header=None):
        name = iox.ServiceName.new(f"{prefix}/{topic.name}")
        builder = node.service_builder(name).publish_subscribe(payload)
        if user_header is not None:
            builder = builder.user_header(user_header)
        # Exactly the settings of topics.rs: iceoryx2 refuses a service opened otherwise.
        self.service = (builder.enable_safe_overflow(False)
                        .subscriber_max_buffer_size(topic.buffer)
                        .history_size(topic.history)
                        .max_publishers(fp.MAX_PUBLISHERS)
                        .max_subscribers(fp.MAX_SUBSCRIBERS)
                        .open_or_create())
        publisher = self.service.publisher_builder()
        if user_header is not None:  # slices grow by powers of two
            publisher = (publisher.initial_max_slice_len(32)
                         .allocation_strategy(iox.AllocationStrategy.PowerOfTwo))
        # Lossless: wait while a subscriber's buffer is full.
        self.publisher = (publisher
                          .backpressure_strategy(iox.BackpressureStrategy.RetryUntilDelivered)
                          .create())
        self.notifier = node.service_builder(name).event().open_or_create().notifier_builder().create()
        self.last = None  # header of the last message sent

    def send(self, message):
        self.publisher.send_copy(message)
        self.notifier.notify()
        self.last = message.header

    def send_slice(self, header, items):
        sample = self.publisher.loan_slice_uninit(len(items))
        sample.user_header()[0] = header  # written into shared memory
        for i, item in enumerate(items):
            sample.payload()[i] = item
        sample.assume_init().send()
        self.notifier.notify()
        self.last = header.header

    def subscribers(self):
        return self.service.dynamic_config.number_of_subscribers


def observe(x, y, theta, with_ids):
    """Noisy range-bearing observations of the landmarks in view."""
    seen = []
    for k, (lx, ly) in enumerate(LANDMARKS):
        r = math.hypot(lx - x, ly - y)
        b = math.atan2(ly - y, lx - x) - theta
        b = math.atan2(math.sin(b), math.cos(b))
        if r <= MAX_RANGE_M and abs(b) <= HALF_FOV:
            noisy = min(max(r + random.gauss(0, SIGMA_RANGE), 0.01), MAX_RANGE_M)
            seen.append(fp.Observation(range=noisy,
                                       bearing=b + random.gauss(0, SIGMA_BEARING),
                                       diameter=0.0, id=k if with_ids else -1))
    return seen


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--prefix", default=os.environ.get("FASTSLAM_PREFIX", "fastslam"),
                        help="stack name (service prefix; default: $FASTSLAM_PREFIX or fastslam)")
    parser.add_argument("--iox-root", default=os.environ.get("FASTSLAM_IOX_ROOT"),
                        help="iceoryx2 root directory, as the stack's (default: $FASTSLAM_IOX_ROOT)")
    parser.add_argument("--duration-s", type=float, default=63.0, help="simulated time")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--wait-subscribers", type=int, default=2,
                        help="start once this many processes take odometry and observations "
                             "(2: the service and a client; 1: the service alone)")
    parser.add_argument("--wait-pose-subscribers", type=int, default=0,
                        help="also wait until the service's `pose` topic has this many "
                             "subscribers (the client and any outside reader, such as "
                             "subscriber.py), so none of them misses the first poses")
    parser.add_argument("--unknown-ids", action="store_true", help="publish ids as -1")
    parser.add_argument("--no-truth", action="store_true",
                        help="publish no ground truth (as a real robot): the client then "
                             "scores what needs no truth")
    args = parser.parse_args()
    random.seed(args.seed)

    # One stack = one prefix, used as iceoryx2's file prefix and as service-name prefix.
    config = iox.config.default()
    config.global_cfg.prefix = iox.FileName.new(args.prefix)
    if args.iox_root:
        config.global_cfg.root_path = iox.Path.new(args.iox_root)
    name = iox.NodeName.new("python-publisher")
    node = iox.NodeBuilder.new().name(name).config(config).create(iox.ServiceType.Ipc)

    truth = landmarks = None
    if not args.no_truth:
        truth = Port(node, args.prefix, fp.GROUND_TRUTH, fp.GroundTruth)
        landmarks = Port(node, args.prefix, fp.TRUTH_LANDMARKS, iox.Slice[fp.MapLandmark],
                         fp.LandmarkMapHeader)
    odometry = Port(node, args.prefix, fp.ODOMETRY, fp.Odometry)
    observations = Port(node, args.prefix, fp.OBSERVATIONS, iox.Slice[fp.Observation],
                        fp.ObservationsHeader)
    eos = Port(node, args.prefix, fp.END_OF_STREAM, fp.EndOfStream)
    # Consumers subscribe to end_of_stream first and to the topic their producer waits on
    # last: once these are there, nothing published is lost. Count every consumer on both
    # sensor topics (a client takes observations too, so one could stand in for a service
    # that is still starting).
    while (odometry.subscribers() < args.wait_subscribers
           or observations.subscribers() < args.wait_subscribers
           or (truth is not None
               and truth.subscribers() < min(args.wait_subscribers - 1, 1))):
        node.wait(iox.Duration.from_millis(5))
    if args.wait_pose_subscribers > 0:
        pose = (node.service_builder(iox.ServiceName.new(f"{args.prefix}/{fp.POSE.name}"))
                .publish_subscribe(fp.PoseEstimate)
                .enable_safe_overflow(False)
                .subscriber_max_buffer_size(fp.POSE.buffer)
                .history_size(fp.POSE.history)
                .max_publishers(fp.MAX_PUBLISHERS)
                .max_subscribers(fp.MAX_SUBSCRIBERS)
                .open())  # the service created it before subscribing to our topics
        while pose.dynamic_config.number_of_subscribers < args.wait_pose_subscribers:
            node.wait(iox.Duration.from_millis(5))

    true_map = [fp.MapLandmark(id=k, x=x, y=y) for k, (x, y) in enumerate(LANDMARKS)]
    map_header = fp.LandmarkMapHeader(header=fp.Header(0, 0), count=len(true_map))
    if landmarks is not None:
        landmarks.send_slice(map_header, true_map)

    dt = 1.0 / ODOMETRY_HZ
    omega = SPEED_MPS / RADIUS_M
    x = y = theta = 0.0  # truth
    dx = dy = dtheta = 0.0  # dead reckoning
    steps = int(args.duration_s * ODOMETRY_HZ)
    for k in range(steps + 1):
        stamp_ns = round(k * dt * 1e9)
        if k > 0:  # move over the interval that ends now
            x += SPEED_MPS * dt * math.cos(theta)
            y += SPEED_MPS * dt * math.sin(theta)
            theta = math.atan2(math.sin(theta + omega * dt), math.cos(theta + omega * dt))
        v_m = SPEED_MPS + random.gauss(0, SIGMA_V) if k > 0 else 0.0
        w_m = omega + random.gauss(0, SIGMA_OMEGA) if k > 0 else 0.0
        if k > 0:
            dx += v_m * dt * math.cos(dtheta)
            dy += v_m * dt * math.sin(dtheta)
            dtheta += w_m * dt
        if truth is not None:
            truth.send(fp.GroundTruth(header=fp.Header(stamp_ns, k), x=x, y=y, theta=theta,
                                      v=SPEED_MPS, omega=omega, steering=0.0))
        odometry.send(fp.Odometry(header=fp.Header(stamp_ns, k), v=v_m, omega=w_m,
                                  steering=0.0, x=dx, y=dy, theta=dtheta))
        if k > 0 and k % OBSERVE_EVERY == 0:
            seen = observe(x, y, theta, not args.unknown_ids)
            seq = k // OBSERVE_EVERY - 1
            header = fp.ObservationsHeader(header=fp.Header(stamp_ns, seq), count=len(seen),
                                           max_range=MAX_RANGE_M, min_bearing=-HALF_FOV,
                                           max_bearing=HALF_FOV)
            observations.send_slice(header, seen)

    ends = [(odometry, fp.STREAM_ODOMETRY), (observations, fp.STREAM_OBSERVATIONS)]
    if truth is not None:
        map_header.header = fp.Header(truth.last.stamp_ns, 1)
        landmarks.send_slice(map_header, true_map)
        ends.insert(0, (truth, fp.STREAM_GROUND_TRUTH))
    for port, stream in ends:
        eos.send(fp.EndOfStream(header=port.last, stream=stream))
    # Slice samples live in this process's shared memory until they are received: stay
    # until the subscribers have taken everything and left (at most 60 s), or the last
    # scans would be lost with this process.
    for _ in range(12000):
        if observations.subscribers() == 0 and (landmarks is None
                                                 or landmarks.subscribers() == 0):
            break
        node.wait(iox.Duration.from_millis(5))
    print(f"published {steps + 1} odometry messages and {observations.last.seq + 1} scans")


if __name__ == "__main__":
    main()
