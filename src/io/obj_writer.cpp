#include "io/obj_writer.h"

#include <fmt/format.h>
#include <fmt/os.h>

#include "io/atomic_file.h"

namespace raycloth {

std::vector<Vec3> cloth_vertex_normals(const ClothModel& model, const std::vector<Vec3>& x) {
  // Over the welded triangles, so that a seam is smooth; seam followers take their
  // representative's normal.
  std::vector<Vec3> n(x.size(), make_vec3(0, 0, 0));
  const std::vector<uint32_t>& tri = model.collision_triangles;
  for (size_t t = 0; t < tri.size(); t += 3) {
    const uint32_t a = tri[t], b = tri[t + 1], c = tri[t + 2];
    const Vec3 fn = cross(x[b] - x[a], x[c] - x[a]);
    n[a] += fn;
    n[b] += fn;
    n[c] += fn;
  }
  for (auto& v : n) v = normalize_or_zero(v);
  for (size_t i = 0; i < n.size(); ++i) n[i] = n[model.alias[i]];
  return n;
}

namespace {
void put(std::ostream& out, const std::string& s) { out.write(s.data(), std::streamsize(s.size())); }
}  // namespace

void write_cloth_obj(const std::filesystem::path& path, const ClothModel& model, const std::vector<Vec3>& x) {
  const std::vector<Vec3> n = cloth_vertex_normals(model, x);
  // Seam partners are one simulated vertex (model.alias): written once, so that the file shows the
  // sewn surface and `raycloth check` sees the triangles on either side of a seam as neighbours.
  std::vector<uint32_t> index(x.size(), 0);
  uint32_t written = 0;
  for (uint32_t i = 0; i < x.size(); ++i)
    if (model.alias[i] == i) index[i] = ++written;
  write_file_atomically(path, [&](std::ostream& out) {
    fmt::memory_buffer buf;
    fmt::format_to(std::back_inserter(buf), "# raycloth cloth frame: {} vertices, {} triangles\n", written,
                   model.num_triangles());
    // 12 significant digits: every float reads back as itself, so a check of this file sees
    // exactly the simulated state.
    for (uint32_t i = 0; i < x.size(); ++i)
      if (model.alias[i] == i) fmt::format_to(std::back_inserter(buf), "v {:.12g} {:.12g} {:.12g}\n", x[i].x, x[i].y, x[i].z);
    for (uint32_t i = 0; i < x.size(); ++i)
      if (model.alias[i] == i) fmt::format_to(std::back_inserter(buf), "vn {:.5f} {:.5f} {:.5f}\n", n[i].x, n[i].y, n[i].z);
    for (const Piece& piece : model.pieces) {
      fmt::format_to(std::back_inserter(buf), "o {}\n", piece.name);
      for (uint32_t t = piece.first_triangle; t < piece.first_triangle + piece.num_triangles; ++t) {
        const uint32_t a = index[model.alias[model.triangles[3 * t]]], b = index[model.alias[model.triangles[3 * t + 1]]],
                       c = index[model.alias[model.triangles[3 * t + 2]]];
        fmt::format_to(std::back_inserter(buf), "f {}//{} {}//{} {}//{}\n", a, a, b, b, c, c);
      }
    }
    put(out, fmt::to_string(buf));
  });
}

void write_obstacles_obj(const std::filesystem::path& path, const ObstacleSet& obstacles,
                         const std::vector<Vec3>& world) {
  write_file_atomically(path, [&](std::ostream& out) {
    fmt::memory_buffer buf;
    fmt::format_to(std::back_inserter(buf), "# raycloth obstacles in world space\n");
    for (const Vec3& p : world) fmt::format_to(std::back_inserter(buf), "v {:.12g} {:.12g} {:.12g}\n", p.x, p.y, p.z);
    for (size_t o = 0; o < obstacles.names.size(); ++o) {
      fmt::format_to(std::back_inserter(buf), "o {}\n", obstacles.names[o]);
      const size_t first = obstacles.first_triangle[o];
      const size_t last = o + 1 < obstacles.names.size() ? obstacles.first_triangle[o + 1]
                                                         : obstacles.world.num_triangles();
      for (size_t t = first; t < last; ++t)
        fmt::format_to(std::back_inserter(buf), "f {} {} {}\n", obstacles.world.indices[3 * t] + 1,
                       obstacles.world.indices[3 * t + 1] + 1, obstacles.world.indices[3 * t + 2] + 1);
    }
    put(out, fmt::to_string(buf));
  });
}

void ObjFrames::begin(Simulator&, const std::filesystem::path& out) { dir_ = out / "frames"; }

void ObjFrames::frame(Simulator& sim, const FrameRecord& r) {
  write_cloth_obj(dir_ / frame_name("cloth", r.index, "obj"), sim.model(), sim.positions());
  if (sim.obstacles().any_moving)
    write_obstacles_obj(dir_ / frame_name("obstacles", r.index, "obj"), sim.obstacles(), sim.obstacle_vertices());
}

}  // namespace raycloth
