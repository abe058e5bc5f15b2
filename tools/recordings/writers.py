# Writers of robot recordings from ROS 1 message objects (Debian's python3-rosbag and message
# packages), for tests and benchmarks: a ROS 1 bag through rosbag itself, and a ROS 2 bag (.db3 with
# CDR messages) and an MCAP file through the small writers here, written to those formats'
# specifications. A message is (topic, type, time_ns, message); time_ns is when it was recorded.
import io
import os
import sqlite3
import struct
import zlib

import geometry_msgs.msg as gm
import nav_msgs.msg as nm
import rosbag
import rospy
import sensor_msgs.msg as sm
import tf2_msgs.msg as tm


def ros_time(ns):
    return rospy.Time(ns // 1000000000, ns % 1000000000)


def write_ros1(path, messages, compression='lz4', chunk_threshold=768 * 1024):
    with rosbag.Bag(path, 'w', compression=compression, chunk_threshold=chunk_threshold) as bag:
        for topic, _, t, m in messages:
            bag.write(topic, m, ros_time(t))


class Cdr:
    """CDR as ROS 2 writes it: the encapsulation header, primitives aligned to their size from its end,
    strings with their NUL counted in their length."""

    def __init__(self):
        self.b = bytearray(b'\x00\x01\x00\x00')

    def put(self, fmt, v):
        n = struct.calcsize(fmt)
        while (len(self.b) - 4) % n:
            self.b.append(0)
        self.b += struct.pack('<' + fmt, v)

    def string(self, s):
        self.put('I', len(s) + 1)
        self.b += s.encode() + b'\x00'

    def header(self, h):
        self.put('i', h.stamp.secs)
        self.put('I', h.stamp.nsecs)
        self.string(h.frame_id)

    def doubles(self, values):
        for v in values:
            self.put('d', v)


def cdr(m):
    w = Cdr()
    if isinstance(m, sm.PointCloud2):
        w.header(m.header)
        w.put('I', m.height)
        w.put('I', m.width)
        w.put('I', len(m.fields))
        for f in m.fields:
            w.string(f.name)
            w.put('I', f.offset)
            w.put('B', f.datatype)
            w.put('I', f.count)
        w.put('B', int(m.is_bigendian))
        w.put('I', m.point_step)
        w.put('I', m.row_step)
        w.put('I', len(m.data))
        w.b += bytes(m.data)
        w.put('B', int(m.is_dense))
    elif isinstance(m, nm.Odometry):
        w.header(m.header)
        w.string(m.child_frame_id)
        p = m.pose.pose
        w.doubles([p.position.x, p.position.y, p.position.z, p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w])
        w.doubles(m.pose.covariance)
        v = m.twist.twist
        w.doubles([v.linear.x, v.linear.y, v.linear.z, v.angular.x, v.angular.y, v.angular.z])
        w.doubles(m.twist.covariance)
    elif isinstance(m, sm.NavSatFix):
        w.header(m.header)
        w.put('b', m.status.status)
        w.put('H', m.status.service)
        w.doubles([m.latitude, m.longitude, m.altitude])
        w.doubles(m.position_covariance)
        w.put('B', m.position_covariance_type)
    elif isinstance(m, tm.TFMessage):
        w.put('I', len(m.transforms))
        for x in m.transforms:
            w.header(x.header)
            w.string(x.child_frame_id)
            tr, q = x.transform.translation, x.transform.rotation
            w.doubles([tr.x, tr.y, tr.z, q.x, q.y, q.z, q.w])
    else:
        raise ValueError('no CDR writer for ' + type(m).__name__)
    return bytes(w.b)


def ros2_type(t):
    pkg, name = t.split('/')
    return pkg + '/msg/' + name


def topics_of(messages):
    topics = []
    for topic, typ, _, _ in messages:
        if (topic, typ) not in topics:
            topics.append((topic, typ))
    return topics


def write_ros2(folder, messages):
    """A ROS 2 bag folder: metadata.yaml and one .db3 with the tables rosbag2 (Humble) writes."""
    os.makedirs(folder, exist_ok=True)
    name = os.path.basename(os.path.normpath(folder)) + '_0.db3'
    path = os.path.join(folder, name)
    if os.path.exists(path):
        os.remove(path)
    topics = topics_of(messages)
    db = sqlite3.connect(path)
    db.execute('CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL)')
    db.execute("INSERT INTO schema VALUES (3, 'humble')")
    db.execute('CREATE TABLE metadata(id INTEGER PRIMARY KEY, metadata_version INTEGER NOT NULL, metadata TEXT NOT NULL)')
    db.execute('CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, '
               'serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL)')
    db.execute('CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL, data BLOB NOT NULL)')
    for i, (topic, typ) in enumerate(topics):
        db.execute('INSERT INTO topics VALUES (?, ?, ?, ?, ?)', (i + 1, topic, ros2_type(typ), 'cdr', ''))
    for topic, typ, t, m in messages:
        db.execute('INSERT INTO messages(topic_id, timestamp, data) VALUES (?, ?, ?)', (topics.index((topic, typ)) + 1, t, cdr(m)))
    db.commit()
    db.close()
    with open(os.path.join(folder, 'metadata.yaml'), 'w') as f:
        f.write('rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n'
                '  relative_file_paths:\n    - %s\n  compression_format: ""\n  compression_mode: ""\n'
                '  message_count: %d\n' % (name, len(messages)))


def _record(op, body):
    return struct.pack('<BQ', op, len(body)) + body


def _str(s):
    b = s.encode() if isinstance(s, str) else s
    return struct.pack('<I', len(b)) + b


def write_mcap(path, messages, per_chunk=4):
    """MCAP with CDR messages: header, schemas and channels, chunks of `per_chunk` messages
    (uncompressed, with their CRC), data end, footer; no summary section."""
    topics = topics_of(messages)
    with open(path, 'wb') as out:
        out.write(b'\x89MCAP0\r\n')
        out.write(_record(0x01, _str('ros2') + _str('pointlocalization-tools')))
        for i, (topic, typ) in enumerate(topics):
            out.write(_record(0x03, struct.pack('<H', i + 1) + _str(ros2_type(typ)) + _str('ros2msg') + _str(b'')))
            out.write(_record(0x04, struct.pack('<HH', i + 1, i + 1) + _str(topic) + _str('cdr') + struct.pack('<I', 0)))
        seq = 0
        for start in range(0, len(messages), per_chunk):
            group = messages[start:start + per_chunk]
            records = bytearray()
            for topic, typ, t, m in group:
                seq += 1
                records += _record(0x05, struct.pack('<HIQQ', topics.index((topic, typ)) + 1, seq, t, t) + cdr(m))
            times = [t for _, _, t, _ in group]
            out.write(_record(0x06, struct.pack('<QQQI', min(times), max(times), len(records), zlib.crc32(records)) + _str('') +
                              struct.pack('<Q', len(records)) + bytes(records)))
        out.write(_record(0x0F, struct.pack('<I', 0)))
        out.write(_record(0x02, struct.pack('<QQI', 0, 0, 0)))
        out.write(b'\x89MCAP0\r\n')
