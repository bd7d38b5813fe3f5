"""Rewrites a ROS 1 bag the way bags recorded before tf2 look, with the independent
`rosbags` library: every frame id with a leading slash (`/odom`, `/base_link`) and the
transforms typed `tf/tfMessage` instead of `tf2_msgs/TFMessage` (the same fields).

Usage: tf1_bag.py SOURCE.bag TARGET.bag
"""

import sys
from pathlib import Path

from rosbags.rosbag1 import Reader, Writer
from rosbags.typesys import Stores, get_typestore, get_types_from_msg

TF2 = 'tf2_msgs/msg/TFMessage'
TF1 = 'tf/msg/tfMessage'


def slashed(frame):
    return frame if not frame or frame.startswith('/') else '/' + frame


def with_slashes(msg):
    """The message with a leading slash on its header's, child's and transforms' frames."""
    if hasattr(msg, 'header'):
        msg.header.frame_id = slashed(msg.header.frame_id)
    if hasattr(msg, 'child_frame_id'):
        msg.child_frame_id = slashed(msg.child_frame_id)
    for t in getattr(msg, 'transforms', []):
        with_slashes(t)
    return msg


def main():
    source, target = Path(sys.argv[1]), Path(sys.argv[2])
    store = get_typestore(Stores.ROS1_NOETIC)
    with Reader(source) as reader:
        for c in reader.connections:
            if c.msgtype not in store.types:
                store.register(get_types_from_msg(c.msgdef.data, c.msgtype))
        store.register(get_types_from_msg('geometry_msgs/TransformStamped[] transforms', TF1))
        with Writer(target) as writer:
            msgtypes = {c.id: TF1 if c.msgtype == TF2 else c.msgtype for c in reader.connections}
            out = {c.id: writer.add_connection(c.topic, msgtypes[c.id], typestore=store)
                   for c in reader.connections}
            for c, ns, data in reader.messages():
                msg = with_slashes(store.deserialize_ros1(data, c.msgtype))
                if msgtypes[c.id] == TF1:
                    msg = store.types[TF1](transforms=msg.transforms)
                writer.write(out[c.id], ns, store.serialize_ros1(msg, msgtypes[c.id]))


if __name__ == '__main__':
    main()
