# The peers' scene in Blender's cloth simulator, run headless by raycloth_vs_bullet:
#
#   blender -b --factory-startup --python-exit-code 1 --python bench/blender/peers_drape.py -- \
#       --size 1.0 --resolution 65 --height 0.30 --radius 0.25 --slices 24 --stacks 25 \
#       --friction 0.4 --duration 2.0 --fps 30 --quality 5 --self-distance 0.005 --out R.json
#
# A square cloth of resolution x resolution vertices (quads, as Blender's cloth springs expect) over
# a UV sphere, both built in Blender from the same numbers as raycloth's scene; Blender's cloth with
# self-collision steps frame by frame (`quality` substeps per frame) and the script times those
# steps alone. It writes the final cloth in raycloth's frame (y up: Blender's z becomes y, its y
# becomes -z) as triangles, so that the caller runs raycloth's exact check and stretch measure on it.
import argparse
import json
import os
import sys
import time

import bpy


def arguments():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="peers_drape.py")
    p.add_argument("--size", type=float, required=True, help="cloth side, metres")
    p.add_argument("--resolution", type=int, required=True, help="vertices along each side")
    p.add_argument("--height", type=float, required=True, help="cloth height above the sphere's centre, metres")
    p.add_argument("--radius", type=float, required=True)
    p.add_argument("--slices", type=int, required=True)
    p.add_argument("--stacks", type=int, required=True)
    p.add_argument("--friction", type=float, required=True)
    p.add_argument("--duration", type=float, required=True, help="simulated seconds")
    p.add_argument("--fps", type=int, default=30)
    p.add_argument("--quality", type=int, default=5, help="Blender's cloth steps per frame")
    p.add_argument("--self-distance", type=float, default=0.005, help="self-collision distance, metres")
    p.add_argument("--distance", type=float, default=0.005, help="cloth-object collision distance, metres")
    p.add_argument("--out", required=True)
    return p.parse_args(argv)


def build_cloth(a):
    n, h = a.resolution, a.size / (a.resolution - 1)
    verts = [(-0.5 * a.size + u * h, -0.5 * a.size + v * h, a.height) for v in range(n) for u in range(n)]
    faces = [(v * n + u, v * n + u + 1, (v + 1) * n + u + 1, (v + 1) * n + u) for v in range(n - 1) for u in range(n - 1)]
    mesh = bpy.data.meshes.new("cloth")
    mesh.from_pydata(verts, [], faces)
    mesh.update()
    obj = bpy.data.objects.new("cloth", mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def main():
    a = arguments()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = a.fps
    frames = int(round(a.duration * a.fps))
    scene.frame_start, scene.frame_end = 1, frames + 1
    scene.gravity = (0.0, 0.0, -9.81)

    bpy.ops.mesh.primitive_uv_sphere_add(segments=a.slices, ring_count=a.stacks, radius=a.radius, location=(0, 0, 0))
    sphere = bpy.context.active_object
    collision = sphere.modifiers.new("Collision", "COLLISION").settings
    collision.cloth_friction = a.friction * 100.0  # Blender's friction is 0..80 for cloth: a coefficient x 100
    collision.thickness_outer = a.distance

    cloth_obj = build_cloth(a)
    cloth = cloth_obj.modifiers.new("Cloth", "CLOTH")
    s = cloth.settings
    s.quality = a.quality
    # Blender's own cloth material (its defaults: vertex mass 0.3, tension and compression 15,
    # shear 5, bending 0.5, air damping 1), as a user would start: its stiffnesses are scaled to its
    # default vertex mass, and with raycloth's 0.05 g per vertex the same springs make a stiff plate
    # that air damping holds up (tried: the cloth had fallen 8 cm of its 30 in 0.4 s).
    c = cloth.collision_settings
    c.use_collision = True
    c.distance_min = a.distance
    c.use_self_collision = True
    c.self_distance_min = a.self_distance
    cloth.point_cache.frame_start, cloth.point_cache.frame_end = 1, frames + 1

    scene.frame_set(1)
    t0 = time.perf_counter()
    for f in range(2, frames + 2):
        scene.frame_set(f)
    wall = time.perf_counter() - t0

    depsgraph = bpy.context.evaluated_depsgraph_get()
    evaluated = cloth_obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    world = evaluated.matrix_world
    vertices = []
    for v in mesh.vertices:
        p = world @ v.co
        vertices.append([p.x, p.z, -p.y])
    triangles = []
    for poly in mesh.polygons:
        ids = list(poly.vertices)
        for k in range(1, len(ids) - 1):
            triangles.append([ids[0], ids[k], ids[k + 1]])
    result = {
        "blender": bpy.app.version_string,
        "frames": frames,
        "quality": a.quality,
        "steps": frames * a.quality,
        "wall_s": wall,
        "vertices": vertices,
        "triangles": triangles,
    }
    tmp = a.out + ".tmp"
    with open(tmp, "w") as f:
        json.dump(result, f)
    os.replace(tmp, a.out)


main()
