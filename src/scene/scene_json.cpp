// Scene files: JSON (comments allowed) into SceneDef. This file reads the file and the scene's own
// sections (time, collision, materials, sewing, output, obstacles); scene_json_cloth.cpp reads the
// cloth's (panels, patterns, garments, seams, pins, attachments) and scene_validate.cpp holds the
// checks every scene goes through. Parsing checks shapes and types and rejects unknown fields;
// validate_scene checks values and cross references, so that scenes built in code get the same
// checks as scenes read from files. Every error is an InputError naming the file, the JSON pointer
// of the field and the reason (docs/scenes.md lists the schema).
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <sstream>
#include <vector>

#include "fabric/kes.h"
#include "fabric/measured.h"
#include "raycloth/error.h"
#include "raycloth/scene.h"
#include "scene/json_text.h"
#include "scene/scene_reader.h"

namespace raycloth {

namespace scene_json {

SceneReader::SceneReader(std::string file, std::filesystem::path dir) : JsonFields(std::move(file)), dir_(std::move(dir)) {}

std::string SceneReader::file_path(const json& j, const std::string& ptr) const {
  const std::filesystem::path f = string(j, ptr);
  return (f.is_absolute() || dir_.empty() ? f : dir_ / f).lexically_normal().string();
}

SceneDef SceneReader::scene(const json& j) const {
  SceneDef s;
  s.source = file();
  object(j, "", {"name", "time", "gravity", "collision", "materials", "panels", "garments", "seams", "pins", "sewing",
                 "attachments", "obstacles", "output"});
  optional(j, "", "name", [&](const json& v, const std::string& p) { s.name = string(v, p); });
  optional(j, "", "time", [&](const json& v, const std::string& p) { s.time = time(v, p); });
  optional(j, "", "gravity", [&](const json& v, const std::string& p) { s.gravity = float3(v, p); });
  optional(j, "", "collision", [&](const json& v, const std::string& p) { s.collision = collision(v, p); });
  list(j, "", "materials", false, [&](const json& v, const std::string& p, size_t) { s.materials.push_back(material(v, p)); });
  list(j, "", "panels", !j.contains("garments"),
       [&](const json& v, const std::string& p, size_t) { s.panels.push_back(panel(v, p)); });
  list(j, "", "seams", false, [&](const json& v, const std::string& p, size_t) { s.seams.push_back(seam(v, p)); });
  // After the file's own panels and seams, so that their indices in messages stay the file's.
  list(j, "", "garments", false, [&](const json& v, const std::string& p, size_t) { garment(v, p, s); });
  list(j, "", "pins", false, [&](const json& v, const std::string& p, size_t) { s.pins.push_back(pin(v, p)); });
  optional(j, "", "sewing", [&](const json& v, const std::string& p) {
    object(v, p, {"close_time", "weld_at_start", "close_tolerance", "ease_gravity", "gravity_waits"});
    optional(v, p, "ease_gravity", [&](const json& w, const std::string& q) { s.sewing.ease_gravity = boolean(w, q); });
    optional(v, p, "gravity_waits", [&](const json& w, const std::string& q) { s.sewing.gravity_waits = boolean(w, q); });
    optional(v, p, "close_time", [&](const json& w, const std::string& q) { s.sewing.close_time = number(w, q); });
    optional(v, p, "weld_at_start", [&](const json& w, const std::string& q) { s.sewing.weld_at_start = boolean(w, q); });
    optional(v, p, "close_tolerance",
             [&](const json& w, const std::string& q) { s.sewing.close_tolerance = number_f(w, q); });
  });
  list(j, "", "attachments", false,
       [&](const json& v, const std::string& p, size_t) { s.attachments.push_back(attachment(v, p)); });
  list(j, "", "obstacles", false,
       [&](const json& v, const std::string& p, size_t i) { s.obstacles.push_back(obstacle(v, p, i)); });
  optional(j, "", "output", [&](const json& v, const std::string& p) { s.output = output(v, p); });
  return s;
}

TimeDef SceneReader::time(const json& j, const std::string& ptr) const {
  TimeDef t;
  object(j, ptr, {"dt", "max_dt", "duration", "fps", "integrator", "iterations", "tolerance"});
  optional(j, ptr, "integrator", [&](const json& v, const std::string& p) {
    const std::string name = string(v, p);
    if (name == "explicit") t.integrator = Integrator::Explicit;
    else if (name == "implicit") t.integrator = Integrator::Implicit;
    else fail(p, "unknown integrator '" + name + "' (expected 'explicit' or 'implicit')");
  });
  if (t.integrator == Integrator::Explicit)
    for (const char* key : {"iterations", "tolerance"})
      if (j.contains(key)) fail(ptr + "/" + key, std::string("field '") + key + "' applies to the implicit integrator only");
  optional(j, ptr, "iterations", [&](const json& v, const std::string& p) { t.iterations = integer(v, p); });
  optional(j, ptr, "tolerance", [&](const json& v, const std::string& p) { t.tolerance = number(v, p); });
  optional(j, ptr, "dt", [&](const json& v, const std::string& p) { t.dt = number(v, p); });
  t.dt_given = j.contains("dt");
  if (t.dt_given && j.contains("max_dt")) fail(ptr + "/max_dt", "give dt or max_dt, not both (max_dt lets the mesh choose a smaller step)");
  optional(j, ptr, "max_dt", [&](const json& v, const std::string& p) {
    t.dt = t.max_dt = number(v, p);
    if (!(t.max_dt > 0)) fail(p, "must be positive (got " + num(t.max_dt) + ")");
  });
  optional(j, ptr, "duration", [&](const json& v, const std::string& p) { t.duration = number(v, p); });
  optional(j, ptr, "fps", [&](const json& v, const std::string& p) { t.fps = number(v, p); });
  return t;
}

CollisionDef SceneReader::collision(const json& j, const std::string& ptr) const {
  CollisionDef c;
  object(j, ptr, {"tolerance", "thickness", "friction", "cloth_cloth"});
  optional(j, ptr, "tolerance", [&](const json& v, const std::string& p) { c.tolerance = number_f(v, p); });
  optional(j, ptr, "thickness", [&](const json& v, const std::string& p) { c.thickness = number_f(v, p); });
  optional(j, ptr, "friction", [&](const json& v, const std::string& p) { c.friction = number_f(v, p); });
  optional(j, ptr, "cloth_cloth", [&](const json& v, const std::string& p) { c.cloth_cloth = boolean(v, p); });
  return c;
}

OutputDef SceneReader::output(const json& j, const std::string& ptr) const {
  OutputDef o;
  object(j, ptr, {"formats", "render", "video", "camera"});
  optional(j, ptr, "formats", [&](const json& v, const std::string& p) {
    if (!v.is_array()) fail(p, std::string("expected an array of format names, got ") + v.type_name());
    o.formats.clear();
    for (size_t i = 0; i < v.size(); ++i) o.formats.push_back(string(v[i], p + "/" + std::to_string(i)));
  });
  optional(j, ptr, "render", [&](const json& v, const std::string& p) { o.render = boolean(v, p); });
  optional(j, ptr, "video", [&](const json& v, const std::string& p) { o.video = boolean(v, p); });
  optional(j, ptr, "camera", [&](const json& v, const std::string& p) { o.camera = camera(v, p); });
  return o;
}

CameraDef SceneReader::camera(const json& j, const std::string& ptr) const {
  CameraDef c;
  object(j, ptr, {"position", "target", "fov", "resolution", "samples"});
  optional(j, ptr, "position", [&](const json& v, const std::string& p) { c.position = float3(v, p); });
  optional(j, ptr, "target", [&](const json& v, const std::string& p) { c.target = float3(v, p); });
  optional(j, ptr, "fov", [&](const json& v, const std::string& p) { c.fov = number_f(v, p); });
  optional(j, ptr, "resolution", [&](const json& v, const std::string& p) {
    const auto r = int2(v, p);
    c.width = r[0];
    c.height = r[1];
  });
  optional(j, ptr, "samples", [&](const json& v, const std::string& p) { c.samples = integer(v, p); });
  return c;
}

MaterialDef SceneReader::material(const json& j, const std::string& ptr) const {
  MaterialDef m;
  object(j, ptr, {"name", "fabric", "kes", "density", "stretch", "shear", "bend", "damping", "spring_damping",
                  "bending"});
  required(j, ptr, "name", [&](const json& v, const std::string& p) { m.name = string(v, p); });
  // A fabric: a named preset, measurements ("kes"), or a preset with some measurements replaced.
  optional(j, ptr, "fabric", [&](const json& v, const std::string& p) {
    const std::string name = string(v, p);
    const fabric::Preset* preset = fabric::find_preset(name);
    if (!preset && fabric::find_measured(name)) {
      m.measured = name;
      return;
    }
    if (!preset)
      fail(p, "unknown fabric '" + name + "' (expected a KES-F preset, " + fabric::preset_names() +
                  ", or a measured fabric, " + fabric::measured_names() + ")");
    m.fabric = FabricDef{name, preset->W, preset->B, preset->G, preset->EMT};
  });
  optional(j, ptr, "kes", [&](const json& v, const std::string& p) {
    if (!m.measured.empty()) fail(p, "the measured fabric '" + m.measured + "' takes no KES-F measurements");
    object(v, p, {"W", "B", "G", "EMT"});
    if (!m.fabric)
      for (const char* key : {"W", "B", "G", "EMT"})
        if (!v.contains(key)) fail(p + "/" + key, "missing required field (no 'fabric' preset gives it)");
    FabricDef f = m.fabric.value_or(FabricDef{});
    optional(v, p, "W", [&](const json& w, const std::string& q) { f.W = number(w, q); });
    optional(v, p, "B", [&](const json& w, const std::string& q) { f.B = number(w, q); });
    optional(v, p, "G", [&](const json& w, const std::string& q) { f.G = number(w, q); });
    optional(v, p, "EMT", [&](const json& w, const std::string& q) { f.EMT = number(w, q); });
    m.fabric = f;
  });
  optional(j, ptr, "density", [&](const json& v, const std::string& p) { m.density = number_f(v, p), m.density_set = true; });
  optional(j, ptr, "stretch", [&](const json& v, const std::string& p) { m.stretch = number_f(v, p), m.stretch_set = true; });
  optional(j, ptr, "shear", [&](const json& v, const std::string& p) { m.shear = number_f(v, p), m.shear_set = true; });
  optional(j, ptr, "bend", [&](const json& v, const std::string& p) { m.bend = number_f(v, p), m.bend_set = true; });
  optional(j, ptr, "damping", [&](const json& v, const std::string& p) { m.damping = number_f(v, p); });
  optional(j, ptr, "spring_damping",
           [&](const json& v, const std::string& p) { m.spring_damping = number_f(v, p); });
  optional(j, ptr, "bending", [&](const json& v, const std::string& p) {
    const std::string b = string(v, p);
    if (b == "springs") m.bending = MaterialDef::Bending::Springs;
    else if (b == "hinges") m.bending = MaterialDef::Bending::Hinges;
    else fail(p, "unknown bending '" + b + "' (expected \"springs\" or \"hinges\")");
  });
  return m;
}

void SceneReader::transform(const json& j, const std::string& ptr, TransformDef& t) const {
  optional(j, ptr, "position", [&](const json& v, const std::string& p) { t.position = float3(v, p); });
  optional(j, ptr, "rotation", [&](const json& v, const std::string& p) { t.rotation = float3(v, p); });
  optional(j, ptr, "scale", [&](const json& v, const std::string& p) { t.scale = float3(v, p); });
}

ObstacleType SceneReader::obstacle_type(const json& j, const std::string& ptr) const {
  const std::string t = string(j, ptr);
  if (t == "uv_sphere") return ObstacleType::UvSphere;
  if (t == "box") return ObstacleType::Box;
  if (t == "plane") return ObstacleType::Plane;
  if (t == "mesh") return ObstacleType::Mesh;
  if (t == "skinned") return ObstacleType::Skinned;
  fail(ptr, "unknown obstacle type '" + t + "' (expected uv_sphere, box, plane, mesh or skinned)");
}

MotionDef SceneReader::motion(const json& j, const std::string& ptr) const {
  MotionDef m;
  object(j, ptr, {"velocity", "angular_velocity", "start"});
  optional(j, ptr, "velocity", [&](const json& v, const std::string& p) { m.velocity = float3(v, p); });
  optional(j, ptr, "angular_velocity",
           [&](const json& v, const std::string& p) { m.angular_velocity = float3(v, p); });
  optional(j, ptr, "start", [&](const json& v, const std::string& p) { m.start = number(v, p); });
  return m;
}

ObstacleDef SceneReader::obstacle(const json& j, const std::string& ptr, size_t index) const {
  ObstacleDef od;
  od.name = "obstacle" + std::to_string(index);
  object(j, ptr, {"name", "type", "radius", "slices", "stacks", "size", "file", "position", "rotation", "scale",
                  "motion", "animation", "speed", "loop", "offset", "blend_in", "hold", "close_holes", "front"});
  std::string type_name;
  required(j, ptr, "type", [&](const json& v, const std::string& p) {
    od.type = obstacle_type(v, p);
    type_name = v.get<std::string>();
  });
  // Shape fields that the type does not use are errors too: "radius" on a box is a mistake.
  auto only_for = [&](const char* key, std::initializer_list<ObstacleType> types) {
    if (!j.contains(key)) return;
    for (ObstacleType t : types)
      if (od.type == t) return;
    fail(ptr + "/" + key, std::string("field '") + key + "' does not apply to obstacle type '" + type_name + "'");
  };
  only_for("radius", {ObstacleType::UvSphere});
  only_for("slices", {ObstacleType::UvSphere});
  only_for("stacks", {ObstacleType::UvSphere});
  only_for("size", {ObstacleType::Box, ObstacleType::Plane});
  only_for("file", {ObstacleType::Mesh, ObstacleType::Skinned});
  for (const char* key : {"animation", "speed", "loop", "offset", "blend_in", "hold"}) only_for(key, {ObstacleType::Skinned});
  only_for("close_holes", {ObstacleType::Mesh, ObstacleType::Skinned});
  if (od.type == ObstacleType::Skinned && j.contains("motion"))
    fail(ptr + "/motion", "field 'motion' does not apply to obstacle type 'skinned' (its animation moves it)");
  optional(j, ptr, "name", [&](const json& v, const std::string& p) { od.name = string(v, p); });
  optional(j, ptr, "radius", [&](const json& v, const std::string& p) { od.radius = number_f(v, p); });
  optional(j, ptr, "slices", [&](const json& v, const std::string& p) { od.slices = integer(v, p); });
  optional(j, ptr, "stacks", [&](const json& v, const std::string& p) { od.stacks = integer(v, p); });
  optional(j, ptr, "size", [&](const json& v, const std::string& p) { od.size = float3(v, p); });
  optional(j, ptr, "animation", [&](const json& v, const std::string& p) { od.animation = string(v, p); });
  optional(j, ptr, "speed", [&](const json& v, const std::string& p) { od.speed = number_f(v, p); });
  optional(j, ptr, "loop", [&](const json& v, const std::string& p) { od.loop = boolean(v, p); });
  optional(j, ptr, "offset", [&](const json& v, const std::string& p) { od.offset = number(v, p); });
  optional(j, ptr, "blend_in", [&](const json& v, const std::string& p) { od.blend_in = number(v, p); });
  optional(j, ptr, "hold", [&](const json& v, const std::string& p) { od.hold = number(v, p); });
  optional(j, ptr, "close_holes", [&](const json& v, const std::string& p) { od.close_holes = boolean(v, p); });
  optional(j, ptr, "front", [&](const json& v, const std::string& p) {
    od.front = float3(v, p);
    if (!(std::hypot(od.front[0], od.front[2]) > 1e-6f)) fail(p, "must point somewhere horizontal (x or z not 0)");
  });
  if (od.type == ObstacleType::Mesh || od.type == ObstacleType::Skinned)
    required(j, ptr, "file", [&](const json& v, const std::string& p) { od.file = file_path(v, p); });
  transform(j, ptr, od.transform);
  optional(j, ptr, "motion", [&](const json& v, const std::string& p) { od.motion = motion(v, p); });
  return od;
}

}  // namespace scene_json

namespace {

using json = nlohmann::json;

// The JSON pointer of the value being parsed, kept from the parser's events, so that an error the
// parser raises inside a value (a number too large for a double) can name the field.
class PointerTracker {
 public:
  bool event(json::parse_event_t ev, const json& parsed) {
    switch (ev) {
      case json::parse_event_t::object_start: frames_.push_back({false, 0, ""}); break;
      case json::parse_event_t::array_start: frames_.push_back({true, 0, ""}); break;
      case json::parse_event_t::key:
        if (!frames_.empty()) frames_.back().key = parsed.get<std::string>();
        break;
      case json::parse_event_t::object_end:
      case json::parse_event_t::array_end:
        if (!frames_.empty()) frames_.pop_back();
        value_done();
        break;
      case json::parse_event_t::value: value_done(); break;
    }
    return true;
  }
  // The pointer of the value the parser is in now.
  std::string pointer() const {
    std::string p;
    for (const Frame& f : frames_) p += "/" + (f.array ? std::to_string(f.index) : json_pointer_token(f.key));
    return p;
  }

 private:
  struct Frame {
    bool array;
    size_t index;
    std::string key;
  };
  void value_done() {
    if (!frames_.empty() && frames_.back().array) ++frames_.back().index;
  }
  std::vector<Frame> frames_;
};

}  // namespace

SceneDef load_scene_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError(path, "", std::string("cannot open scene file: ") + std::strerror(EISDIR));
  // A device or a pipe (/dev/zero) would be read forever.
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec))
    throw InputError(path, "", "cannot open scene file: it is not a regular file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", std::string("cannot open scene file: ") + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InputError(path, "", std::string("cannot read scene file: ") + std::strerror(errno));
  return parse_scene(text.str(), path);
}

SceneDef parse_scene(const std::string& text, const std::string& origin) {
  json j;
  PointerTracker where;
  try {
    j = json::parse(
        text, [&](int, json::parse_event_t ev, json& parsed) { return where.event(ev, parsed); },
        /*allow_exceptions=*/true, /*ignore_comments=*/true);
  } catch (const json::parse_error& e) {
    throw InputError(origin, "", without_json_exception_tags(e.what()));
  } catch (const json::out_of_range& e) {
    // nlohmann: "number overflow parsing '1e400'", raised while the value is being read.
    throw InputError(origin, where.pointer(), without_json_exception_tags(e.what()) + ": not a finite number");
  }
  return parse_scene(j, origin, std::filesystem::path(origin).parent_path());
}

SceneDef parse_scene(const json& j, const std::string& origin, const std::filesystem::path& dir) {
  const scene_json::SceneReader reader(origin, dir);
  SceneDef scene = reader.scene(j);
  validate_scene(scene);
  return scene;
}

}  // namespace raycloth
