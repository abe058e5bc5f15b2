#!/usr/bin/python3
# Test helper for test_bag_ros1: writes a ROS 1 bag with Debian's python3-rosbag (a writer
# independent of ours) and a JSON manifest of what it wrote, so the C++ test can compare every
# topic, time and serialized message byte for byte. Run it with /usr/bin/python3 (the system Python
# that has the ROS packages).
#
#   make_ros1_bag.py OUT.bag MANIFEST.json [--compression none|bz2|lz4] [--chunk-threshold N]
#                    [--scenario robot|small|clouds] [--clouds N] [--points N] [--unindexed] [--no-bytes]
#
# Scenario "robot": a lidar, odometry, GPS, a static transform and a pose topic, with a few messages
# written out of time order and two at the same time; then the bag is reopened for appending, which
# makes rosbag add new connections to topics it already has (a second GPS publisher, and the pose
# topic with another message type). Scenario "small": five messages, a few hundred bytes each, as
# seeds for the fuzz target. Scenario "clouds": only PointCloud2 messages of --points points (22
# bytes each), for measuring read speed.
#
# --unindexed makes the bag look like a recording that was stopped before rosbag wrote its index:
# the file is cut where the index section began and the bag header's index_pos, conn_count and
# chunk_count are set to 0, as rosbag writes them when a recording starts.
#
# The manifest: {"topics": [{"name", "type", "definition", "count"}],
#                "messages": [{"topic", "type", "time_ns", "size", "hex"}] (in the order written,
#                which is the order in the file), "connections": N}

import argparse
import json
import os
import random
import struct

import genpy
import geometry_msgs.msg
import nav_msgs.msg
import rosbag
import sensor_msgs.msg
import tf2_msgs.msg

T0 = 1700000000  # seconds; a recent date so the nanosecond times need all 64 bits' attention


class Recorder:
    """Writes messages to a bag and remembers what it wrote."""

    def __init__(self, bag, keep_bytes):
        self.bag = bag
        self.keep_bytes = keep_bytes
        self.messages = []
        self.topics = {}

    def write(self, topic, msg, t, connection_header=None):
        self.bag.write(topic, msg, t, connection_header=connection_header)
        buf = bytearray()

        class Sink:
            def write(self, b):
                buf.extend(b)

        msg.serialize(Sink())
        kind = msg.__class__._type
        entry = {"topic": topic, "type": kind, "time_ns": t.secs * 1000000000 + t.nsecs, "size": len(buf)}
        if self.keep_bytes:
            entry["hex"] = bytes(buf).hex()
        self.messages.append(entry)
        key = (topic, kind)
        if key not in self.topics:
            self.topics[key] = {"name": topic, "type": kind, "definition": msg._full_text, "count": 0}
        self.topics[key]["count"] += 1


def header_for(msg, topic, **extra):
    """A connection header as `rosbag record` writes it (with callerid and, for latched topics, latching)."""
    h = {"topic": topic, "type": msg.__class__._type, "md5sum": msg.__class__._md5sum,
         "message_definition": msg._full_text}
    h.update(extra)
    return h


def point_cloud(rng, t, n, frame="velodyne"):
    """A Velodyne-like cloud: x, y, z, intensity (float32), ring (uint16), time (float32): 22 bytes a point."""
    m = sensor_msgs.msg.PointCloud2()
    m.header.stamp = t
    m.header.frame_id = frame
    m.height = 1
    m.width = n
    F = sensor_msgs.msg.PointField
    m.fields = [F("x", 0, F.FLOAT32, 1), F("y", 4, F.FLOAT32, 1), F("z", 8, F.FLOAT32, 1),
                F("intensity", 12, F.FLOAT32, 1), F("ring", 16, F.UINT16, 1), F("time", 18, F.FLOAT32, 1)]
    m.is_bigendian = False
    m.point_step = 22
    m.row_step = 22 * n
    m.is_dense = True
    if rng is None:
        m.data = os.urandom(22 * n)
    else:
        m.data = bytes(rng.getrandbits(8) for _ in range(22 * n))
    return m


def odometry(rng, t, seq):
    m = nav_msgs.msg.Odometry()
    m.header.seq = seq
    m.header.stamp = t
    m.header.frame_id = "odom"
    m.child_frame_id = "base_link"
    p = m.pose.pose
    p.position.x, p.position.y, p.position.z = rng.uniform(-50, 50), rng.uniform(-50, 50), rng.uniform(-1, 1)
    p.orientation.w = 1.0
    m.pose.covariance = [rng.random() for _ in range(36)]
    m.twist.twist.linear.x = rng.uniform(0, 2)
    m.twist.covariance = [rng.random() for _ in range(36)]
    return m


def nav_sat_fix(rng, t):
    m = sensor_msgs.msg.NavSatFix()
    m.header.stamp = t
    m.header.frame_id = "gps"
    m.status.status = 0
    m.status.service = 1
    m.latitude = 48.1 + rng.random() * 1e-3
    m.longitude = 11.5 + rng.random() * 1e-3
    m.altitude = 520 + rng.random()
    m.position_covariance = [rng.random() for _ in range(9)]
    m.position_covariance_type = 2
    return m


def static_transforms(t):
    m = tf2_msgs.msg.TFMessage()
    for child, x in (("velodyne", 0.3), ("gps", -0.2)):
        tr = geometry_msgs.msg.TransformStamped()
        tr.header.stamp = t
        tr.header.frame_id = "base_link"
        tr.child_frame_id = child
        tr.transform.translation.x = x
        tr.transform.translation.z = 1.2
        tr.transform.rotation.w = 1.0
        m.transforms.append(tr)
    return m


def pose(rng, t):
    m = geometry_msgs.msg.PoseStamped()
    m.header.stamp = t
    m.header.frame_id = "map"
    m.pose.position.x = rng.uniform(-10, 10)
    m.pose.orientation.w = 1.0
    return m


def pose_with_covariance(rng, t):
    m = geometry_msgs.msg.PoseWithCovarianceStamped()
    m.header.stamp = t
    m.header.frame_id = "map"
    m.pose.pose.position.y = rng.uniform(-10, 10)
    m.pose.pose.orientation.w = 1.0
    m.pose.covariance = [rng.random() for _ in range(36)]
    return m


def at(step_ns):
    ns = T0 * 1000000000 + step_ns
    return genpy.Time(ns // 1000000000, ns % 1000000000)


def write_robot(path, args, rng):
    bag = rosbag.Bag(path, "w", compression=args.compression, chunk_threshold=args.chunk_threshold)
    rec = Recorder(bag, not args.no_bytes)
    tf = static_transforms(at(0))
    rec.write("/tf_static", tf, at(0), header_for(tf, "/tf_static", callerid="/robot_state_publisher", latching="1"))
    for i in range(40):
        t = at(i * 50000000 + 1234)  # 20 Hz, with a nanosecond remainder
        o = odometry(rng, t, i)
        rec.write("/odom", o, t, header_for(o, "/odom", callerid="/wheel_odometry"))
        if i % 2 == 0:
            rec.write("/velodyne_points", point_cloud(rng, t, 40 + 3 * i), t)
        if i % 4 == 0:
            rec.write("/gps/fix", nav_sat_fix(rng, t), t)  # the same time as the odometry before it
        if i % 10 == 5:
            rec.write("/pose", pose(rng, t), t)
        if i == 20:
            # Late arrivals: written now, recorded as earlier (a reader must sort by time).
            rec.write("/odom", odometry(rng, at(12500000), 99), at(12500000))
            rec.write("/gps/fix", nav_sat_fix(rng, at(7)), at(7))
    bag.close()

    # Appending starts rosbag afresh on topic connections: a second publisher on /gps/fix and a
    # second message type on /pose get connections of their own.
    bag = rosbag.Bag(path, "a", compression=args.compression, chunk_threshold=args.chunk_threshold)
    rec.bag = bag
    for i in range(40, 48):
        t = at(i * 50000000 + 1234)
        n = nav_sat_fix(rng, t)
        rec.write("/gps/fix", n, t, header_for(n, "/gps/fix", callerid="/gps_b"))
        if i % 4 == 0:
            rec.write("/pose", pose_with_covariance(rng, t), t)
        rec.write("/velodyne_points", point_cloud(rng, t, 10), t)
    bag.close()
    return rec


def write_small(path, args, rng):
    """A few messages of each kind in a few chunks: seeds for the fuzz target (fuzz_ros1_bag)."""
    bag = rosbag.Bag(path, "w", compression=args.compression, chunk_threshold=args.chunk_threshold)
    rec = Recorder(bag, not args.no_bytes)
    tf = static_transforms(at(0))
    rec.write("/tf_static", tf, at(0), header_for(tf, "/tf_static", callerid="/robot_state_publisher", latching="1"))
    rec.write("/odom", odometry(rng, at(5), 0), at(5))
    rec.write("/velodyne_points", point_cloud(rng, at(10), 3), at(10))
    rec.write("/gps/fix", nav_sat_fix(rng, at(3)), at(3))
    rec.write("/odom", odometry(rng, at(10), 1), at(10))
    bag.close()
    return rec


def write_clouds(path, args):
    bag = rosbag.Bag(path, "w", compression=args.compression, chunk_threshold=args.chunk_threshold)
    rec = Recorder(bag, not args.no_bytes)
    for i in range(args.clouds):
        t = at(i * 100000000)
        rec.write("/velodyne_points", point_cloud(None, t, args.points), t)
    bag.close()
    return rec


def cut_index(path):
    """Cut the file where its index began and zero the header's index fields."""
    with open(path, "r+b") as f:
        head = f.read(4096)
        fields = {}
        for name, width in ((b"index_pos=", 8), (b"conn_count=", 4), (b"chunk_count=", 4)):
            p = head.find(name)
            assert p > 0, name
            fields[name] = (p + len(name), width)
        p, _ = fields[b"index_pos="]
        (index_pos,) = struct.unpack("<Q", head[p:p + 8])
        assert index_pos > 4096
        f.truncate(index_pos)
        for p, width in fields.values():
            f.seek(p)
            f.write(b"\0" * width)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("bag")
    ap.add_argument("manifest")
    ap.add_argument("--compression", default="none", choices=["none", "bz2", "lz4"])
    ap.add_argument("--chunk-threshold", type=int, default=4096)
    ap.add_argument("--scenario", default="robot", choices=["robot", "small", "clouds"])
    ap.add_argument("--clouds", type=int, default=3)
    ap.add_argument("--points", type=int, default=1000)
    ap.add_argument("--unindexed", action="store_true")
    ap.add_argument("--no-bytes", action="store_true", help="leave the message bytes out of the manifest")
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args()

    rng = random.Random(args.seed)
    if args.scenario == "robot":
        rec = write_robot(args.bag, args, rng)
    elif args.scenario == "small":
        rec = write_small(args.bag, args, rng)
    else:
        rec = write_clouds(args.bag, args)
    with rosbag.Bag(args.bag) as check:
        connections = len(check._connections)
    if args.unindexed:
        cut_index(args.bag)
    with open(args.manifest, "w") as f:
        json.dump({"topics": list(rec.topics.values()), "messages": rec.messages, "connections": connections}, f)


if __name__ == "__main__":
    main()
