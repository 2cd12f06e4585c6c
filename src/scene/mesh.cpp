#include "scene/mesh.h"

#include <tiny_obj_loader.h>

#include <cerrno>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "raycloth/error.h"

namespace raycloth {

TriMesh make_uv_sphere(float radius, int slices, int stacks) {
  TriMesh m;
  m.vertices.push_back(make_vec3(0, radius, 0));  // north pole
  for (int s = 1; s < stacks; ++s) {
    const double theta = M_PI * s / stacks;
    for (int k = 0; k < slices; ++k) {
      const double phi = 2.0 * M_PI * k / slices;
      m.vertices.push_back(make_vec3(float(radius * std::sin(theta) * std::cos(phi)),
                                     float(radius * std::cos(theta)),
                                     float(-radius * std::sin(theta) * std::sin(phi))));
    }
  }
  m.vertices.push_back(make_vec3(0, -radius, 0));  // south pole
  const uint32_t south = uint32_t(m.vertices.size() - 1);
  auto ring = [&](int s, int k) { return uint32_t(1 + (s - 1) * slices + (k % slices)); };
  auto tri = [&](uint32_t a, uint32_t b, uint32_t c) { m.indices.insert(m.indices.end(), {a, b, c}); };
  for (int k = 0; k < slices; ++k) tri(0, ring(1, k), ring(1, k + 1));
  for (int s = 1; s < stacks - 1; ++s) {
    for (int k = 0; k < slices; ++k) {
      tri(ring(s, k), ring(s + 1, k), ring(s + 1, k + 1));
      tri(ring(s, k), ring(s + 1, k + 1), ring(s, k + 1));
    }
  }
  for (int k = 0; k < slices; ++k) tri(south, ring(stacks - 1, k + 1), ring(stacks - 1, k));
  return m;
}

TriMesh make_box(Vec3 size) {
  TriMesh m;
  const Vec3 h = size * 0.5f;
  for (int i = 0; i < 8; ++i)
    m.vertices.push_back(make_vec3(i & 1 ? h.x : -h.x, i & 2 ? h.y : -h.y, i & 4 ? h.z : -h.z));
  // Faces as quads (a, b, c, d) counter-clockwise seen from outside.
  const uint32_t q[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                            {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (auto& f : q) m.indices.insert(m.indices.end(), {f[0], f[1], f[2], f[0], f[2], f[3]});
  return m;
}

TriMesh make_plane(Vec3 size) {
  TriMesh m;
  const float hx = size.x * 0.5f, hz = size.z * 0.5f;
  m.vertices = {make_vec3(-hx, 0, -hz), make_vec3(hx, 0, -hz), make_vec3(hx, 0, hz), make_vec3(-hx, 0, hz)};
  m.indices = {0, 2, 1, 0, 3, 2};
  return m;
}

namespace {

// tinyobjloader reads a coordinate it cannot parse ("nan", "abc") as 0 and one past the float range
// as infinity, without a word; every `v` line is read here first, so that the error names the line.
void check_obj_vertex_lines(const std::string& text, const std::function<void(const std::string&)>& fail) {
  std::istringstream in(text);
  std::string line;
  for (size_t number = 1; std::getline(in, line); ++number) {
    const size_t v = std::min(line.find_first_not_of(" \t"), line.size());  // tinyobjloader skips these too
    if (line.size() < v + 2 || line[v] != 'v' || (line[v + 1] != ' ' && line[v + 1] != '\t')) continue;
    std::istringstream words(line.substr(v + 2));
    std::string word;
    const std::string at = "line " + std::to_string(number) + ": ";
    for (int k = 0; k < 3; ++k) {
      if (!(words >> word)) fail(at + "a vertex needs three coordinates");
      char* end = nullptr;
      const double value = std::strtod(word.c_str(), &end);
      if (end == word.c_str() || *end != '\0') fail(at + "vertex coordinate '" + word + "' is not a number");
      if (!std::isfinite(value) || !std::isfinite(float(value)))
        fail(at + "vertex coordinate '" + word + "' is not a finite number");
    }
  }
}

// `vw` lines (tinyobjloader's skin weights) are never used, and their parser converts a joint number
// of any size to int (undefined past INT_MAX): they are blanked, keeping the line numbers.
std::string without_skin_weight_lines(const std::string& text) {
  std::string out = text;
  for (size_t at = 0; at < out.size();) {
    const size_t end = std::min(out.find('\n', at), out.size());
    size_t p = at;
    while (p < end && (out[p] == ' ' || out[p] == '\t')) ++p;
    if (end - p >= 3 && out[p] == 'v' && out[p + 1] == 'w' && (out[p + 2] == ' ' || out[p + 2] == '\t'))
      out.replace(at, end - at, end - at, ' ');
    at = end + 1;
  }
  return out;
}

// Lines end as tinyobjloader ends them: "\n", "\r\n" or a lone "\r". Made "\n" everywhere, so that the
// checks here see the lines tinyobjloader reads (and number them as it does).
std::string with_newline_ends(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '\r') {
      out += text[i];
    } else {
      out += '\n';
      if (i + 1 < text.size() && text[i + 1] == '\n') ++i;
    }
  }
  return out;
}

}  // namespace

ObjTriangles parse_obj_triangles(const std::string& raw_text, const std::function<void(const std::string&)>& fail) {
  const std::string text = without_skin_weight_lines(with_newline_ends(raw_text));
  check_obj_vertex_lines(text, fail);
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  // No material text: `mtllib` names no file that would be opened (materials are not used).
  if (!reader.ParseFromString(text, "", config)) {
    std::string why = reader.Error();
    while (!why.empty() && (why.back() == '\n' || why.back() == '\r')) why.pop_back();
    fail("is malformed: " + why);
  }
  const auto& attrib = reader.GetAttrib();
  ObjTriangles m;
  const size_t nv = attrib.vertices.size() / 3;
  m.vertices.reserve(nv);
  for (size_t i = 0; i < nv; ++i)
    m.vertices.push_back(make_vec3(attrib.vertices[3 * i], attrib.vertices[3 * i + 1], attrib.vertices[3 * i + 2]));
  for (const auto& shape : reader.GetShapes()) {
    m.group_names.push_back(shape.name);
    m.group_first_triangle.push_back(uint32_t(m.indices.size() / 3));
    for (const auto& idx : shape.mesh.indices) {
      if (idx.vertex_index < 0 || size_t(idx.vertex_index) >= nv)
        fail("is malformed: face refers to vertex " + std::to_string(idx.vertex_index + 1) + " of " +
             std::to_string(nv));
      m.indices.push_back(uint32_t(idx.vertex_index));
    }
  }
  return m;
}

std::string input_file_problem(const std::string& path) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (status.type() == std::filesystem::file_type::not_found) return "does not exist";
  if (ec) return "cannot be read: " + ec.message();
  if (!std::filesystem::is_regular_file(status)) return "is not a regular file";
  return "";
}

ObjTriangles read_obj_triangles(const std::string& path, const std::function<void(const std::string&)>& fail) {
  if (const std::string problem = input_file_problem(path); !problem.empty()) fail(problem);
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  if (!in || in.bad()) fail(std::string("cannot be read: ") + std::strerror(errno));
  return parse_obj_triangles(text.str(), fail);
}

TriMesh load_obj_mesh(const std::string& path, const std::string& scene_file, const std::string& field) {
  const auto fail = [&](const std::string& reason) {
    throw InputError(scene_file, field, "OBJ file '" + path + "' " + reason);
  };
  ObjTriangles obj = read_obj_triangles(path, fail);
  if (obj.indices.empty()) fail("is malformed: it has no faces");
  TriMesh m;
  m.vertices = std::move(obj.vertices);
  m.indices = std::move(obj.indices);
  return m;
}

}  // namespace raycloth
