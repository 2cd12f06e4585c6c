// The scene reader, shared by the files that implement it: SceneReader turns the JSON of a scene
// file into a SceneDef section by section (scene_json.cpp: the scene and its own sections;
// scene_json_cloth.cpp: the cloth's), with the names of a rectangle's edges and corners and the
// size limit, which the checks (scene_validate.cpp) use too.
#pragma once
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "raycloth/scene.h"
#include "scene/json_fields.h"

namespace raycloth::scene_json {

// The most cloth vertices (all panels) and UV-sphere vertices a scene may ask for.
inline constexpr int64_t kMaxVertices = int64_t(1) << 22;

inline constexpr std::string_view kEdges[] = {"left", "right", "bottom", "top"};
inline constexpr std::string_view kCorners[] = {"bottom_left", "bottom_right", "top_left", "top_right"};

inline bool is_edge(const std::string& e) {
  for (auto k : kEdges)
    if (e == k) return true;
  return false;
}

inline bool is_corner(const std::string& c) {
  for (auto k : kCorners)
    if (c == k) return true;
  return false;
}

inline std::string bad_edge(const std::string& e) {
  return "unknown edge '" + e + "' (expected left, right, bottom or top)";
}
inline std::string bad_corner(const std::string& c) {
  return "unknown corner '" + c + "' (expected bottom_left, bottom_right, top_left or top_right)";
}

// Reads JSON values into defs; `file` names the scene in errors, `dir` resolves the paths of the
// files it names (meshes, glTF bodies, GarmentCode patterns).
class SceneReader : public JsonFields {
 public:
  SceneReader(std::string file, std::filesystem::path dir);
  SceneDef scene(const json& j) const;

 private:
  // A file named by the scene, relative to the scene's folder.
  std::string file_path(const json& j, const std::string& ptr) const;

  // scene_json.cpp
  TimeDef time(const json& j, const std::string& ptr) const;
  CollisionDef collision(const json& j, const std::string& ptr) const;
  OutputDef output(const json& j, const std::string& ptr) const;
  CameraDef camera(const json& j, const std::string& ptr) const;
  MaterialDef material(const json& j, const std::string& ptr) const;
  void transform(const json& j, const std::string& ptr, TransformDef& t) const;
  ObstacleType obstacle_type(const json& j, const std::string& ptr) const;
  MotionDef motion(const json& j, const std::string& ptr) const;
  ObstacleDef obstacle(const json& j, const std::string& ptr, size_t index) const;

  // scene_json_cloth.cpp
  PanelDef panel(const json& j, const std::string& ptr) const;
  PatternDef pattern_def(const json& j, const std::string& ptr) const;
  void garment(const json& j, const std::string& ptr, SceneDef& s) const;
  void path_fields(const json& j, const std::string& ptr, EdgeRef& e, std::optional<std::array<int, 2>>* range) const;
  EdgeRef edge_ref(const json& j, const std::string& ptr) const;
  SeamDef seam(const json& j, const std::string& ptr) const;
  PinDef pin(const json& j, const std::string& ptr) const;
  AttachmentDef attachment(const json& j, const std::string& ptr) const;

  std::filesystem::path dir_;
};

}  // namespace raycloth::scene_json
