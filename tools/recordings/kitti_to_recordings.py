#!/usr/bin/python3
# A KITTI raw drive as a robot would have recorded it, in the three formats: DRIVE.bag (ROS 1, written
# by Debian's python3-rosbag), DRIVE_ros2/ (ROS 2 .db3) and DRIVE.mcap (tools/recordings/writers.py).
# Topics: /velodyne_points (sensor_msgs/PointCloud2: x y z intensity float32 and ring uint16, the ring
# found as pl's rings_from_azimuth finds it, in float32 arithmetic, so that the beams chosen match the
# folder's), /ground_truth (nav_msgs/Odometry: the LiDAR's ground-truth pose in "world", given as a
# TUM file, e.g. `pl-dataset poses DRIVE --format tum`), /gps/fix (sensor_msgs/NavSatFix from OXTS),
# /tf_static (velodyne -> oxts: the IMU/antenna in the LiDAR frame). Stamps are the drive's absolute
# OXTS times. Usage: kitti_to_recordings.py DRIVE_DIR GT_TUM OUT_STEM [--formats bag,ros2,mcap]
#   [--bag-compression lz4|bz2|none] [--layout pl|velodyne-zero-time|pcl-xyzi]
# --layout velodyne-zero-time writes the clouds as the Velodyne driver lays them out (x y z intensity
# float32, ring uint16, time float32) with every time 0, as several drivers and converters leave it;
# --layout pcl-xyzi as PCL's PointXYZI (x y z, 4 bytes of padding, intensity, point_step 32; no ring).
import argparse
import datetime
import math
import os
import struct
import sys

import geometry_msgs.msg as gm
import nav_msgs.msg as nm
import sensor_msgs.msg as sm
import std_msgs.msg as st
import tf2_msgs.msg as tm

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import writers  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument('drive')
ap.add_argument('truth')
ap.add_argument('out')
ap.add_argument('--formats', default='bag,ros2,mcap')
ap.add_argument('--bag-compression', default='lz4', choices=['none', 'bz2', 'lz4'])
ap.add_argument('--layout', default='pl', choices=['pl', 'velodyne-zero-time', 'pcl-xyzi'])
a = ap.parse_args()
F = sm.PointField


def f32(v):
    return struct.unpack('f', struct.pack('f', v))[0]


def pseudo_azimuth(x, y):
    # As common/src/scan.cpp computes it in float32: an add, then a division, each rounded to float32
    # (a double result rounded once to float32 equals the float32 operation's result).
    s = f32(abs(x) + abs(y))
    if s == 0.0:
        return 0.0
    if y >= 0.0:
        return f32(y / s) if x >= 0.0 else f32(1.0 - f32(x / s))
    return f32(2.0 - f32(y / s)) if x < 0.0 else f32(3.0 + f32(x / s))


def rings_from_azimuth(xs, ys):
    rings, ring, prev = [], 0, 0.0
    for i, (x, y) in enumerate(zip(xs, ys)):
        az = pseudo_azimuth(x, y)
        if i > 0 and f32(prev - az) > 0.25 and ring < 65535:
            ring += 1
        rings.append(ring)
        prev = az
    if ring > 0:
        last, before = rings.count(ring), rings.count(ring - 1)
        if last * 20 < before:
            rings = [r - 1 if r == ring else r for r in rings]
    return rings


def stamp_ns(text):
    # "2011-09-26 13:02:25.964389445" as nanoseconds since 1970 (UTC), exactly.
    day, clock = text.strip().split(' ')
    h, m, s = clock.split(':')
    whole, frac = (s.split('.') + [''])[:2]
    d = datetime.datetime.strptime(day, '%Y-%m-%d').replace(tzinfo=datetime.timezone.utc)
    secs = int(d.timestamp()) + int(h) * 3600 + int(m) * 60 + int(whole)
    return secs * 1000000000 + int((frac + '000000000')[:9])


def header(ns, frame):
    h = st.Header()
    h.stamp = writers.ros_time(ns)
    h.frame_id = frame
    return h


scans_dir = os.path.join(a.drive, 'velodyne_points', 'data')
names = sorted(n for n in os.listdir(scans_dir) if n.endswith('.bin'))
times = [stamp_ns(line) for line in open(os.path.join(a.drive, 'oxts', 'timestamps.txt')) if line.strip()]
truth = [list(map(float, line.split())) for line in open(a.truth) if line.strip() and not line.startswith('#')]
if len(truth) != len(names):
    sys.exit('%s: %d poses for %d scans' % (a.truth, len(truth), len(names)))
calib = {}
for line in open(os.path.join(a.drive, 'calib_imu_to_velo.txt')):
    if ':' in line:
        k, v = line.split(':', 1)
        calib[k.strip()] = [float(x) for x in v.split()] if k.strip() in ('R', 'T') else v
R, T = calib['R'], calib['T']


def quat_from_matrix(r):
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = r
    tr = m00 + m11 + m22
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        return ((m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, 0.25 * s)
    if m00 > m11 and m00 > m22:
        s = math.sqrt(1.0 + m00 - m11 - m22) * 2
        return (0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s)
    if m11 > m22:
        s = math.sqrt(1.0 + m11 - m00 - m22) * 2
        return ((m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s)
    s = math.sqrt(1.0 + m22 - m00 - m11) * 2
    return ((m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s)


messages = []
tf = tm.TFMessage()
x = gm.TransformStamped()
x.header = header(times[0], 'velodyne')
x.child_frame_id = 'oxts'
x.transform.translation = gm.Vector3(*T)
x.transform.rotation = gm.Quaternion(*quat_from_matrix(R))
tf.transforms.append(x)
messages.append(('/tf_static', 'tf2_msgs/TFMessage', times[0], tf))
fields = [F('x', 0, F.FLOAT32, 1), F('y', 4, F.FLOAT32, 1), F('z', 8, F.FLOAT32, 1), F('intensity', 12, F.FLOAT32, 1),
          F('ring', 16, F.UINT16, 1)]
step = 18
if a.layout == 'velodyne-zero-time':
    fields.append(F('time', 18, F.FLOAT32, 1))
    step = 22
if a.layout == 'pcl-xyzi':
    fields = [F('x', 0, F.FLOAT32, 1), F('y', 4, F.FLOAT32, 1), F('z', 8, F.FLOAT32, 1), F('intensity', 16, F.FLOAT32, 1)]
    step = 32
for i, name in enumerate(names):
    frame = int(name[:-4])
    raw = open(os.path.join(scans_dir, name), 'rb').read()
    n = len(raw) // 16
    vals = struct.unpack('<%df' % (4 * n), raw)
    xs, ys = vals[0::4], vals[1::4]
    rings = rings_from_azimuth(xs, ys)
    data = bytearray(step * n)  # the time field, where there is one, and padding stay 0
    for k in range(n):
        if a.layout == 'pcl-xyzi':
            struct.pack_into('<3f4xf', data, step * k, vals[4 * k], vals[4 * k + 1], vals[4 * k + 2], vals[4 * k + 3])
        else:
            struct.pack_into('<4fH', data, step * k, vals[4 * k], vals[4 * k + 1], vals[4 * k + 2], vals[4 * k + 3], rings[k])
    c = sm.PointCloud2()
    c.header = header(times[frame], 'velodyne')
    c.height, c.width, c.fields, c.is_bigendian = 1, n, fields, False
    c.point_step, c.row_step, c.data, c.is_dense = step, step * n, bytes(data), True
    messages.append(('/velodyne_points', 'sensor_msgs/PointCloud2', times[frame] + 50000000, c))
    t = truth[i]
    o = nm.Odometry()
    o.header = header(times[frame], 'world')
    o.child_frame_id = 'velodyne'
    o.pose.pose.position = gm.Point(t[1], t[2], t[3])
    o.pose.pose.orientation = gm.Quaternion(t[4], t[5], t[6], t[7])
    messages.append(('/ground_truth', 'nav_msgs/Odometry', times[frame], o))
    ox = [float(v) for v in open(os.path.join(a.drive, 'oxts', 'data', '%010d.txt' % frame)).read().split()]
    f = sm.NavSatFix()
    f.header = header(times[frame], 'oxts')
    posmode = int(ox[27])
    f.status.status = 2 if posmode >= 4 else 1 if posmode == 2 else 0 if posmode >= 1 else -1
    f.status.service = 1
    f.latitude, f.longitude, f.altitude = ox[0], ox[1], ox[2]
    f.position_covariance = [ox[23] ** 2, 0, 0, 0, ox[23] ** 2, 0, 0, 0, (2 * ox[23]) ** 2]
    f.position_covariance_type = 2
    messages.append(('/gps/fix', 'sensor_msgs/NavSatFix', times[frame], f))
    if sys.stderr.isatty():  # a progress line on a terminal only
        print('\r%d / %d scans' % (i + 1, len(names)), end='', file=sys.stderr)
if sys.stderr.isatty():
    print(file=sys.stderr)
messages.sort(key=lambda m: m[2])
formats = a.formats.split(',')
if 'bag' in formats:
    writers.write_ros1(a.out + '.bag', messages, compression=a.bag_compression)
if 'ros2' in formats:
    writers.write_ros2(a.out + '_ros2', messages)
if 'mcap' in formats:
    writers.write_mcap(a.out + '.mcap', messages)
