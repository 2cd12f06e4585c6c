#include "io/ply_writer.h"

#include <fmt/format.h>

#include <bit>
#include <cstring>

#include "io/atomic_file.h"
#include "io/obj_writer.h"

namespace raycloth {

static_assert(std::endian::native == std::endian::little, "PLY output is written as binary_little_endian");

namespace {

// Appends the raw bytes of plain values: the host is little-endian (checked above).
template <typename T>
void append(std::string& buf, const T& v) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &v, sizeof(T));
  buf.append(bytes, sizeof(T));
}

void append_triangles(std::string& buf, const uint32_t* indices, size_t num_triangles) {
  for (size_t t = 0; t < num_triangles; ++t) {
    append(buf, uint8_t(3));
    for (int k = 0; k < 3; ++k) append(buf, int32_t(indices[3 * t + k]));
  }
}

}  // namespace

void write_cloth_ply(const std::filesystem::path& path, const ClothModel& model, const std::vector<Vec3>& x) {
  const std::vector<Vec3> n = cloth_vertex_normals(model, x);
  std::vector<uint32_t> panel(x.size(), 0);
  for (uint32_t p = 0; p < model.pieces.size(); ++p)
    for (uint32_t i = 0; i < model.pieces[p].num_vertices(); ++i) panel[model.pieces[p].first_vertex + i] = p;

  std::string buf = "ply\nformat binary_little_endian 1.0\ncomment raycloth cloth frame\n";
  for (size_t p = 0; p < model.pieces.size(); ++p) buf += fmt::format("comment panel {} {}\n", p, model.pieces[p].name);
  buf += fmt::format(
      "element vertex {}\nproperty float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty float nz\nproperty uint panel\n"
      "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
      x.size(), model.num_triangles());
  buf.reserve(buf.size() + x.size() * 28 + model.num_triangles() * 13);
  for (size_t i = 0; i < x.size(); ++i) {
    for (float f : {x[i].x, x[i].y, x[i].z, n[i].x, n[i].y, n[i].z}) append(buf, f);
    append(buf, panel[i]);
  }
  append_triangles(buf, model.triangles.data(), model.num_triangles());
  write_file_atomically(path, [&](std::ostream& out) { out.write(buf.data(), std::streamsize(buf.size())); });
}

void write_obstacles_ply(const std::filesystem::path& path, const ObstacleSet& obstacles,
                         const std::vector<Vec3>& world) {
  std::string buf = "ply\nformat binary_little_endian 1.0\ncomment raycloth obstacles in world space\n";
  for (size_t o = 0; o < obstacles.names.size(); ++o)
    buf += fmt::format("comment obstacle {} {} from vertex {}\n", o, obstacles.names[o], obstacles.first_vertex[o]);
  buf += fmt::format(
      "element vertex {}\nproperty float x\nproperty float y\nproperty float z\n"
      "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
      world.size(), obstacles.world.num_triangles());
  for (const Vec3& p : world)
    for (float f : {p.x, p.y, p.z}) append(buf, f);
  append_triangles(buf, obstacles.world.indices.data(), obstacles.world.num_triangles());
  write_file_atomically(path, [&](std::ostream& out) { out.write(buf.data(), std::streamsize(buf.size())); });
}

void PlyFrames::begin(Simulator&, const std::filesystem::path& out) { dir_ = out / "frames"; }

void PlyFrames::frame(Simulator& sim, const FrameRecord& r) {
  write_cloth_ply(dir_ / frame_name("cloth", r.index, "ply"), sim.model(), sim.positions());
  if (sim.obstacles().any_moving)
    write_obstacles_ply(dir_ / frame_name("obstacles", r.index, "ply"), sim.obstacles(), sim.obstacle_vertices());
}

}  // namespace raycloth
