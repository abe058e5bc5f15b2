#!/usr/bin/python3
# A pl-sim drive as a vehicle running ROS would have recorded it: a ROS 1 bag written by Debian's
# python3-rosbag, for the ROS node's test. Topics:
#   /velodyne_points  sensor_msgs/PointCloud2 in "velodyne": x y z intensity (float32), ring (uint16,
#                     the nearest of the sensor's vertical angles), time (float32 s from the stamp,
#                     from point_times/)
#   /odom             nav_msgs/Odometry of "base_link" in "odom" at the encoder's 100 Hz: the wheels
#                     integrated as a differential drive (d = (dl + dr) / 2, dtheta = (dr - dl) / L),
#                     pl-sim's encoder telling the LiDAR's planar motion, moved to base_link
#   /gps/fix          sensor_msgs/NavSatFix from gps.csv, frame "gps_antenna"
#   /tf_static        base_link -> velodyne (BASE_FROM_LIDAR below), base_link -> gps_antenna
# Stamps: the drive's times plus T0 (ROS time 0 means "no time"). Usage:
#   make_sim_bag.py SIM_DIR OUT.bag    (prints the first scan's base pose as JSON on stdout)
import json
import math
import os
import struct
import sys

import geometry_msgs.msg as gm
import nav_msgs.msg as nm
import rosbag
import rospy
import sensor_msgs.msg as sm
import std_msgs.msg as st
import tf2_msgs.msg as tm

T0 = 1700000000.0
BASE_FROM_LIDAR = (1.25, 0.0, 1.75)  # translation only: the base sits under the LiDAR

sim, out = sys.argv[1], sys.argv[2]
meta = json.load(open(os.path.join(sim, 'meta.json')))
times = [float(x) for x in open(os.path.join(sim, 'times.txt')).read().split()]
poses = [[float(v) for v in line.split()] for line in open(os.path.join(sim, 'poses.txt')) if line.strip()]
angles = meta['sensor']['vertical_angles_deg']
wheel_base = meta['vehicle']['wheel_base_m']
lever = meta['vehicle']['gps_lever_arm_m']  # the antenna in the LiDAR frame


def stamp(t):
    ns = int(round(t * 1e9))  # the drive's time in whole nanoseconds after T0 (exact, unlike T0 + t)
    return rospy.Time(int(T0) + ns // 1000000000, ns % 1000000000)


def header(t, frame):
    h = st.Header()
    h.stamp = stamp(t)
    h.frame_id = frame
    return h


def quat_yaw(yaw):
    return gm.Quaternion(0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


F = sm.PointField
FIELDS = [F('x', 0, F.FLOAT32, 1), F('y', 4, F.FLOAT32, 1), F('z', 8, F.FLOAT32, 1),
          F('intensity', 12, F.FLOAT32, 1), F('ring', 16, F.UINT16, 1), F('time', 18, F.FLOAT32, 1)]


def cloud(i, t):
    raw = open(os.path.join(sim, 'velodyne', '%06d.bin' % i), 'rb').read()
    n = len(raw) // 16
    pts = struct.unpack('<%df' % (4 * n), raw)
    tpath = os.path.join(sim, 'point_times', '%06d.bin' % i)
    pt = struct.unpack('<%df' % n, open(tpath, 'rb').read()) if os.path.exists(tpath) else [0.0] * n
    data = bytearray()
    for k in range(n):
        x, y, z, inten = pts[4 * k:4 * k + 4]
        elev = math.degrees(math.atan2(z, math.hypot(x, y)))
        ring = min(range(len(angles)), key=lambda r: abs(angles[r] - elev))
        data += struct.pack('<ffffHf', x, y, z, inten, ring, pt[k])
    m = sm.PointCloud2()
    m.header = header(t, 'velodyne')
    m.height, m.width = 1, n
    m.fields = FIELDS
    m.is_bigendian = False
    m.point_step = 22
    m.row_step = 22 * n
    m.data = bytes(data)
    m.is_dense = True
    return m


bag = rosbag.Bag(out, 'w')
try:
    # Extrinsics.
    tfm = tm.TFMessage()
    for child, xyz in (('velodyne', BASE_FROM_LIDAR),
                       ('gps_antenna', tuple(BASE_FROM_LIDAR[j] + lever[j] for j in range(3)))):
        ts = gm.TransformStamped()
        ts.header = header(times[0], 'base_link')
        ts.child_frame_id = child
        ts.transform.translation = gm.Vector3(*xyz)
        ts.transform.rotation = gm.Quaternion(0, 0, 0, 1)
        tfm.transforms.append(ts)
    bag.write('/tf_static', tfm, stamp(times[0]))

    # Odometry: the LiDAR's planar motion from the wheels, then base_link = lidar * inverse(extrinsic).
    x = y = th = 0.0
    prev = None
    for line in open(os.path.join(sim, 'encoder.csv')).read().splitlines()[1:]:
        t, left, right = (float(v) for v in line.split(','))
        if prev is not None:
            dl, dr = left - prev[0], right - prev[1]
            d, dth = (dl + dr) / 2, (dr - dl) / wheel_base
            x += d * math.cos(th + dth / 2)
            y += d * math.sin(th + dth / 2)
            th += dth
        prev = (left, right)
        bx = x - (math.cos(th) * BASE_FROM_LIDAR[0] - math.sin(th) * BASE_FROM_LIDAR[1])
        by = y - (math.sin(th) * BASE_FROM_LIDAR[0] + math.cos(th) * BASE_FROM_LIDAR[1])
        o = nm.Odometry()
        o.header = header(t, 'odom')
        o.child_frame_id = 'base_link'
        o.pose.pose.position = gm.Point(bx, by, -BASE_FROM_LIDAR[2])
        o.pose.pose.orientation = quat_yaw(th)
        bag.write('/odom', o, stamp(t))

    for line in open(os.path.join(sim, 'gps.csv')).read().splitlines()[1:]:
        t, lat, lon, alt, std, status = (float(v) for v in line.split(','))
        f = sm.NavSatFix()
        f.header = header(t, 'gps_antenna')
        f.status.status = -1 if status == 0 else 2 if status >= 4 else 0
        f.latitude, f.longitude, f.altitude = lat, lon, alt
        f.position_covariance = [std * std, 0, 0, 0, std * std, 0, 0, 0, 4 * std * std]
        f.position_covariance_type = 2
        bag.write('/gps/fix', f, stamp(t))

    for i, t in enumerate(times):
        bag.write('/velodyne_points', cloud(i, t), stamp(t))
finally:
    bag.close()

# The first scan's pose: of the LiDAR (x, y, z, yaw) for pl-localize --init, of the base for the node.
p = poses[0]
yaw = math.atan2(p[4], p[0])
lx, ly, lz = p[3], p[7], p[11]
bx = lx - (math.cos(yaw) * BASE_FROM_LIDAR[0] - math.sin(yaw) * BASE_FROM_LIDAR[1])
by = ly - (math.sin(yaw) * BASE_FROM_LIDAR[0] + math.cos(yaw) * BASE_FROM_LIDAR[1])
print(json.dumps({'lidar': [lx, ly, lz, math.degrees(yaw)], 'base': [bx, by, lz - BASE_FROM_LIDAR[2], 0.0, 0.0, math.degrees(yaw)],
                  'base_from_lidar': BASE_FROM_LIDAR, 't0': T0 + times[0], 'scans': len(times)}))
