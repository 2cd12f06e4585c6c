#!/usr/bin/env python3
"""Compares two `raycloth run` output folders frame by frame (backend parity, before/after):
the largest and the median distance between corresponding cloth vertices in each frame's OBJ, and
the two run.json's steps, wall time and exact check.
    scripts/compare_runs.py RUN_A RUN_B"""
import glob, json, os, statistics, sys


def vertices(path):
    with open(path) as f:
        return [tuple(map(float, l.split()[1:4])) for l in f if l.startswith("v ")]


def main(a, b):
    frames = sorted(os.path.basename(p) for p in glob.glob(os.path.join(a, "frames", "cloth_*.obj")))
    worst = (0.0, None)
    for name in frames:
        pb = os.path.join(b, "frames", name)
        if not os.path.exists(pb):
            print(f"{name}: missing in {b}")
            return 1
        va, vb = vertices(os.path.join(a, "frames", name)), vertices(pb)
        if len(va) != len(vb):
            print(f"{name}: {len(va)} vertices against {len(vb)}")
            return 1
        d = [sum((x - y) ** 2 for x, y in zip(p, q)) ** 0.5 for p, q in zip(va, vb)]
        if max(d) > worst[0]:
            worst = (max(d), name)
        last = (name, max(d), statistics.median(d))
    print(f"{len(frames)} frames; last {last[0]}: max {last[1] * 1e3:.3f} mm, median {last[2] * 1e3:.3f} mm; "
          f"worst frame {worst[1]}: max {worst[0] * 1e3:.3f} mm")
    for run in (a, b):
        j = json.load(open(os.path.join(run, "run.json")))
        t = json.load(open(os.path.join(run, "timing.json"))) if os.path.exists(os.path.join(run, "timing.json")) else {}
        c = j.get("check", {})
        print(f"{run}: device {j.get('device')}, {j.get('steps')} steps, simulated s per wall s "
              f"{t.get('simulated_seconds_per_wall_second', 0):.3f}; check: {c.get('bad_frames')} bad of "
              f"{c.get('frames_checked')} frames, at most {c.get('max_crossings')} crossings and "
              f"{c.get('max_vertices_inside')} vertices inside")
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
