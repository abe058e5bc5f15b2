#!/usr/bin/python3
# Writes one small drive as three recordings, for the recording datasets' tests: a ROS 1 bag written by
# Debian's python3-rosbag (lz4 chunks), a ROS 2 bag (metadata.yaml + .db3, CDR messages) and an MCAP
# file (CDR messages, a chunk per four messages), the last two with tools/recordings/writers.py. The drive: 6 scans at 10 Hz of a box-shaped room seen from a
# vehicle moving 1 m/s along x, Velodyne-style clouds (x y z intensity ring time) in frame "velodyne"
# with one NaN point each, odometry of base_link in odom at 20 Hz, GPS fixes at 5 Hz from
# "gps_antenna", and /tf_static: base_link -> velodyne (1.2, 0, 1.7) and base_link -> gps_antenna
# (-0.3, 0.2, 1.9). Usage: make_drive_recordings.py OUT_DIR
import json
import math
import os
import sys

import geometry_msgs.msg as gm
import nav_msgs.msg as nm
import rospy
import sensor_msgs.msg as sm
import sensor_msgs.point_cloud2 as pc2
import std_msgs.msg as st
import tf2_msgs.msg as tm

out = sys.argv[1]
os.makedirs(out, exist_ok=True)
T0 = 1700000000  # seconds since 1970: times stay absolute
F = sm.PointField
FIELDS = [F('x', 0, F.FLOAT32, 1), F('y', 4, F.FLOAT32, 1), F('z', 8, F.FLOAT32, 1),
          F('intensity', 12, F.FLOAT32, 1), F('ring', 16, F.UINT16, 1), F('time', 18, F.FLOAT32, 1)]


def stamp(t):
    sec = int(math.floor(t))
    return sec, int(round((t - sec) * 1e9))


def scan_points(k):
    pts = []
    for ring in range(16):
        elev = math.radians(-15 + 2 * ring)
        for j in range(90):
            az = 2 * math.pi * j / 90
            d = 8.0 + 0.01 * k + 0.5 * math.sin(3 * az)
            pts.append((d * math.cos(az) * math.cos(elev), d * math.sin(az) * math.cos(elev), d * math.sin(elev),
                        float(ring * 3 + j % 7), ring, -0.05 + 0.1 * j / 90))
    pts.insert(100, (float('nan'), float('nan'), float('nan'), 0.0, 3, 0.0))
    return pts


def header(t, frame):
    h = st.Header()
    h.stamp = rospy.Time(*stamp(t))
    h.frame_id = frame
    return h


# (topic, type, time, ros1 message)
msgs = []
tf = tm.TFMessage()
for child, xyz in (('velodyne', (1.2, 0.0, 1.7)), ('gps_antenna', (-0.3, 0.2, 1.9))):
    x = gm.TransformStamped()
    x.header = header(T0, 'base_link')
    x.child_frame_id = child
    x.transform.translation = gm.Vector3(*xyz)
    x.transform.rotation = gm.Quaternion(0, 0, 0, 1)
    tf.transforms.append(x)
msgs.append(('/tf_static', 'tf2_msgs/TFMessage', T0, tf))
for k in range(6):
    t = T0 + 0.1 * k
    # Recorded a little after the sweep's stamp, as a driver publishes at the sweep's end.
    msgs.append(('/velodyne_points', 'sensor_msgs/PointCloud2', t + 0.05, pc2.create_cloud(header(t, 'velodyne'), FIELDS, scan_points(k))))
for k in range(12):
    t = T0 + 0.05 * k
    o = nm.Odometry()
    o.header = header(t, 'odom')
    o.child_frame_id = 'base_link'
    o.pose.pose.position = gm.Point(1.0 * (t - T0), 0.0, 0.0)
    o.pose.pose.orientation = gm.Quaternion(0, 0, math.sin(0.01 * k), math.cos(0.01 * k))
    o.twist.twist.linear = gm.Vector3(1.0, 0, 0)
    msgs.append(('/odom', 'nav_msgs/Odometry', t, o))
for k in range(3):
    t = T0 + 0.2 * k
    f = sm.NavSatFix()
    f.header = header(t, 'gps_antenna')
    f.status.status = 2
    f.latitude, f.longitude, f.altitude = 49.0 + 1e-5 * k, 8.4, 110.0
    f.position_covariance = [0.0004, 0, 0, 0, 0.0004, 0, 0, 0, 0.0016]
    f.position_covariance_type = 2
    msgs.append(('/gps/fix', 'sensor_msgs/NavSatFix', t, f))
msgs.sort(key=lambda m: m[2])

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'tools', 'recordings'))
import writers  # noqa: E402

as_ns = [(topic, typ, round(t * 1e9), m) for topic, typ, t, m in msgs]
writers.write_ros1(os.path.join(out, 'drive.bag'), as_ns, compression='lz4', chunk_threshold=64 * 1024)
writers.write_ros2(os.path.join(out, 'drive_ros2'), as_ns)
writers.write_mcap(os.path.join(out, 'drive.mcap'), as_ns)

# The same drive with a ground-truth topic: the LiDAR's pose in "world" at each scan's stamp (a
# reference system's, e.g. an RTK/INS), with odometry beside it.
truth = []
for k in range(6):
    t = T0 + 0.1 * k
    o = nm.Odometry()
    o.header = header(t, 'world')
    o.child_frame_id = 'velodyne'
    o.pose.pose.position = gm.Point(100.0 + 1.25 * k, -3.0 + 0.5 * k, 0.125 * k)
    o.pose.pose.orientation = gm.Quaternion(0, 0, math.sin(0.05 * k), math.cos(0.05 * k))
    truth.append(('/ground_truth', 'nav_msgs/Odometry', round(t * 1e9), o))
writers.write_ros1(os.path.join(out, 'drive_truth.bag'), sorted(as_ns + truth, key=lambda m: m[2]), compression='none')
print(json.dumps({'scans': 6, 'odometry': 12, 'gps': 3}))
