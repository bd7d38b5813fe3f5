#!/usr/bin/env python3
"""Reads the pose estimates of a running FastSLAM stack over iceoryx2, from Python.

Joins the stack named by --prefix / --iox-root (default: FASTSLAM_PREFIX and
FASTSLAM_IOX_ROOT, which `fastslam-stack run` prints when it starts), opens the `pose` and
`end_of_stream` topics with the stack's settings, prints one CSV line per pose
(`stamp_ns,x,y,theta,var_x,var_y,var_theta`) and exits when the service announces the end
of its pose stream. It only opens services (`open()`): a stack that is not there is an
error after --wait-s, never a separate, empty service of its own. Needs the iceoryx2 wheel
0.10 and the generated module `services/protocol/python/fastslam_protocol.py`.

    python3 examples/python/subscriber.py --prefix fs1234x --iox-root /tmp/fsl/fs1234x

It prints `ready` on stderr once subscribed; poses published before that are not seen
(the pose topic keeps no history).
"""

import argparse
import os
import sys
import time
from pathlib import Path

import iceoryx2 as iox

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "services/protocol/python"))
import fastslam_protocol as fp  # noqa: E402  (found through the path above)


def open_topic(node, prefix, topic, payload, wait_s, after=0):
    """A subscriber on `topic`, opened with the stack's settings (topics.rs); retries
    until the stack has created the service and it has `after` subscribers, or `wait_s`
    passed."""
    name = iox.ServiceName.new(f"{prefix}/{topic.name}")
    deadline = time.monotonic() + wait_s
    while True:
        try:
            service = (node.service_builder(name).publish_subscribe(payload)
                       .enable_safe_overflow(False)
                       .subscriber_max_buffer_size(topic.buffer)
                       .history_size(topic.history)
                       .max_publishers(fp.MAX_PUBLISHERS)
                       .max_subscribers(fp.MAX_SUBSCRIBERS)
                       .open())
            while service.dynamic_config.number_of_subscribers < after:
                if time.monotonic() > deadline:
                    sys.exit(f"error: {prefix}/{topic.name} has fewer than {after} subscribers")
                time.sleep(0.01)
            return service.subscriber_builder().create()
        except Exception as error:  # the wheel raises a plain exception per failure kind
            if time.monotonic() > deadline:
                sys.exit(f"error: cannot open {prefix}/{topic.name}: {error}")
            time.sleep(0.05)


def print_pose(sample):
    """One CSV line: stamp, pose and the variances of x, y and heading."""
    p = sample.payload().contents
    c = p.covariance
    print(f"{p.header.stamp_ns},{p.x},{p.y},{p.theta},{c[0]},{c[4]},{c[8]}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--prefix", default=os.environ.get("FASTSLAM_PREFIX", "fastslam"),
                        help="stack name (default: $FASTSLAM_PREFIX or fastslam)")
    parser.add_argument("--iox-root", default=os.environ.get("FASTSLAM_IOX_ROOT"),
                        help="iceoryx2 root directory of the stack (default: $FASTSLAM_IOX_ROOT)")
    parser.add_argument("--wait-s", type=float, default=30.0,
                        help="give up when the stack's topics do not exist after this long")
    parser.add_argument("--after-subscribers", type=int, default=0,
                        help="subscribe to `pose` only once it has this many subscribers "
                             "(the stack's own client among them)")
    args = parser.parse_args()

    config = iox.config.default()
    config.global_cfg.prefix = iox.FileName.new(args.prefix)
    if args.iox_root:
        config.global_cfg.root_path = iox.Path.new(args.iox_root)
    node = (iox.NodeBuilder.new().name(iox.NodeName.new("python-subscriber"))
            .config(config).create(iox.ServiceType.Ipc))
    # End of stream first: an announcement can then not overtake the poses it ends.
    ends = open_topic(node, args.prefix, fp.END_OF_STREAM, fp.EndOfStream, args.wait_s)
    poses = open_topic(node, args.prefix, fp.POSE, fp.PoseEstimate, args.wait_s,
                       args.after_subscribers)
    print("ready", file=sys.stderr, flush=True)

    received, ended = 0, False
    while not ended:
        while (sample := poses.receive()) is not None:
            print_pose(sample)
            received += 1
        while (sample := ends.receive()) is not None:
            ended |= sample.payload().contents.stream == fp.STREAM_POSE
        if not ended:
            node.wait(iox.Duration.from_millis(2))
    # The poses sent before the announcement are in by now; take the last of them.
    while (sample := poses.receive()) is not None:
        print_pose(sample)
        received += 1
    print(f"received {received} poses", file=sys.stderr, flush=True)


if __name__ == "__main__":
    main()
