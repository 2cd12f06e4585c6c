#include "io/viewer.h"

#include <fmt/format.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "check/folder_check.h"
#include "io/atomic_file.h"
#include "raycloth/error.h"
#include "scene/mesh.h"

namespace tinygltf {
// The base64 encoder of tinygltf (compiled in io/gltf_writer.cpp with TINYGLTF_IMPLEMENTATION).
std::string base64_encode(unsigned char const* bytes, unsigned int len);
}  // namespace tinygltf

namespace raycloth {
namespace embedded {
std::string_view viewer_0();  // src/io/viewer.html
std::string_view viewer_1();  // third_party/three/three.module.min.js
std::string_view viewer_2();  // third_party/three/OrbitControls.js
}  // namespace embedded

namespace {

namespace fs = std::filesystem;

std::string b64(const void* data, size_t bytes) {
  return tinygltf::base64_encode(static_cast<const unsigned char*>(data), static_cast<unsigned int>(bytes));
}
std::string b64(std::string_view text) { return b64(text.data(), text.size()); }

// frames/PREFIX_NNNN.obj by frame number.
std::map<int, fs::path> numbered(const fs::path& frames, const std::string& prefix) {
  std::map<int, fs::path> out;
  if (!fs::is_directory(frames)) return out;
  const std::regex name(prefix + "_([0-9]+)\\.obj");
  for (const auto& e : fs::directory_iterator(frames)) {
    std::smatch m;
    const std::string file = e.path().filename().string();
    if (std::regex_match(file, m, name)) out[std::stoi(m[1].str())] = e.path();
  }
  return out;
}

ObjTriangles read(const fs::path& path) {
  return read_obj_triangles(path.string(), [&](const std::string& reason) { throw InputError(path.string(), "", reason); });
}

nlohmann::json read_json(const fs::path& path) {
  std::ifstream in(path);
  try {
    return nlohmann::json::parse(in, nullptr, true, true);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path.string(), "", fmt::format("is not valid JSON: {}", e.what()));
  }
}

// One mesh over frames: the first frame's triangles, every frame's positions (float32, base64).
nlohmann::json mesh_frames(const std::vector<fs::path>& files, size_t* vertices) {
  nlohmann::json frames = nlohmann::json::array();
  ObjTriangles first;
  for (size_t k = 0; k < files.size(); ++k) {
    ObjTriangles m = read(files[k]);
    if (k == 0) {
      first = m;
    } else if (m.vertices.size() != first.vertices.size()) {
      throw InputError(files[k].string(), "",
                       fmt::format("has {} vertices where {} has {}", m.vertices.size(),
                                   files[0].filename().string(), first.vertices.size()));
    }
    std::vector<float> xyz;
    xyz.reserve(3 * m.vertices.size());
    for (const Vec3& v : m.vertices) xyz.insert(xyz.end(), {v.x, v.y, v.z});
    frames.push_back(b64(xyz.data(), xyz.size() * sizeof(float)));
  }
  if (vertices) *vertices = first.vertices.size();
  return {{"triangles", b64(first.indices.data(), first.indices.size() * sizeof(uint32_t))}, {"frames", frames}};
}

}  // namespace

ViewSummary write_view(const fs::path& dir, bool check) {
  if (!fs::is_directory(dir)) throw InputError(dir.string(), "", "is not a folder (an output folder of `raycloth run`)");
  const std::map<int, fs::path> cloth = numbered(dir / "frames", "cloth");
  if (cloth.empty())
    throw InputError(dir.string(), "frames",
                     "no frames/cloth_NNNN.obj: `raycloth view` plays the OBJ frames of `raycloth run` (its default "
                     "output, --format obj)");
  ViewSummary summary;
  nlohmann::json data;
  data["name"] = dir.filename().string();
  data["fps"] = 30.0;
  std::vector<fs::path> cloth_files;
  std::vector<int> numbers;
  for (const auto& [k, p] : cloth) cloth_files.push_back(p), numbers.push_back(k);
  for (size_t k = 0; k < numbers.size(); ++k)
    if (numbers[k] != int(k))
      throw InputError((dir / "frames").string(), "", fmt::format("frame {:04d} is missing (frames must run from 0000 on)", k));
  data["cloth"] = mesh_frames(cloth_files, &summary.cloth_vertices);
  summary.frames = cloth_files.size();

  // The bodies: per frame where they move, else the one obstacles.obj.
  const std::map<int, fs::path> moving = numbered(dir / "frames", "obstacles");
  if (!moving.empty()) {
    std::vector<fs::path> files;
    for (const auto& [k, p] : moving) files.push_back(p);
    data["obstacles"] = mesh_frames(files, nullptr);
  } else if (fs::exists(dir / "obstacles.obj")) {
    data["obstacles"] = mesh_frames({dir / "obstacles.obj"}, nullptr);
  }

  // The run's figures and camera.
  nlohmann::json figures = {{"vertices", summary.cloth_vertices}};
  if (fs::exists(dir / "run.json")) {
    const nlohmann::json run = read_json(dir / "run.json");
    if (run.contains("scene") && run["scene"].is_string()) data["name"] = run["scene"];
    if (run.contains("fps") && run["fps"].is_number() && run["fps"].get<double>() > 0) data["fps"] = run["fps"];
    if (run.contains("camera")) data["camera"] = run["camera"];
    for (const char* key : {"dt", "device", "steps", "vertices"})
      if (run.contains(key)) figures[key] = run[key];
  }
  if (fs::exists(dir / "timing.json")) {
    const nlohmann::json timing = read_json(dir / "timing.json");
    if (timing.contains("steps_per_second")) figures["steps_per_second"] = timing["steps_per_second"];
  }
  data["figures"] = figures;

  // The exact check of every frame: its status, its bad vertices (those of the first crossings and
  // of the first vertices inside that the check records) and its one-line description.
  if (check) {
    const FolderCheck c = check_output_folder(dir);
    nlohmann::json frames = nlohmann::json::array();
    for (const FolderFrameCheck& f : c.frames) {
      const CheckReport& r = f.report;
      std::vector<uint32_t> bad;
      for (const auto& x : r.first_crossings) bad.insert(bad.end(), {x.edge_a, x.edge_b});
      for (const auto& v : r.first_inside) bad.push_back(v.vertex);
      const char* status = r.failed() ? "failed" : (r.pinched_only() ? "pinched" : "clean");
      frames.push_back({{"frame", f.frame}, {"status", status}, {"bad", bad}, {"text", describe(r)}});
    }
    summary.bad_frames = c.bad_frames();
    summary.checked = true;
    data["check"] = {{"frames", frames},
                     {"summary", c.bad_frames() == 0 ? fmt::format("clean on all {} frames", c.frames.size())
                                                      : fmt::format("{} of {} frames failed", c.bad_frames(), c.frames.size())}};
  }

  // The page: the template with three.js, OrbitControls and the data put in. "</" in the JSON
  // becomes "<\/" (the same string to JSON) so that no text can close the script element early.
  std::string json = data.dump();
  for (size_t at = json.find("</"); at != std::string::npos; at = json.find("</", at + 3)) json.replace(at, 2, "<\\/");
  std::string page(embedded::viewer_0());
  auto put = [&](const std::string& marker, const std::string& text) {
    const size_t at = page.find(marker);
    if (at == std::string::npos) throw std::logic_error("viewer.html lost its marker " + marker);
    page.replace(at, marker.size(), text);
  };
  put("/*RAYCLOTH_THREE*/", b64(embedded::viewer_1()));
  put("/*RAYCLOTH_ORBIT*/", b64(embedded::viewer_2()));
  put("/*RAYCLOTH_DATA*/", json);
  summary.page = dir / "view.html";
  summary.bytes = page.size();
  write_file_atomically(summary.page, [&](std::ostream& out) { out << page; });
  return summary;
}

}  // namespace raycloth
