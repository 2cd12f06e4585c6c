#include "check/state_check.h"

#include <fmt/format.h>
#include <tiny_obj_loader.h>

#include <algorithm>
#include <map>
#include <regex>

#include "raycloth/error.h"

namespace raycloth {

namespace fs = std::filesystem;

CheckMesh cloth_check_mesh(const ClothModel& model, const std::vector<Vec3>& positions) {
  CheckMesh m;
  m.vertices = positions;
  m.triangles = model.collision_triangles;
  for (const Piece& p : model.pieces) {
    m.group_names.push_back(p.name);
    m.group_first_triangle.push_back(p.first_triangle);
  }
  return m;
}

CheckMesh obstacle_check_mesh(const ObstacleSet& obstacles, const std::vector<Vec3>& world) {
  CheckMesh m;
  m.vertices = world;
  m.triangles = obstacles.world.indices;
  m.group_names = obstacles.names;
  m.group_first_triangle = obstacles.first_triangle;
  return m;
}

void refuse_crossing_start(const ClothModel& model, const std::string& scene_file) {
  CheckReport r;
  check_cloth_crossings(cloth_check_mesh(model, model.initial_positions), r);
  if (r.crossings == 0) return;
  const CrossingRecord& c = r.first_crossings.front();
  const std::string which = c.edge_group == c.triangle_group
                                ? fmt::format("panel '{}' crosses itself", c.edge_group)
                                : fmt::format("panels '{}' and '{}' cross", c.edge_group, c.triangle_group);
  throw InputError(scene_file, "/panels",
                   fmt::format("{} in the starting state ({} cloth edges through cloth triangles); move or "
                               "rotate the panels apart",
                               which, r.crossings));
}

size_t FolderCheck::bad_frames() const {
  return size_t(std::count_if(frames.begin(), frames.end(), [](const auto& f) { return !f.report.clean(); }));
}

namespace {

// An OBJ as a CheckMesh, one group per `o`/`g` name.
CheckMesh read_obj(const fs::path& path) {
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  if (!fs::exists(path)) throw InputError(path.string(), "", "file does not exist");
  if (!reader.ParseFromFile(path.string(), config)) {
    std::string why = reader.Error();
    while (!why.empty() && (why.back() == '\n' || why.back() == '\r')) why.pop_back();
    throw InputError(path.string(), "", "malformed OBJ: " + why);
  }
  const auto& attrib = reader.GetAttrib();
  CheckMesh m;
  const size_t nv = attrib.vertices.size() / 3;
  for (size_t i = 0; i < nv; ++i)
    m.vertices.push_back(make_vec3(attrib.vertices[3 * i], attrib.vertices[3 * i + 1], attrib.vertices[3 * i + 2]));
  for (const auto& shape : reader.GetShapes()) {
    m.group_names.push_back(shape.name);
    m.group_first_triangle.push_back(uint32_t(m.num_triangles()));
    for (const auto& idx : shape.mesh.indices) {
      if (idx.vertex_index < 0 || size_t(idx.vertex_index) >= nv)
        throw InputError(path.string(), "", fmt::format("malformed OBJ: a face refers to vertex {} of {}",
                                                        idx.vertex_index + 1, nv));
      m.triangles.push_back(uint32_t(idx.vertex_index));
    }
  }
  if (m.triangles.empty()) throw InputError(path.string(), "", "malformed OBJ: it has no faces");
  for (const Vec3& v : m.vertices)
    if (!is_finite(v)) throw InputError(path.string(), "", "malformed OBJ: a vertex is not finite");
  return m;
}

}  // namespace

FolderCheck check_output_folder(const fs::path& dir, const std::function<void(const FolderFrameCheck&)>& on_frame) {
  if (!fs::is_directory(dir)) throw InputError(dir.string(), "", "not a folder");
  std::map<int, fs::path> frames;
  const std::regex name(R"(cloth_(\d+)\.obj)");
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir / "frames", ec)) {
    std::smatch m;
    const std::string file = entry.path().filename().string();
    if (std::regex_match(file, m, name)) frames[std::stoi(m[1].str())] = entry.path();
  }
  if (frames.empty())
    throw InputError(dir.string(), "frames/", "no cloth frames (frames/cloth_NNNN.obj) to check; was it run with --format obj?");
  const fs::path static_obstacles = dir / "obstacles.obj";
  const CheckMesh fixed = fs::exists(static_obstacles) ? read_obj(static_obstacles) : CheckMesh{};
  FolderCheck out;
  for (const auto& [index, path] : frames) {
    const CheckMesh cloth = read_obj(path);
    const fs::path moving = dir / "frames" / fmt::format("obstacles_{:04d}.obj", index);
    const CheckMesh obstacles = fs::exists(moving) ? read_obj(moving) : fixed;
    out.frames.push_back({index, check_state(cloth, obstacles)});
    if (on_frame) on_frame(out.frames.back());
  }
  return out;
}

}  // namespace raycloth
