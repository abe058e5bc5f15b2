#!/usr/bin/python3
# Writes ROS 1 messages serialized by ROS's own Python message classes (Debian's python3-sensor-msgs,
# python3-nav-msgs, python3-tf2-msgs, python3-geometry-msgs): an independent serializer for the
# decoders of recordings/src/ros_msgs.cpp. One line per message: NAME HEX.
import io
import math
import struct

import geometry_msgs.msg as gm
import nav_msgs.msg as nm
import rospy
import sensor_msgs.msg as sm
import sensor_msgs.point_cloud2 as pc2
import std_msgs.msg as st
import tf2_msgs.msg as tm

F = sm.PointField


def emit(name, msg):
    buf = io.BytesIO()
    msg.serialize(buf)
    print(name, buf.getvalue().hex())


def header(sec, nsec, frame):
    h = st.Header()
    h.seq = 7
    h.stamp = rospy.Time(sec, nsec)
    h.frame_id = frame
    return h


# Velodyne's driver: x y z intensity (f32), ring (u16), time (f32 seconds from the stamp); 22-byte
# points padded to 32 as the driver does. Point 3 is a NaN (no return).
fields = [F('x', 0, F.FLOAT32, 1), F('y', 4, F.FLOAT32, 1), F('z', 8, F.FLOAT32, 1),
          F('intensity', 12, F.FLOAT32, 1), F('ring', 16, F.UINT16, 1), F('time', 18, F.FLOAT32, 1)]
pts = [(1.5, -2.25, 0.125, 7.0, 3, -0.05), (10.0, 20.0, -1.0, 100.0, 15, 0.0),
       (float('nan'), float('nan'), float('nan'), 0.0, 4, 0.01), (-3.0, 0.5, 2.0, 1.0, 0, 0.049)]
cloud = pc2.create_cloud(header(1317000000, 123456789, 'velodyne'), fields, pts)
emit('velodyne', cloud)

# Ouster's: x y z (f32) + pad, intensity (f32), t (u32 ns from the stamp), reflectivity (u16),
# ring (u16, "ring" in the ROS driver), organised 2 x 2 with one NaN.
fields = [F('x', 0, F.FLOAT32, 1), F('y', 4, F.FLOAT32, 1), F('z', 8, F.FLOAT32, 1),
          F('intensity', 16, F.FLOAT32, 1), F('t', 20, F.UINT32, 1), F('reflectivity', 24, F.UINT16, 1),
          F('ring', 26, F.UINT16, 1)]
pts = [(1.0, 2.0, 3.0, 0.0, 5.0, 1000, 9, 0), (4.0, 5.0, 6.0, 0.0, 6.0, 50000000, 10, 1),
       (float('nan'), 0.0, 0.0, 0.0, 0.0, 0, 0, 2), (7.0, 8.0, 9.0, 0.0, 8.0, 99000000, 12, 3)]
cloud = pc2.create_cloud(header(1600000000, 0, 'os_lidar'), [F('x', 0, F.FLOAT32, 1), F('y', 4, F.FLOAT32, 1), F('z', 8, F.FLOAT32, 1),
                                                             F('_pad', 12, F.FLOAT32, 1)] + fields[3:], pts)
cloud.height, cloud.width, cloud.row_step = 2, 2, 2 * cloud.point_step
emit('ouster', cloud)

# Hesai's: x y z intensity (f32), timestamp (f64 absolute seconds), ring (u16).
fields = [F('x', 0, F.FLOAT32, 1), F('y', 4, F.FLOAT32, 1), F('z', 8, F.FLOAT32, 1), F('intensity', 12, F.FLOAT32, 1),
          F('timestamp', 16, F.FLOAT64, 1), F('ring', 24, F.UINT16, 1)]
pts = [(1.0, 1.0, 1.0, 1.0, 1700000000.25, 1), (2.0, 2.0, 2.0, 2.0, 1700000000.3, 31)]
emit('hesai', pc2.create_cloud(header(1700000000, 250000000, 'hesai_lidar'), fields, pts))

# Livox's (livox_ros_driver2): x y z intensity (f32), tag, line (u8), timestamp (f64 absolute ns).
fields = [F('x', 0, F.FLOAT32, 1), F('y', 4, F.FLOAT32, 1), F('z', 8, F.FLOAT32, 1), F('intensity', 12, F.FLOAT32, 1),
          F('tag', 16, F.UINT8, 1), F('line', 17, F.UINT8, 1), F('timestamp', 18, F.FLOAT64, 1)]
pts = [(5.0, 0.0, 0.0, 3.0, 0, 2, 1650000000100000000.0), (6.0, 0.0, 0.0, 4.0, 0, 5, 1650000000150000000.0)]
emit('livox', pc2.create_cloud(header(1650000000, 100000000, 'livox_frame'), fields, pts))

# No x: refused.
emit('no_xyz', pc2.create_cloud(header(1, 0, 'l'), [F('a', 0, F.FLOAT32, 1)], [(1.0,)]))

o = nm.Odometry()
o.header = header(1317000001, 5, 'odom')
o.child_frame_id = 'base_link'
o.pose.pose.position = gm.Point(1.0, -2.0, 0.5)
o.pose.pose.orientation = gm.Quaternion(0.0, 0.0, math.sin(0.25), math.cos(0.25))
o.pose.covariance = [float(i) for i in range(36)]
o.twist.twist.linear = gm.Vector3(3.0, 0.1, 0.0)
o.twist.twist.angular = gm.Vector3(0.0, 0.0, 0.2)
emit('odometry', o)

f = sm.NavSatFix()
f.header = header(1317000002, 0, 'gps_antenna')
f.status.status = 2
f.status.service = 1
f.latitude, f.longitude, f.altitude = 49.011, 8.422, 112.5
f.position_covariance = [0.0004, 0, 0, 0, 0.0009, 0, 0, 0, 0.01]
f.position_covariance_type = 2
emit('navsatfix', f)

t = gm.TwistStamped()
t.header = header(5, 6, 'base_link')
t.twist.linear = gm.Vector3(1.0, 2.0, 3.0)
t.twist.angular = gm.Vector3(-1.0, -2.0, -3.0)
emit('twist', t)

i = sm.Imu()
i.header = header(9, 10, 'imu')
i.orientation = gm.Quaternion(0.0, 0.0, 0.0, 1.0)
i.angular_velocity = gm.Vector3(0.1, 0.2, 0.3)
i.linear_acceleration = gm.Vector3(0.0, 0.0, 9.81)
emit('imu', i)

tf = tm.TFMessage()
for parent, child, xyz in (('base_link', 'velodyne', (1.2, 0.0, 1.7)), ('base_link', 'gps_antenna', (-0.3, 0.2, 1.9))):
    x = gm.TransformStamped()
    x.header = header(0, 0, parent)
    x.child_frame_id = child
    x.transform.translation = gm.Vector3(*xyz)
    x.transform.rotation = gm.Quaternion(0.0, 0.0, 0.0, 1.0)
    tf.transforms.append(x)
emit('tf', tf)
