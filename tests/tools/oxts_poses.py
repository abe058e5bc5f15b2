#!/usr/bin/env python3
"""Independent check of pl-dataset's OXTS conversion (python3 standard library only).

Converts a KITTI raw drive's OXTS records to LiDAR poses the usual KITTI way -- scaled Mercator,
R = Rz(yaw) Ry(pitch) Rx(roll), relative to the first frame, then T_imu->velo * T * T_imu->velo^-1 --
and compares them with a KITTI pose file. Prints the largest differences; exits 1 above --tol metres.

usage: oxts_poses.py RAW_DIR POSES.txt [--tol 0.001]
"""
import math
import os
import sys

EARTH_RADIUS = 6378137.0


def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def rigid_inverse(t):
    r = [[t[j][i] for j in range(3)] for i in range(3)]
    p = [-sum(r[i][k] * t[k][3] for k in range(3)) for i in range(3)]
    return [r[0] + [p[0]], r[1] + [p[1]], r[2] + [p[2]], [0.0, 0.0, 0.0, 1.0]]


def rotation(roll, pitch, yaw):
    cr, sr, cp, sp, cy, sy = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch), math.cos(yaw), math.sin(yaw)
    rx = [[1, 0, 0], [0, cr, -sr], [0, sr, cr]]
    ry = [[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]]
    rz = [[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]]
    m3 = lambda a, b: [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    return m3(rz, m3(ry, rx))


def main():
    args = sys.argv[1:]
    tol = 0.001
    if "--tol" in args:
        i = args.index("--tol")
        tol = float(args[i + 1])
        del args[i:i + 2]
    raw, poses_path = args
    files = sorted(f for f in os.listdir(os.path.join(raw, "oxts", "data")) if f.endswith(".txt"))
    oxts = [[float(v) for v in open(os.path.join(raw, "oxts", "data", f)).read().split()] for f in files]

    calib = {}
    for line in open(os.path.join(raw, "calib_imu_to_velo.txt")):
        key, _, rest = line.partition(":")
        calib[key.strip()] = rest
    r = [float(v) for v in calib["R"].split()]
    t = [float(v) for v in calib["T"].split()]
    imu_to_velo = [r[0:3] + [t[0]], r[3:6] + [t[1]], r[6:9] + [t[2]], [0.0, 0.0, 0.0, 1.0]]
    velo_to_imu = rigid_inverse(imu_to_velo)

    scale = math.cos(oxts[0][0] * math.pi / 180.0)
    first_inv = None
    expected = []
    for o in oxts:
        mx = scale * o[1] * math.pi * EARTH_RADIUS / 180.0
        my = scale * EARTH_RADIUS * math.log(math.tan((90.0 + o[0]) * math.pi / 360.0))
        rot = rotation(o[3], o[4], o[5])
        pose = [rot[0] + [mx], rot[1] + [my], rot[2] + [o[2]], [0.0, 0.0, 0.0, 1.0]]
        if first_inv is None:
            first_inv = rigid_inverse(pose)
        expected.append(matmul(matmul(imu_to_velo, matmul(first_inv, pose)), velo_to_imu))

    got = [[float(v) for v in line.split()] for line in open(poses_path) if line.strip() and not line.startswith('#')]
    if len(got) != len(expected):
        print("pose count differs: %d in %s, %d OXTS records" % (len(got), poses_path, len(expected)))
        return 1
    max_t = max_r = 0.0
    for e, g in zip(expected, got):
        for i in range(3):
            max_t = max(max_t, abs(e[i][3] - g[4 * i + 3]))
            for j in range(3):
                max_r = max(max_r, abs(e[i][j] - g[4 * i + j]))
    print("poses %d  max translation difference %.3e m  max rotation entry difference %.3e" % (len(got), max_t, max_r))
    return 0 if max_t <= tol and max_r <= 1e-6 else 1


if __name__ == "__main__":
    sys.exit(main())
