#include "check/folder_check.h"

#include "scene/mesh.h"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>

#include "raycloth/error.h"
#include "raycloth/scene.h"

namespace raycloth {

namespace fs = std::filesystem;

size_t FolderCheck::bad_frames() const {
  return size_t(std::count_if(frames.begin(), frames.end(), [](const auto& f) { return f.report.failed(); }));
}

size_t FolderCheck::pinched_frames() const {
  return size_t(std::count_if(frames.begin(), frames.end(), [](const auto& f) { return f.report.pinched_only(); }));
}

namespace {

// An OBJ as a CheckMesh, one group per `o`/`g` name.
CheckMesh read_obj(const fs::path& path) {
  ObjTriangles obj = read_obj_triangles(path.string(), [&](const std::string& reason) {
    throw InputError(path.string(), "", reason);
  });
  if (obj.indices.empty()) throw InputError(path.string(), "", "is malformed: it has no faces");
  CheckMesh m;
  m.vertices = std::move(obj.vertices);
  m.triangles = std::move(obj.indices);
  m.group_names = std::move(obj.group_names);
  m.group_first_triangle = std::move(obj.group_first_triangle);
  return m;
}

// The cloth thickness of the run that wrote `dir`: run.json's /thickness.
double run_thickness(const fs::path& dir) {
  const fs::path file = dir / "run.json";
  const std::string where = file.string(), field = "/thickness";
  const std::string why = "`raycloth check` needs the run's cloth thickness (which `raycloth run` writes there) to tell "
                          "cloth pinched by the body from penetration";
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError(where, field, "cannot be read (" + std::string(std::strerror(errno)) + "); " + why);
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw InputError(where, "", "is not a JSON object; " + why);
  if (!j.contains("thickness")) throw InputError(where, field, "missing; " + why + ": run the scene again");
  const nlohmann::json& t = j["thickness"];
  if (!t.is_number() || !(t.get<double>() >= 0) || !std::isfinite(t.get<double>()))
    throw InputError(where, field, "must be a non-negative number of metres (got " + t.dump() + ")");
  return t.get<double>();
}

}  // namespace

FolderCheck check_output_folder(const fs::path& dir, const std::function<void(const FolderFrameCheck&)>& on_frame) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError(dir.string(), "", "not a folder");
  std::map<int, fs::path> frames;
  const std::regex name(R"(cloth_(\d+)\.obj)");
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
  bool any_obstacles = fixed.num_triangles() > 0;
  for (const auto& [index, path] : frames)
    any_obstacles = any_obstacles || fs::exists(dir / "frames" / fmt::format("obstacles_{:04d}.obj", index));
  if (any_obstacles) out.thickness = run_thickness(dir);
  for (const auto& [index, path] : frames) {
    const CheckMesh cloth = read_obj(path);
    const fs::path moving = dir / "frames" / fmt::format("obstacles_{:04d}.obj", index);
    const CheckMesh obstacles = fs::exists(moving) ? read_obj(moving) : fixed;
    out.frames.push_back({index, check_state(cloth, obstacles, out.thickness)});
    if (on_frame) on_frame(out.frames.back());
  }
  return out;
}

}  // namespace raycloth
