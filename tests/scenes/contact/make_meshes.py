#!/usr/bin/env python3
"""Writes the OBJ cloth meshes of the contact scenes in this folder (standard library only).

    python3 make_meshes.py      # writes poncho.obj and tube_skirt.obj beside this file

poncho.obj     a 1.0 m square (31 x 31 grid, 3.3 cm, diagonals alternating) lying in y = 0,
               centred on the origin, with a round head hole of radius 0.14 m at its centre
               (every triangle whose centroid lies within 0.14 m is removed; the hole's edge
               is a staircase between 0.14 and about 0.17 m).
tube_skirt.obj an open tube 0.55 m long, its axis along y: the top ring (y = 0) is an
               ellipse of semi-axes 0.15 m (x) by 0.20 m (z), the hem (y = -0.55) a circle
               of radius 0.32 m, 48 vertices round, 19 rings. The top ring's 48 vertices
               come first (OBJ vertices 0..47, numbered from 0), so a scene can attach them
               with "range": [0, 47].
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def write_obj(path, header, verts, faces):
    with open(path, "w") as f:
        for line in header:
            f.write("# " + line + "\n")
        for v in verts:
            f.write("v %.6f %.6f %.6f\n" % v)
        for a, b, c in faces:
            f.write("f %d %d %d\n" % (a + 1, b + 1, c + 1))


def check_manifold(faces, nverts):
    """Every edge in at most two faces, consistently oriented; every vertex one fan."""
    edges = {}
    for t in faces:
        for i in range(3):
            e = (t[i], t[(i + 1) % 3])
            assert e not in edges, "edge %s used twice in the same direction" % (e,)
            edges[e] = True
    # Boundary edges: directed edges whose reverse is absent. Each boundary vertex must start
    # exactly one of them (otherwise two fans meet at it: a bow-tie).
    starts = {}
    for (a, b) in edges:
        if (b, a) not in edges:
            starts[a] = starts.get(a, 0) + 1
    bad = [v for v, n in starts.items() if n != 1]
    assert not bad, "bow-tie vertices: %s" % bad[:10]
    used = set(i for t in faces for i in t)
    assert len(used) == nverts, "unused vertices"


def poncho(size=1.0, n=31, hole=0.14):
    h = size / (n - 1)
    grid = {}
    verts = []
    faces = []
    tris = []
    for j in range(n - 1):
        for i in range(n - 1):
            a, b, c, d = (i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)
            # Alternate the diagonal by quadrant so the square is symmetric about its centre lines.
            if (i < (n - 1) // 2) == (j < (n - 1) // 2):
                tris += [(a, b, c), (a, c, d)]
            else:
                tris += [(a, b, d), (b, c, d)]

    def pos(ij):
        return (-size / 2 + ij[0] * h, 0.0, -size / 2 + ij[1] * h)

    for t in tris:
        p = [pos(k) for k in t]
        cx = sum(q[0] for q in p) / 3
        cz = sum(q[2] for q in p) / 3
        if math.hypot(cx, cz) < hole:
            continue
        idx = []
        for k in t:
            if k not in grid:
                grid[k] = len(verts)
                verts.append(pos(k))
            idx.append(grid[k])
        # Counter-clockwise seen from +y: the normal points up (+y).
        faces.append((idx[0], idx[2], idx[1]))
    check_manifold(faces, len(verts))
    return verts, faces


def tube(around=48, rings=19, length=0.55, top=(0.15, 0.20), hem=0.32):
    verts = []
    for r in range(rings):
        s = r / (rings - 1)
        ax = top[0] + s * (hem - top[0])
        az = top[1] + s * (hem - top[1])
        y = -s * length
        for k in range(around):
            th = 2 * math.pi * k / around
            verts.append((ax * math.cos(th), y, az * math.sin(th)))
    faces = []
    for r in range(rings - 1):
        for k in range(around):
            a = r * around + k
            b = r * around + (k + 1) % around
            c = (r + 1) * around + (k + 1) % around
            d = (r + 1) * around + k
            # Outward normals; diagonals alternate round the tube.
            if (k + r) % 2 == 0:
                faces += [(a, c, d), (a, b, c)]
            else:
                faces += [(a, b, d), (b, c, d)]
    check_manifold(faces, len(verts))
    return verts, faces


def main():
    v, f = poncho()
    write_obj(os.path.join(HERE, "poncho.obj"),
              ["poncho: 1.0 m square, 31 x 31 grid, head hole of radius 0.14 m at the centre",
               "written by make_meshes.py; %d vertices, %d triangles" % (len(v), len(f))], v, f)
    print("poncho.obj: %d vertices, %d triangles" % (len(v), len(f)))
    v, f = tube()
    write_obj(os.path.join(HERE, "tube_skirt.obj"),
              ["tube skirt: open tube 0.55 m, top ellipse 0.15 x 0.20 m, hem radius 0.32 m",
               "48 round x 19 rings; OBJ vertices 0..47 (from 0) are the top ring",
               "written by make_meshes.py; %d vertices, %d triangles" % (len(v), len(f))], v, f)
    print("tube_skirt.obj: %d vertices, %d triangles" % (len(v), len(f)))


if __name__ == "__main__":
    main()
