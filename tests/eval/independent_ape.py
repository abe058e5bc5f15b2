#!/usr/bin/env python3
"""Independent check of `pl-eval ape` on two KITTI pose files, in plain Python 3 (stdlib only).

usage: independent_ape.py EST GT [--align none|se3|sim3]

Reads the two files line by line (blank lines and lines starting with '#' are skipped, as in the
C++ reader), pairs line i of EST with line i of GT, takes the translations (fields 4, 8, 12 of the
row-major 3x4 matrix) and prints the APE statistics as one JSON object: alignment, matched,
gt_poses, coverage, mean, median, rmse, std (population), max.

--align se3 aligns EST onto GT with Horn's closed-form quaternion method (the eigenvector of the
largest eigenvalue of a 4x4 symmetric matrix, found here by Jacobi rotations), a different route to
the same least-squares rotation as the SVD that pl-eval uses.

--align sim3 adds Horn's scale: with that rotation R, s = sum(gt' . R est') / sum |est'|^2 over the
centred points (the asymmetric least-squares scale, section 2.D of Horn's paper), and prints it as
"scale".
"""
import json
import math
import sys


def read_kitti_translations(path):
    out = []
    with open(path) as f:
        for number, line in enumerate(f, 1):
            text = line.strip()
            if not text or text.startswith('#'):
                continue
            fields = text.split()
            if len(fields) != 12:
                sys.exit('%s:%d: expected 12 numbers, found %d' % (path, number, len(fields)))
            v = [float(x) for x in fields]
            out.append((v[3], v[7], v[11]))
    return out


def jacobi_eigen(a, sweeps=100):
    """Eigenvalues and eigenvectors (columns) of a small symmetric matrix."""
    n = len(a)
    a = [row[:] for row in a]
    v = [[1.0 if i == j else 0.0 for j in range(n)] for i in range(n)]
    for _ in range(sweeps):
        off = sum(a[i][j] ** 2 for i in range(n) for j in range(n) if i != j)
        if off < 1e-30:
            break
        for p in range(n):
            for q in range(p + 1, n):
                if abs(a[p][q]) < 1e-300:
                    continue
                theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q])
                t = (1.0 if theta >= 0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                c = 1.0 / math.sqrt(t * t + 1.0)
                s = t * c
                for k in range(n):  # A <- A J
                    akp, akq = a[k][p], a[k][q]
                    a[k][p] = c * akp - s * akq
                    a[k][q] = s * akp + c * akq
                for k in range(n):  # A <- J^T A
                    apk, aqk = a[p][k], a[q][k]
                    a[p][k] = c * apk - s * aqk
                    a[q][k] = s * apk + c * aqk
                for k in range(n):
                    vkp, vkq = v[k][p], v[k][q]
                    v[k][p] = c * vkp - s * vkq
                    v[k][q] = s * vkp + c * vkq
    return [a[i][i] for i in range(n)], v


def horn_align(src, dst, with_scale=False):
    """Rotation matrix, translation and scale minimising sum |s R src + t - dst|^2 (Horn 1987);
    s = 1 unless with_scale."""
    n = float(len(src))
    ms = [sum(p[k] for p in src) / n for k in range(3)]
    md = [sum(p[k] for p in dst) / n for k in range(3)]
    s = [[0.0] * 3 for _ in range(3)]  # S[a][b] = sum src'_a dst'_b
    for p, q in zip(src, dst):
        a = [p[k] - ms[k] for k in range(3)]
        b = [q[k] - md[k] for k in range(3)]
        for i in range(3):
            for j in range(3):
                s[i][j] += a[i] * b[j]
    (sxx, sxy, sxz), (syx, syy, syz), (szx, szy, szz) = s
    nmat = [
        [sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
        [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
        [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
        [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz],
    ]
    values, vectors = jacobi_eigen(nmat)
    best = max(range(4), key=lambda i: values[i])
    w, x, y, z = (vectors[k][best] for k in range(4))
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / norm, x / norm, y / norm, z / norm
    r = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]
    scale = 1.0
    if with_scale:
        num = 0.0
        den = 0.0
        for p, q in zip(src, dst):
            a = [p[k] - ms[k] for k in range(3)]
            b = [q[k] - md[k] for k in range(3)]
            ra = [sum(r[i][k] * a[k] for k in range(3)) for i in range(3)]
            num += sum(b[i] * ra[i] for i in range(3))
            den += sum(x * x for x in a)
        scale = num / den
    t = [md[i] - scale * sum(r[i][k] * ms[k] for k in range(3)) for i in range(3)]
    return r, t, scale


def main(argv):
    args = argv[1:]
    align = 'none'
    if '--align' in args:
        i = args.index('--align')
        align = args[i + 1]
        del args[i:i + 2]
    if len(args) != 2 or align not in ('none', 'se3', 'sim3'):
        sys.exit(__doc__)
    est = read_kitti_translations(args[0])
    gt = read_kitti_translations(args[1])
    if len(est) > len(gt):
        sys.exit('estimate longer than ground truth')
    gt_matched = gt[:len(est)]
    scale = None
    if align in ('se3', 'sim3'):
        r, t, scale = horn_align(est, gt_matched, align == 'sim3')
        est = [tuple(scale * sum(r[i][k] * p[k] for k in range(3)) + t[i] for i in range(3)) for p in est]
    errors = [math.sqrt(sum((p[k] - q[k]) ** 2 for k in range(3))) for p, q in zip(est, gt_matched)]
    n = len(errors)
    mean = math.fsum(errors) / n
    ordered = sorted(errors)
    median = ordered[n // 2] if n % 2 else 0.5 * (ordered[n // 2 - 1] + ordered[n // 2])
    rmse = math.sqrt(math.fsum(e * e for e in errors) / n)
    std = math.sqrt(math.fsum((e - mean) ** 2 for e in errors) / n)
    result = {
        'alignment': align,
        'matched': n,
        'gt_poses': len(gt),
        'coverage': n / len(gt),
        'mean': mean,
        'median': median,
        'rmse': rmse,
        'std': std,
        'max': ordered[-1],
    }
    if align == 'sim3':
        result['scale'] = scale
    print(json.dumps(result, indent=2))


if __name__ == '__main__':
    main(sys.argv)
