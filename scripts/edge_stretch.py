#!/usr/bin/env python3
"""Edge stretch of one frame of a `raycloth run` output folder, against the first frame's edges
(for cloth that starts unstretched, as the peers' scene does): the mean and largest stretch, how
many edges are stretched over a threshold, and the worst edges with where they are.
    scripts/edge_stretch.py RUN [FRAME_INDEX] [--over 0.1] [--worst 10]"""
import argparse, glob, math, os, sys


def load(path):
    v, f = [], []
    with open(path) as fh:
        for line in fh:
            if line.startswith("v "):
                v.append(tuple(map(float, line.split()[1:4])))
            elif line.startswith("f "):
                f.append([int(x.split("/")[0]) - 1 for x in line.split()[1:4]])
    return v, f


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run")
    ap.add_argument("frame", nargs="?", type=int, help="frame index (default: the last)")
    ap.add_argument("--over", type=float, default=0.1, help="count edges stretched over this share")
    ap.add_argument("--worst", type=int, default=10, help="list this many worst edges")
    a = ap.parse_args()
    frames = sorted(glob.glob(os.path.join(a.run, "frames", "cloth_*.obj")))
    if not frames:
        sys.exit(f"{a.run}: no frames/cloth_*.obj")
    pick = frames[-1] if a.frame is None else os.path.join(a.run, "frames", f"cloth_{a.frame:04d}.obj")
    if not os.path.exists(pick):
        sys.exit(f"{pick}: no such frame")
    v0, faces = load(frames[0])
    v1, _ = load(pick)
    if len(v0) != len(v1):
        sys.exit(f"{pick}: {len(v1)} vertices against {len(v0)} in {frames[0]}")
    edges = sorted({(min(f[k], f[(k + 1) % 3]), max(f[k], f[(k + 1) % 3])) for f in faces for k in range(3)})
    s = [((math.dist(v1[i], v1[j]) - math.dist(v0[i], v0[j])) / math.dist(v0[i], v0[j]), i, j) for i, j in edges]
    s.sort(reverse=True)
    print(f"{os.path.basename(pick)}: {len(s)} edges, stretch mean {100 * sum(x for x, _, _ in s) / len(s):.2f} %, "
          f"max {100 * s[0][0]:.2f} %, {sum(1 for x, _, _ in s if x > a.over)} over {100 * a.over:g} %")
    for x, i, j in s[: a.worst]:
        p = [(v1[i][k] + v1[j][k]) / 2 for k in range(3)]
        print(f"  {100 * x:6.2f} %  vertices {i}-{j}  at ({p[0]:.3f}, {p[1]:.3f}, {p[2]:.3f}), {math.hypot(*p):.3f} m from the origin")


if __name__ == "__main__":
    main()
