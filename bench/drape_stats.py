#!/usr/bin/env python3
"""Compares the last cloth frame of two `raycloth run` folders (same scene geometry, e.g. the
explicit and the implicit run of the peers' scene): the median, mean and largest vertex distance,
and each run's edge strain (every edge of the OBJ faces against its length in the first frame),
mean of |strain| and largest, over all edges and, with --sphere CX CY CZ R, separately for the edges
within 2 cm of that sphere and the others. Needs numpy (Debian python3-numpy).

  python3 bench/drape_stats.py OUT_EXPLICIT OUT_IMPLICIT [--sphere 0 0 0 0.25]
"""
import argparse
import glob
import sys

import numpy as np


def load(path):
    vertices, edges = [], set()
    with open(path) as f:
        for line in f:
            if line.startswith('v '):
                vertices.append([float(x) for x in line.split()[1:4]])
            elif line.startswith('f '):
                face = [int(x.split('/')[0]) - 1 for x in line.split()[1:]]
                for k in range(len(face)):
                    a, b = face[k], face[(k + 1) % len(face)]
                    edges.add((min(a, b), max(a, b)))
    return np.array(vertices), np.array(sorted(edges))


def frames(folder):
    found = sorted(glob.glob(folder + '/frames/cloth_*.obj'))
    if not found:
        sys.exit(f'{folder}: no frames/cloth_*.obj (run with the OBJ output)')
    return found


def strain(x, edges, rest):
    return np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1) / rest - 1.0


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('a')
    p.add_argument('b')
    p.add_argument('--sphere', nargs=4, type=float, metavar=('CX', 'CY', 'CZ', 'R'))
    o = p.parse_args()
    fa, fb = frames(o.a), frames(o.b)
    first, edges = load(fa[0])
    rest = np.linalg.norm(first[edges[:, 0]] - first[edges[:, 1]], axis=1)
    xa, _ = load(fa[-1])
    xb, _ = load(fb[-1])
    if xa.shape != xb.shape:
        sys.exit('the two runs have different cloths')
    d = np.linalg.norm(xa - xb, axis=1)
    print(f'last frames: {fa[-1]} and {fb[-1]}')
    print(f'vertex distance: median {100 * np.median(d):.2f} cm, mean {100 * d.mean():.2f} cm, largest {100 * d.max():.2f} cm')
    for name, x in ((o.a, xa), (o.b, xb)):
        s = strain(x, edges, rest)
        line = f'{name}: strain mean {100 * np.abs(s).mean():.2f} %, largest {100 * s.max():.1f} %'
        if o.sphere:
            c, r = np.array(o.sphere[:3]), o.sphere[3]
            mid = 0.5 * (x[edges[:, 0]] + x[edges[:, 1]])
            near = np.linalg.norm(mid - c, axis=1) < r + 0.02
            line += (f'; on the sphere ({near.sum()} edges) {100 * np.abs(s[near]).mean():.2f} %, '
                     f'elsewhere ({(~near).sum()}) {100 * np.abs(s[~near]).mean():.2f} %')
        print(line)


if __name__ == '__main__':
    main()
