"""Rewrites a rosbag2 bag as a 3D lidar would have recorded it, with the independent
`rosbags` library: each sensor_msgs/msg/LaserScan message becomes a
sensor_msgs/msg/PointCloud2 on /points (same stamp and frame), every return on three
rings (z -0.1, 0 and +0.1 m) with a floor point (z -0.45 m) and a ceiling point
(z +1.0 m) nearer along its beam; /odom and /tf are left out, every other topic is copied.

Usage: scans_to_clouds.py SOURCE_BAG TARGET_BAG
"""

import math
import sys
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import Reader, StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

TS = get_typestore(Stores.ROS2_HUMBLE)
T = TS.types
SCAN = 'sensor_msgs/msg/LaserScan'
CLOUD = 'sensor_msgs/msg/PointCloud2'
FIELDS = [T['sensor_msgs/msg/PointField'](name=n, offset=4 * k, datatype=7, count=1)
          for k, n in enumerate('xyz')]


def cloud_of(scan):
    """The scan's returns as points (see the module doc)."""
    points = []
    for i, r in enumerate(scan.ranges.tolist()):
        if not (math.isfinite(r) and scan.range_min <= r < scan.range_max):
            continue
        a = scan.angle_min + i * scan.angle_increment
        c, s = math.cos(a), math.sin(a)
        points += [(r * c, r * s, z) for z in (-0.1, 0.0, 0.1)]
        points += [(0.5 * r * c, 0.5 * r * s, -0.45), (0.7 * r * c, 0.7 * r * s, 1.0)]
    xyz = np.array(points, dtype=np.float32).reshape(-1, 3)
    return T[CLOUD](header=scan.header, height=1, width=len(xyz), fields=FIELDS,
                    is_bigendian=False, point_step=12, row_step=12 * len(xyz),
                    data=xyz.view(np.uint8).reshape(-1), is_dense=True)


def main():
    source, target = Path(sys.argv[1]), Path(sys.argv[2])
    with Reader(source) as reader, Writer(target, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        out = {}
        for c in reader.connections:
            if c.topic not in ('/odom', '/tf'):
                topic, msgtype = ('/points', CLOUD) if c.msgtype == SCAN else (c.topic, c.msgtype)
                out[c.id] = writer.add_connection(topic, msgtype, typestore=TS)
        for c, ns, data in reader.messages():
            if c.id not in out:
                continue
            if c.msgtype == SCAN:
                data = TS.serialize_cdr(cloud_of(TS.deserialize_cdr(data, SCAN)), CLOUD)
            writer.write(out[c.id], ns, data)


if __name__ == '__main__':
    main()
