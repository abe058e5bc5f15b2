#!/usr/bin/python3
# The ROS 1 node end to end, with real parts: a rosmaster on a free port, pl-server serving a map
# built from a pl-sim drive, the node started by its launch file through roslaunch, the drive played
# from a ROS 1 bag (written by Debian's python3-rosbag) by `rosbag play --clock`.
#  1. The node's per-scan poses match pl-localize's on the same bag and map within 1 cm; it publishes
#     the fused pose at the odometry's rate, map -> odom on /tf, and diagnostics.
#  2. The map service is away when a second node starts (it retries and says so), comes, goes away
#     in the middle of the drive (the node says offline and keeps localizing) and comes back (online,
#     fetching again); the drive played again (its clock jumps back) restarts the node's localizer.
#  3. With no start pose the node waits, saying so, until /initialpose (rviz's "2D Pose Estimate")
#     starts it.
#  4. ros1/config/localizer.yaml holds every setting of `pl-localize --list-settings`, at its default.
# Usage: test_ros1_node.py BUILD_DIR WORK_DIR
import json
import math
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time

BUILD, WORK = sys.argv[1], sys.argv[2]
BIN = os.path.join(BUILD, 'bin')
HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.dirname(os.path.dirname(HERE))
failures = []
procs = []


def check(ok, what):
    print(('ok    ' if ok else 'FAIL  ') + what, flush=True)
    if not ok:
        failures.append(what)


def run(cmd, **kw):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, **kw)
    if r.returncode != 0:
        sys.exit('command failed (%d): %s\n%s' % (r.returncode, ' '.join(cmd), r.stdout))
    return r.stdout


def start(cmd, log, env=None):
    p = subprocess.Popen(cmd, stdout=open(log, 'w'), stderr=subprocess.STDOUT, env=env, start_new_session=True)
    procs.append(p)
    return p


def stop(p):
    if p.poll() is None:
        os.killpg(p.pid, signal.SIGINT)
        try:
            p.wait(20)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()


def free_port():
    s = socket.socket()
    s.bind(('127.0.0.1', 0))
    port = s.getsockname()[1]
    s.close()
    return port


def lidar_of(x, y, z, r):
    """The LiDAR's position from the node's base position, turned as pl-localize's pose r (a KITTI
    row: lidar = base + R * base_from_lidar)."""
    return (x + r[0] * E[0] + r[1] * E[1] + r[2] * E[2], y + r[4] * E[0] + r[5] * E[1] + r[6] * E[2],
            z + r[8] * E[0] + r[9] * E[1] + r[10] * E[2])


def wait_for(pred, timeout, what):
    t = time.time()
    while time.time() - t < timeout:
        if pred():
            return True
        time.sleep(0.1)
    print('timed out after %.0f s waiting for %s' % (timeout, what), flush=True)
    return False


shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)
W = lambda *p: os.path.join(WORK, *p)  # noqa: E731

# --- The drive, its map, its bag, and pl-localize's poses on them. ---
run([os.path.join(BIN, 'pl-sim'), '--route', 'loop', '--frames', '40', '--seed', '7', '--lidar', 'vlp16', '--out', W('drive')])
run([os.path.join(BIN, 'pl-map'), 'build', '--dataset', W('drive'), '--poses', 'gt', '--out', W('map.pcd')])
run([os.path.join(BIN, 'pl-map'), 'tile', '--cloud', W('map.pcd'), '--db', W('maps.sqlite'), '--map', 'town'])
run([os.path.join(BIN, 'pl-map'), 'publish', '--db', W('maps.sqlite'), '--map', 'town', '--version', '1'])
start_pose = json.loads(run(['/usr/bin/python3', os.path.join(HERE, 'make_sim_bag.py'), W('drive'), W('drive.bag')]))
E = start_pose['base_from_lidar']
scans = start_pose['scans']

server_port = free_port()
server_url = 'http://127.0.0.1:%d' % server_port


def start_server(log):
    p = start([os.path.join(BIN, 'pl-server'), '--db', W('maps.sqlite'), '--listen', '127.0.0.1:%d' % server_port], W(log))
    wait_for(lambda: 'listening' in open(W(log)).read(), 30, 'pl-server')
    return p


server = start_server('server1.log')
init = ','.join('%.17g' % v for v in start_pose['lidar'])
run([os.path.join(BIN, 'pl-localize'), '--dataset', W('drive.bag'), '--server', server_url, '--map', 'town', '--init', init,
     '--init-search', 'off', '--kitti-out', W('ref.txt'), '--out', W('ref.tum')])
ref = [[float(v) for v in line.split()] for line in open(W('ref.txt')) if line.strip() and not line.startswith('#')]
check(len(ref) == scans, 'pl-localize localized the %d scans of the bag' % scans)
# A recording's own frame is ENU about its first fix, 12 m from the map's origin here: --init gps
# places the fix about the map's origin, so the first scan starts within the antenna's lever arm.
run([os.path.join(BIN, 'pl-localize'), '--dataset', W('drive.bag'), '--server', server_url, '--map', 'town', '--init', 'gps',
     '--timing', W('gps.csv'), '--out', W('gps.tum')])
first = open(W('gps.csv')).read().splitlines()
correction = float(first[1].split(',')[first[0].split(',').index('correction_m')])
check(correction < 2.0, 'a GPS start from a recording lands about the map\'s origin (first correction %.2f m)' % correction)

# --- ROS. ---
env = dict(os.environ)
master_port = free_port()
env.update({'ROS_MASTER_URI': 'http://127.0.0.1:%d' % master_port, 'ROS_HOME': W('ros'), 'ROS_LOG_DIR': W('ros', 'log'),
            'ROS_PACKAGE_PATH': os.path.join(BUILD, 'ros1', 'share'), 'CMAKE_PREFIX_PATH': os.path.join(BUILD, 'ros1'),
            'ROSCONSOLE_STDOUT_LINE_BUFFERED': '1', 'PYTHONUNBUFFERED': '1'})
# roscpp keeps singletons alive to the end of the process: LeakSanitizer would call them leaks.
env['ASAN_OPTIONS'] = 'detect_leaks=0:abort_on_error=1'
os.environ.update(env)
master = start(['rosmaster', '--core', '-p', str(master_port)], W('master.log'), env)

import rospy  # noqa: E402  (after ROS_MASTER_URI is set)
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from geometry_msgs.msg import PoseWithCovarianceStamped  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from tf2_msgs.msg import TFMessage  # noqa: E402

wait_for(lambda: subprocess.run(['rosparam', 'list'], env=env, capture_output=True).returncode == 0, 30, 'rosmaster')
rospy.init_node('pl_test', anonymous=True, disable_signals=True)
rospy.set_param('/use_sim_time', True)

lock = threading.Lock()
got = {'pose': [], 'odometry': [], 'tf': [], 'diag': []}


def listen(node):
    def on_pose(m):
        with lock:
            p = m.pose.pose
            got['pose'].append((m.header.stamp.to_nsec(), p.position.x, p.position.y, p.position.z,
                                p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w, list(m.pose.covariance)))

    def on_diag(m):
        with lock:
            got['diag'].append((time.time(), {s.name: (s.level, s.message, {kv.key: kv.value for kv in s.values}) for s in m.status}))

    def on_tf(m):
        with lock:
            for t in m.transforms:
                got['tf'].append((t.header.frame_id, t.child_frame_id))

    return [rospy.Subscriber('/%s/pose' % node, PoseWithCovarianceStamped, on_pose),
            rospy.Subscriber('/%s/odometry' % node, Odometry, lambda m: got['odometry'].append(m.header.stamp.to_nsec())),
            rospy.Subscriber('/diagnostics', DiagnosticArray, on_diag),
            rospy.Subscriber('/tf', TFMessage, on_tf)]


def launch(node, log, params, settings, init='pose'):
    """The launch file with the node's own parameters set first and the settings in a copy of
    ros1/config/localizer.yaml (the launch file loads it, over anything set before)."""
    import yaml
    for k, v in params.items():
        rospy.set_param('/%s/%s' % (node, k), v)
    config = yaml.safe_load(open(os.path.join(SOURCE, 'ros1', 'config', 'localizer.yaml')))
    for name, v in settings.items():
        d = config
        *path, last = name.split('/')
        for p in path:
            d = d[p]
        assert last in d, name
        d[last] = v
    yaml.safe_dump(config, open(W(node + '.yaml'), 'w'))
    return start(['roslaunch', 'pl_localizer', 'localizer.launch', 'server:=' + server_url, 'map:=town', 'init:=' + init,
                  'respawn:=false', 'node_name:=' + node, 'points:=/velodyne_points', 'odom:=/odom', 'fix:=/gps/fix',
                  'config:=' + W(node + '.yaml')], W(log), env)


def play(rate):
    return subprocess.run(['rosbag', 'play', '--clock', '-r', str(rate), '--wait-for-subscribers', W('drive.bag')],
                          stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT, env=env, timeout=120).returncode


def tiles_status():
    with lock:
        for _, d in reversed(got['diag']):
            if 'pl_localizer: map tiles' in d:
                return d['pl_localizer: map tiles']
    return None


def node_alive(node):
    return subprocess.run(['pgrep', '-f', '__name:=' + node], capture_output=True).returncode == 0


try:
    # 1. The same poses as pl-localize.
    subs = listen('pl_localizer')
    node1 = launch('pl_localizer', 'node1.log', {'initial_pose': start_pose['base'], 'initial_search': False, 'queue_scans': True}, {})
    check(play(0.5) == 0, 'rosbag play ran')
    wait_for(lambda: len(got['pose']) >= scans, 120, 'the node\'s %d poses' % scans)
    time.sleep(1.5)
    with lock:
        poses, odo, tfs = list(got['pose']), list(got['odometry']), list(got['tf'])
    check(len(poses) == scans, 'the node published one pose per scan (%d of %d)' % (len(poses), scans))
    worst = 0.0
    for (ns, x, y, z, *_), r in zip(poses, ref):
        lx, ly, lz = lidar_of(x, y, z, r)
        worst = max(worst, math.sqrt((lx - r[3]) ** 2 + (ly - r[7]) ** 2 + (lz - r[11]) ** 2))
    check(worst < 0.01, 'the node\'s poses match pl-localize\'s within 1 cm (max %.6f m)' % worst)
    stamps = [p[0] for p in poses]
    check(stamps == sorted(stamps) and abs(stamps[0] / 1e9 - start_pose['t0']) < 1e-6, 'poses in order, the first at the first scan\'s stamp')
    check(all(p[8][0] > 0 and p[8][7] > 0 and p[8][35] > 0 for p in poses), 'every pose carries a covariance')
    check(len(odo) >= 0.9 * (scans - 1) * 10, 'fused poses at the odometry\'s 100 Hz (%d over %.1f s)' % (len(odo), (scans - 1) / 10))
    check(('map', 'odom') in tfs, 'map -> odom published on /tf')
    st = tiles_status()
    check(st is not None and st[0] == 0 and st[2].get('online') == 'true', 'diagnostics: the tile client online (%s)' % (st,))
    stop(node1)
    for s in subs:
        s.unregister()

    # 2. The map service away at the start, away in the middle, back; the clock jumping back.
    stop(server)
    with lock:
        for k in got:
            got[k].clear()
    subs = listen('pl_local2')
    node2 = launch('pl_local2', 'node2.log', {'initial_pose': start_pose['base'], 'initial_search': False, 'queue_scans': True,
                                              'retry_s': 0.5},
                   {'tiles/radius_m': 45.0, 'localizer/roi_radius_m': 40.0, 'ready_timeout_s': 1.0})
    player = threading.Thread(target=play, args=(0.25,))
    player.start()
    ok = wait_for(lambda: (tiles_status() or (0, '', {}))[2].get('attempts', '0') not in ('0', '1'), 30,
                  'the node to report that the map service is away')
    st = tiles_status()
    check(ok and st[0] == 2 and st[1] != '', 'diagnostics: no map yet, retrying (%s)' % (st,))
    server = start_server('server2.log')
    wait_for(lambda: len(got['pose']) >= 3, 60, 'the first poses after the map service came')
    stop(server)
    wait_for(lambda: (tiles_status() or (0, '', {}))[2].get('online') == 'false', 30, 'the node to notice the outage')
    st = tiles_status()
    check(st is not None and st[0] == 1 and st[2].get('online') == 'false', 'diagnostics: offline during the outage (%s)' % (st,))
    fetched_before = int(st[2].get('fetched', '0')) if st else 0
    n_before = len(got['pose'])
    # The next pose comes from the tiles the node holds (the wait is a hang guard, not a time bound).
    check(wait_for(lambda: len(got['pose']) > n_before or len(got['pose']) >= scans - 5, 120, 'a pose during the outage'),
          'still localizing during the outage')
    server = start_server('server3.log')
    player.join()
    wait_for(lambda: (tiles_status() or (0, '', {}))[2].get('online') == 'true', 60, 'the node to be online again')
    st = tiles_status()
    check(st is not None and st[2].get('online') == 'true' and int(st[2].get('fetched', '0')) > fetched_before,
          'diagnostics: online again, tiles fetched after the outage (%s)' % (st,))
    # Every scan is registered (~queue_scans), some after the drive has played (slow builds).
    wait_for(lambda: len(got['pose']) >= scans, 180, 'every scan of the first play')
    time.sleep(1.0)
    first_run = len(got['pose'])
    check(first_run == scans, 'a pose for every scan, through the outage (%d of %d)' % (first_run, scans))
    check(play(0.5) == 0, 'the drive played again')
    wait_for(lambda: len(got['pose']) >= first_run + scans, 120, 'the poses of the second play')
    second = [p for p in got['pose'][first_run:]]
    check(len(second) == scans, 'after the clock jumped back the node started again: one pose per scan (%d)' % len(second))
    worst = 0.0
    for (ns, x, y, z, *_), r in zip(second, ref):
        lx, ly, _ = lidar_of(x, y, z, r)
        worst = max(worst, math.hypot(lx - r[3], ly - r[7]))
    check(worst < 0.2, 'and localized again from the start pose (max %.3f m from pl-localize\'s)' % worst)
    check(node_alive('pl_local2'), 'the node is still running')
    stop(node2)
    for sub in subs:
        sub.unregister()

    # 3. No start pose: the node waits (scans dropped, saying why) until rviz's "2D Pose Estimate"
    #    arrives on /initialpose, 1 m and 5 degrees off; the next scan searches round it.
    with lock:
        for k in got:
            got[k].clear()
    subs = listen('pl_local3')
    node3 = launch('pl_local3', 'node3.log', {'queue_scans': True}, {}, init='wait')
    player = threading.Thread(target=play, args=(0.25,))
    player.start()

    def localization():
        with lock:
            for _, d in reversed(got['diag']):
                if 'pl_localizer: localization' in d:
                    return d['pl_localizer: localization']
        return None
    ok = wait_for(lambda: (localization() or (0, '', {}))[1] == 'waiting for /initialpose' and
                  int(localization()[2].get('dropped', '0')) > 0, 60, 'the node to wait for /initialpose')
    check(ok and not got['pose'], 'without a start the node drops the scans and says it waits for /initialpose (%s)' % (localization(),))
    b0 = start_pose['base']
    yaw = math.radians(b0[5] + 5.0)
    guess = PoseWithCovarianceStamped()
    guess.header.frame_id = 'map'
    guess.pose.pose.position.x, guess.pose.pose.position.y = b0[0] + 0.8, b0[1] - 0.6
    guess.pose.pose.orientation.z, guess.pose.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    pub = rospy.Publisher('/initialpose', PoseWithCovarianceStamped, queue_size=1, latch=True)
    wait_for(lambda: pub.get_num_connections() > 0, 30, 'the node to subscribe to /initialpose')
    pub.publish(guess)
    player.join()
    wait_for(lambda: len(got['pose']) >= 5, 120, 'poses after /initialpose')
    time.sleep(2.0)
    with lock:
        after = list(got['pose'])
    worst = 0.0
    for ns, x, y, z, *_ in after[2:]:
        k = int(round((ns / 1e9 - start_pose['t0']) / 0.1))
        r = ref[k]
        lx, ly, _ = lidar_of(x, y, z, r)
        worst = max(worst, math.hypot(lx - r[3], ly - r[7]))
    check(len(after) >= 5 and worst < 0.2, '/initialpose started the node: %d poses, from the third on within %.3f m of '
          'pl-localize\'s' % (len(after), worst))
    stop(node3)

    # 4. The settings file: every setting, at its default.
    listed = {}
    for line in run([os.path.join(BIN, 'pl-localize'), '--list-settings']).splitlines():
        name, _, value = line.split(' ', 1)[0].partition('=')
        listed[name] = value
    own = {'tiles/server', 'tiles/map', 'store_path', 'tiles/token', 'tiles/cache_path', 'localizer/scan/beams',
           'localizer/scan/sensor_beams', 'localizer/compensate_motion', 'start_from_gps'}  # the node's own parameters
    check(len(listed) > 100 and 'localizer/icp/kernel_m' in listed, 'pl-localize --list-settings lists %d settings' % len(listed))
    import yaml  # noqa: E402
    flat = {}

    def walk(d, prefix):
        for k, v in d.items():
            if isinstance(v, dict):
                walk(v, prefix + k + '/')
            else:
                flat[prefix + k] = v
    walk(yaml.safe_load(open(os.path.join(SOURCE, 'ros1', 'config', 'localizer.yaml'))), '')
    missing = [k for k in listed if k not in flat and k not in own]
    check(not missing, 'localizer.yaml has every setting (missing: %s)' % missing[:8])
    def same(text, v):
        if isinstance(v, bool):
            return text == ('true' if v else 'false')
        if isinstance(v, (int, float)):
            return abs(float(text) - v) <= 1e-12 * max(1.0, abs(v))
        return text == str(v)
    wrong = [k for k, v in flat.items() if k not in listed or k in own or not same(listed[k], v)]
    check(not wrong, 'localizer.yaml\'s values are the defaults (differing or unknown: %s)' % wrong[:8])
finally:
    for p in reversed(procs):
        stop(p)
    try:
        rospy.signal_shutdown('done')
    except Exception:
        pass

if failures:
    print('%d checks failed; logs in %s' % (len(failures), WORK))
    sys.exit(1)
print('all checks passed')
