"""Writes the rosbag2 bags the replay's bag reader is tested on, with the independent
`rosbags` library, and what a reader should find in them.

Usage: write_bag.py OUT_DIR

Bags written under OUT_DIR (each a rosbag2 folder):
- mcap:            MCAP storage, zstd-compressed chunks. Scans on /base_scan; odometry only
                   on /tf (odom -> base_footprint moving; base_footprint -> base_link and
                   base_link -> laser on /tf_static); a /chatter topic to be skipped.
- sqlite:          the same in SQLite storage, plus an exact duplicate of one scan and a
                   different scan at the last scan's stamp.
- sqlite_file_zstd: the same as mcap, SQLite storage compressed whole (file mode).
- mcap_message_zstd: the same as mcap, each message compressed (message mode).
- long_file_zstd:  MCAP compressed whole (file mode), 3000 scans on /scan and odometry on
                   /odom: a file of many zstd blocks, to be cut.
- long_sqlite_file_zstd: the same in SQLite storage.
- two_scans:       MCAP with /front/scan and /rear/scan, odometry on /odom.
- bad_message:     MCAP whose /scan message 2 is cut short.
- multi_echo:      the same as mcap with the scans as sensor_msgs/msg/MultiEchoLaserScan:
                   each beam's first echo is the mcap bag's reading, a second echo lies
                   beyond it, and the NaN beam has no echo at all.
- cloud:           MCAP with two sensor_msgs/msg/PointCloud2 topics, /points (a 3D lidar,
                   frame velodyne) and /camera/points, odometry on /odom and the lidar's
                   mounting on /tf_static; no 2D scan. expected.json gives, per cloud, the
                   beams that hold a point of the +-0.2 m band (720 beams over the turn)
                   and their ranges.

OUT_DIR/expected.json says what the readers should get: stamps relative to the epoch,
ranges after REP-117 (as strings, so inf and nan survive JSON), poses, mounts.
"""

import json
import math
import sys
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

TS = get_typestore(Stores.ROS2_HUMBLE)
T = TS.types
SCAN = 'sensor_msgs/msg/LaserScan'
MULTI_ECHO = 'sensor_msgs/msg/MultiEchoLaserScan'
ODOM = 'nav_msgs/msg/Odometry'
TF = 'tf2_msgs/msg/TFMessage'
STRING = 'std_msgs/msg/String'

T0 = 1_700_000_000_000_000_000  # ns
RECEIVE_DELAY = 3_000_000  # ns between a header stamp and the bag's receive time
MOUNT = (0.2, -0.1, 0.3)  # base_link -> laser: x, y, yaw
FOOTPRINT_TO_LINK = (0.05, 0.0, 0.0)  # base_footprint -> base_link, 0.1 m up
RANGE_MIN, RANGE_MAX = 0.1, 20.0
BEAMS = 9
N_SCANS, N_TF = 10, 20


def time(ns):
    return T['builtin_interfaces/msg/Time'](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def header(ns, frame):
    return T['std_msgs/msg/Header'](stamp=time(ns), frame_id=frame)


def quaternion(yaw):
    return T['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))


def vector(x, y, z):
    return T['geometry_msgs/msg/Vector3'](x=x, y=y, z=z)


def transform(ns, parent, child, x, y, z, yaw):
    return T['geometry_msgs/msg/TransformStamped'](
        header=header(ns, parent),
        child_frame_id=child,
        transform=T['geometry_msgs/msg/Transform'](translation=vector(x, y, z), rotation=quaternion(yaw)),
    )


def tf_message(transforms):
    return T[TF](transforms=transforms)


def scan_ranges(k):
    """Beam values of scan k: readings, a no-return inf, a NaN, one beyond range_max
    and one below range_min."""
    r = [1.0 + 0.25 * k + 0.5 * i for i in range(BEAMS)]
    r[1] = math.inf
    r[3] = math.nan
    r[5] = 25.0 + k  # beyond range_max: a no-return
    r[7] = 0.05  # below range_min: too close
    return np.array(r, dtype=np.float32)


def rep117(values):
    out = []
    for v in values.tolist():
        if math.isfinite(v) and v > np.float32(RANGE_MAX):
            v = math.inf
        elif math.isfinite(v) and v < np.float32(RANGE_MIN):
            v = -math.inf
        out.append(repr(float(np.float32(v))))
    return out


def scan(ns, frame, ranges):
    return T[SCAN](
        header=header(ns, frame),
        angle_min=-math.pi / 2,
        angle_max=math.pi / 2,
        angle_increment=math.pi / (BEAMS - 1),
        time_increment=0.001,
        scan_time=0.1,
        range_min=RANGE_MIN,
        range_max=RANGE_MAX,
        ranges=ranges,
        intensities=np.zeros(BEAMS, dtype=np.float32),
    )


def multi_echo_scan(ns, frame, ranges):
    """The scan with `ranges` as first echoes: a second, farther echo on every beam but
    the NaN one, which has none."""
    echo = T['sensor_msgs/msg/LaserEcho']
    echoes = [[] if math.isnan(r) else [r, r + 2.0] for r in ranges.tolist()]
    plain = scan(ns, frame, ranges)
    same = ('header', 'angle_min', 'angle_max', 'angle_increment', 'time_increment', 'scan_time',
            'range_min', 'range_max')
    return T[MULTI_ECHO](
        **{field: getattr(plain, field) for field in same},
        ranges=[echo(echoes=np.array(e, dtype=np.float32)) for e in echoes],
        intensities=[echo(echoes=np.ones(len(e), dtype=np.float32)) for e in echoes],
    )


def cloud(ns, frame, points):
    """A PointCloud2 of `points` (x, y, z), float32 fields x, y, z and intensity."""
    field = T['sensor_msgs/msg/PointField']
    fields = [field(name=n, offset=4 * k, datatype=7, count=1) for k, n in enumerate('xyzi')]
    data = np.array([(x, y, z, 1.0) for x, y, z in points], dtype=np.float32)
    return T['sensor_msgs/msg/PointCloud2'](
        header=header(ns, frame), height=1, width=len(points), fields=fields, is_bigendian=False,
        point_step=16, row_step=16 * len(points), data=data.view(np.uint8).reshape(-1), is_dense=True)


def cloud_bag(path):
    """Point clouds and odometry, no 2D scan; returns each cloud's expected beams."""
    cloud_type = 'sensor_msgs/msg/PointCloud2'
    increment = 2 * math.pi / 720
    writer = open_writer(path, StoragePlugin.MCAP)
    clouds = []
    with writer:
        conns = {
            topic: writer.add_connection(topic, msgtype, typestore=TS)
            for topic, msgtype in [('/points', cloud_type), ('/camera/points', cloud_type), ('/odom', ODOM), ('/tf_static', TF)]
        }
        write(writer, conns, '/tf_static', T0, TF, tf_message([transform(T0, 'base_link', 'velodyne', 0.1, 0.0, 0.5, 0.0)]))
        for k in range(5):
            ns = T0 + k * 100_000_000
            write(writer, conns, '/odom', ns, ODOM, odom_msg(ns, 0.1 * k, 0.0, 0.0, 1.0, 0.0))
            beams = {}
            points = []
            for beam, r in [(10, 4.0 + k), (200, 2.5), (360, 3.0), (600, 7.25)]:
                bearing = -math.pi + (beam + 0.5) * increment
                x, y = np.float32(r * math.cos(bearing)), np.float32(r * math.sin(bearing))
                points.append((x, y, 0.1 * (k % 3 - 1)))
                # Farther in the same beam, and nearer but off the band (floor, ceiling).
                points.append((np.float32(1.5 * x), np.float32(1.5 * y), 0.0))
                points.append((np.float32(0.5 * x), np.float32(0.5 * y), -0.45))
                points.append((np.float32(0.5 * x), np.float32(0.5 * y), 0.8))
                beams[beam] = float(np.float32(math.hypot(float(x), float(y))))
            write(writer, conns, '/points', ns + 1, cloud_type, cloud(ns + 1, 'velodyne', points))
            write(writer, conns, '/camera/points', ns + 2, cloud_type, cloud(ns + 2, 'camera', [(0.0, 0.0, 1.0)]))
            clouds.append({'stamp_ns': ns + 1 - T0, 'beams': {str(b): r for b, r in beams.items()}})
    return {'clouds': clouds}


def footprint_pose(j):
    return (0.1 * j, 0.02 * j * j, 0.05 * j - 0.3)


def compose(a, b):
    ax, ay, at = a
    bx, by, bt = b
    return (ax + bx * math.cos(at) - by * math.sin(at), ay + bx * math.sin(at) + by * math.cos(at), at + bt)


def odom_msg(ns, x, y, yaw, v, w):
    pose = T['geometry_msgs/msg/Pose'](position=T['geometry_msgs/msg/Point'](x=x, y=y, z=0.0), orientation=quaternion(yaw))
    twist = T['geometry_msgs/msg/Twist'](linear=vector(v, 0.0, 0.0), angular=vector(0.0, 0.0, w))
    return T[ODOM](
        header=header(ns, 'odom'),
        child_frame_id='base_link',
        pose=T['geometry_msgs/msg/PoseWithCovariance'](pose=pose, covariance=np.zeros(36)),
        twist=T['geometry_msgs/msg/TwistWithCovariance'](twist=twist, covariance=np.zeros(36)),
    )


def open_writer(path, plugin, version=9, compression=None):
    writer = Writer(path, version=version, storage_plugin=plugin)
    if compression is not None:
        writer.set_compression(compression, CompressionFormat.ZSTD)
    return writer


def write(writer, conns, topic, receive_ns, msgtype, msg):
    writer.write(conns[topic], receive_ns, TS.serialize_cdr(msg, msgtype))


def tf_only_bag(path, plugin, compression=None, extras=False, multi_echo=False):
    """Scans on /base_scan (multi-echo ones with `multi_echo`) and odometry on /tf;
    returns what a reader should find."""
    scan_type, scan_msg = (MULTI_ECHO, multi_echo_scan) if multi_echo else (SCAN, scan)
    writer = open_writer(path, plugin, compression=compression)
    with writer:
        conns = {
            topic: writer.add_connection(topic, msgtype, typestore=TS)
            for topic, msgtype in [('/base_scan', scan_type), ('/tf', TF), ('/tf_static', TF), ('/chatter', STRING)]
        }
        statics = tf_message([
            transform(0, 'base_footprint', 'base_link', *FOOTPRINT_TO_LINK[:2], 0.1, FOOTPRINT_TO_LINK[2]),
            transform(0, 'base_link', 'laser', MOUNT[0], MOUNT[1], 0.3, MOUNT[2]),
        ])
        write(writer, conns, '/tf_static', T0, TF, statics)
        events = []
        for j in range(N_TF):
            ns = T0 + j * 50_000_000
            x, y, yaw = footprint_pose(j)
            events.append((ns, '/tf', TF, tf_message([transform(ns, 'odom', 'base_footprint', x, y, 0.0, yaw)])))
        scans = []
        for k in range(N_SCANS):
            ns = T0 + 50_000_000 + k * 100_000_000
            ranges = scan_ranges(k)
            # Scan 3 has no header stamp: the reader falls back to the receive time.
            stamp = 0 if k == 3 else ns
            events.append((ns, '/base_scan', scan_type, scan_msg(stamp, 'laser', ranges)))
            scans.append({'stamp_ns': ns + (RECEIVE_DELAY if k == 3 else 0), 'ranges': rep117(ranges)})
            if extras and k == 5:
                events.append((ns + 1, '/base_scan', scan_type, scan_msg(ns, 'laser', ranges)))
        if extras:
            ns = T0 + 50_000_000 + (N_SCANS - 1) * 100_000_000
            ranges = scan_ranges(N_SCANS - 1) + np.float32(0.5)
            events.append((ns + 2, '/base_scan', scan_type, scan_msg(ns, 'laser', ranges)))
            scans.append({'stamp_ns': ns + 1, 'ranges': rep117(ranges)})
        events.append((T0 + 10, '/chatter', STRING, T[STRING](data='hello')))
        events.sort(key=lambda e: e[0])
        for ns, topic, msgtype, msg in events:
            write(writer, conns, topic, ns + RECEIVE_DELAY, msgtype, msg)
    odometry = []
    for j in range(N_TF):
        x, y, yaw = compose(footprint_pose(j), FOOTPRINT_TO_LINK)
        odometry.append({'stamp_ns': j * 50_000_000, 'x': x, 'y': y, 'theta': yaw})
    for s in scans:
        s['stamp_ns'] -= T0
    return {'scans': scans, 'odometry': odometry, 'mount': list(MOUNT), 'epoch_ns': T0}


def two_scans_bag(path):
    writer = open_writer(path, StoragePlugin.MCAP)
    with writer:
        conns = {
            topic: writer.add_connection(topic, msgtype, typestore=TS)
            for topic, msgtype in [('/front/scan', SCAN), ('/rear/scan', SCAN), ('/odom', ODOM), ('/tf_static', TF)]
        }
        write(writer, conns, '/tf_static', T0, TF, tf_message([
            transform(T0, 'base_link', 'front_laser', 0.3, 0.0, 0.2, 0.0),
            transform(T0, 'base_link', 'rear_laser', -0.3, 0.0, 0.2, math.pi),
        ]))
        for k in range(4):
            ns = T0 + k * 100_000_000
            write(writer, conns, '/odom', ns, ODOM, odom_msg(ns, 0.5 * k, 0.0, 0.1 * k, 0.5, 0.25))
            for topic, frame in [('/front/scan', 'front_laser'), ('/rear/scan', 'rear_laser')]:
                write(writer, conns, topic, ns + 1, SCAN, scan(ns + 1, frame, scan_ranges(k)))
    return {'odometry': [{'stamp_ns': k * 100_000_000, 'x': 0.5 * k, 'y': 0.0, 'theta': 0.1 * k, 'v': 0.5, 'omega': 0.25} for k in range(4)]}


def bad_message_bag(path):
    writer = open_writer(path, StoragePlugin.MCAP)
    with writer:
        conns = {topic: writer.add_connection(topic, msgtype, typestore=TS) for topic, msgtype in [('/scan', SCAN), ('/odom', ODOM)]}
        for k in range(5):
            ns = T0 + k * 100_000_000
            write(writer, conns, '/odom', ns, ODOM, odom_msg(ns, 0.0, 0.0, 0.0, 0.0, 0.0))
            data = TS.serialize_cdr(scan(ns, 'laser', scan_ranges(k)), SCAN)
            if k == 2:
                data = data[:40]
            writer.write(conns['/scan'], ns, data)


def long_bag(path, plugin, compression):
    writer = open_writer(path, plugin, compression=compression)
    with writer:
        conns = {topic: writer.add_connection(topic, msgtype, typestore=TS) for topic, msgtype in [('/scan', SCAN), ('/odom', ODOM)]}
        for k in range(3000):
            ns = T0 + k * 100_000_000
            write(writer, conns, '/odom', ns, ODOM, odom_msg(ns, 0.01 * k, 0.0, 0.0, 0.1, 0.0))
            write(writer, conns, '/scan', ns + 1, SCAN, scan(ns + 1, 'laser', scan_ranges(k)))


def main():
    out = Path(sys.argv[1])
    expected = {
        'mcap': tf_only_bag(out / 'mcap', StoragePlugin.MCAP, CompressionMode.STORAGE),
        'sqlite': tf_only_bag(out / 'sqlite', StoragePlugin.SQLITE3, extras=True),
        'sqlite_file_zstd': tf_only_bag(out / 'sqlite_file_zstd', StoragePlugin.SQLITE3, CompressionMode.FILE),
        'mcap_message_zstd': tf_only_bag(out / 'mcap_message_zstd', StoragePlugin.MCAP, CompressionMode.MESSAGE),
        'two_scans': two_scans_bag(out / 'two_scans'),
        'multi_echo': tf_only_bag(out / 'multi_echo', StoragePlugin.MCAP, multi_echo=True),
        'cloud': cloud_bag(out / 'cloud'),
    }
    bad_message_bag(out / 'bad_message')
    long_bag(out / 'long_file_zstd', StoragePlugin.MCAP, CompressionMode.FILE)
    long_bag(out / 'long_sqlite_file_zstd', StoragePlugin.SQLITE3, CompressionMode.FILE)
    (out / 'expected.json').write_text(json.dumps(expected, indent=1))


if __name__ == '__main__':
    main()
