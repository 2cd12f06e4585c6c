// Triangle meshes for obstacles: generators (UV sphere, box, plane) and the OBJ reader.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "raycloth/vec3.h"

namespace raycloth {

struct TriMesh {
  std::vector<Vec3> vertices;
  std::vector<uint32_t> indices;  // 3 per triangle, counter-clockwise seen from outside
  size_t num_triangles() const { return indices.size() / 3; }
};

// slices around the axis, stacks from pole to pole: 2 + slices * (stacks - 1) vertices and
// 2 * slices * (stacks - 1) triangles (24 x 25 gives the paper's 578 and 1152).
TriMesh make_uv_sphere(float radius, int slices, int stacks);
TriMesh make_box(Vec3 size);
// A square in the y = 0 plane, normal +y, size.x by size.z.
TriMesh make_plane(Vec3 size);
// An OBJ file's faces, triangulated, and its `o`/`g` groups.
struct ObjTriangles {
  std::vector<Vec3> vertices;
  std::vector<uint32_t> indices;  // 3 per triangle
  std::vector<std::string> group_names;
  std::vector<uint32_t> group_first_triangle;
};
// What keeps `path` from being read as an input file: "" when it is a regular file, else "does not
// exist", "is not a regular file" (a device or a pipe would be read forever) or "cannot be read:
// REASON" (a name too long, a folder that cannot be searched). Never throws.
std::string input_file_problem(const std::string& path);

// The one OBJ reader (scene obstacles, `raycloth check`, `raycloth render`): tinyobjloader, with
// every `v` line checked first. On a missing or malformed file it calls fail(reason), which must
// throw; reason is "does not exist", "is malformed: ..." or "line N: ...".
ObjTriangles read_obj_triangles(const std::string& path, const std::function<void(const std::string&)>& fail);
// The same on OBJ text already in memory (materials are never read).
ObjTriangles parse_obj_triangles(const std::string& text, const std::function<void(const std::string&)>& fail);
// Reads an OBJ obstacle; throws InputError(file, field, "OBJ file 'PATH' " + reason).
TriMesh load_obj_mesh(const std::string& path, const std::string& scene_file, const std::string& field);

}  // namespace raycloth
