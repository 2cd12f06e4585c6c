// Scene files: JSON (comments allowed) into SceneDef, and the checks every scene goes through.
// Parsing checks shapes and types and rejects unknown fields; validate_scene checks values and
// cross references, so that scenes built in code get the same checks as scenes read from files.
// Every error is an InputError naming the file, the JSON pointer of the field and the reason
// (docs/scenes.md lists the schema).
#include <nlohmann/json.hpp>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <sstream>
#include <string_view>

#include "raycloth/error.h"
#include "raycloth/scene.h"
#include "fabric/kes.h"
#include "scene/garmentcode.h"
#include "scene/json_text.h"
#include "scene/mesh.h"

namespace raycloth {

namespace {

using json = nlohmann::json;

// Shortest form of a number that reads back the same in a message: 0.75, -1, 1e+39.
std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

template <class T, size_t N>
std::string num_list(const std::array<T, N>& a) {
  std::string s = "[";
  for (size_t i = 0; i < N; ++i) s += (i ? ", " : "") + num(double(a[i]));
  return s + "]";
}

// The most cloth vertices (all panels) and UV-sphere vertices a scene may ask for.
constexpr int64_t kMaxVertices = int64_t(1) << 22;

constexpr std::string_view kEdges[] = {"left", "right", "bottom", "top"};
constexpr std::string_view kCorners[] = {"bottom_left", "bottom_right", "top_left", "top_right"};

bool is_edge(const std::string& e) {
  for (auto k : kEdges)
    if (e == k) return true;
  return false;
}

bool is_corner(const std::string& c) {
  for (auto k : kCorners)
    if (c == k) return true;
  return false;
}

// Vertices along an edge: left/right run along v, bottom/top along u.
int edge_vertex_count(const PanelDef& p, const std::string& edge) {
  return edge == "left" || edge == "right" ? p.resolution_v : p.resolution_u;
}

// Reads JSON values into defs; `file` names the scene in errors, `dir` resolves mesh paths.
class Reader {
 public:
  Reader(std::string file, std::filesystem::path dir) : file_(std::move(file)), dir_(std::move(dir)) {}

  SceneDef scene(const json& j) {
    SceneDef s;
    s.source = file_;
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
      object(v, p, {"close_time", "weld_at_start", "close_tolerance", "ease_gravity"});
      optional(v, p, "ease_gravity", [&](const json& w, const std::string& q) { s.sewing.ease_gravity = boolean(w, q); });
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

 private:
  [[noreturn]] void fail(const std::string& field, const std::string& reason) const {
    throw InputError(file_, field, reason);
  }

  // An object whose keys must all be in `allowed`: a typo is an error, not a silent default.
  void object(const json& j, const std::string& ptr, std::initializer_list<std::string_view> allowed) const {
    if (!j.is_object()) fail(ptr, std::string("expected an object, got ") + j.type_name());
    for (const auto& [key, value] : j.items()) {
      bool known = false;
      for (auto a : allowed) known = known || key == a;
      if (!known) fail(ptr + "/" + json_pointer_token(key), "unknown field '" + key + "'");
    }
  }

  template <class F>
  void optional(const json& obj, const std::string& ptr, const char* key, F&& read) const {
    const auto it = obj.find(key);
    if (it != obj.end()) read(*it, ptr + "/" + key);
  }

  template <class F>
  void required(const json& obj, const std::string& ptr, const char* key, F&& read) const {
    const auto it = obj.find(key);
    if (it == obj.end()) fail(ptr + "/" + key, "missing required field");
    read(*it, ptr + "/" + key);
  }

  // An array of objects under `key`, each read by `read(value, pointer, index)`.
  template <class F>
  void list(const json& obj, const std::string& ptr, const char* key, bool need_one, F&& read) const {
    const std::string p = ptr + "/" + key;
    const auto it = obj.find(key);
    if (it == obj.end()) {
      if (need_one) fail(p, "missing required field");
      return;
    }
    if (!it->is_array()) fail(p, std::string("expected an array, got ") + it->type_name());
    if (need_one && it->empty()) fail(p, "needs at least one entry");
    for (size_t i = 0; i < it->size(); ++i) read((*it)[i], p + "/" + std::to_string(i), i);
  }

  double number(const json& j, const std::string& ptr) const {
    if (!j.is_number()) fail(ptr, std::string("expected a number, got ") + j.type_name());
    return j.get<double>();
  }

  float number_f(const json& j, const std::string& ptr) const {
    const double v = number(j, ptr);
    if (std::abs(v) > double(std::numeric_limits<float>::max())) fail(ptr, "is out of range (got " + num(v) + ")");
    return float(v);
  }

  int integer(const json& j, const std::string& ptr) const {
    if (!j.is_number()) fail(ptr, std::string("expected an integer, got ") + j.type_name());
    const double v = j.get<double>();
    if (v != std::floor(v)) fail(ptr, "expected an integer, got " + num(v));
    if (v < double(std::numeric_limits<int>::min()) || v > double(std::numeric_limits<int>::max()))
      fail(ptr, "is out of range (got " + num(v) + ")");
    return int(v);
  }

  bool boolean(const json& j, const std::string& ptr) const {
    if (!j.is_boolean()) fail(ptr, std::string("expected true or false, got ") + j.type_name());
    return j.get<bool>();
  }

  std::string string(const json& j, const std::string& ptr) const {
    if (!j.is_string()) fail(ptr, std::string("expected a string, got ") + j.type_name());
    return j.get<std::string>();
  }

  // A fixed-length array, each element read by `read`.
  template <class T, size_t N, class F>
  std::array<T, N> fixed(const json& j, const std::string& ptr, const char* what, F&& read) const {
    if (!j.is_array())
      fail(ptr, "expected an array of " + std::to_string(N) + " " + what + ", got " + j.type_name());
    if (j.size() != N)
      fail(ptr, "expected " + std::to_string(N) + " " + what + ", got " + std::to_string(j.size()));
    std::array<T, N> a{};
    for (size_t i = 0; i < N; ++i) a[i] = read(j[i], ptr + "/" + std::to_string(i));
    return a;
  }

  Float3 float3(const json& j, const std::string& ptr) const {
    return fixed<float, 3>(j, ptr, "numbers", [&](const json& v, const std::string& p) { return number_f(v, p); });
  }
  std::array<float, 2> float2(const json& j, const std::string& ptr) const {
    return fixed<float, 2>(j, ptr, "numbers", [&](const json& v, const std::string& p) { return number_f(v, p); });
  }
  std::array<int, 2> int2(const json& j, const std::string& ptr) const {
    return fixed<int, 2>(j, ptr, "integers", [&](const json& v, const std::string& p) { return integer(v, p); });
  }

  TimeDef time(const json& j, const std::string& ptr) const {
    TimeDef t;
    object(j, ptr, {"dt", "duration", "fps", "integrator", "iterations", "tolerance"});
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
    optional(j, ptr, "duration", [&](const json& v, const std::string& p) { t.duration = number(v, p); });
    optional(j, ptr, "fps", [&](const json& v, const std::string& p) { t.fps = number(v, p); });
    return t;
  }

  CollisionDef collision(const json& j, const std::string& ptr) const {
    CollisionDef c;
    object(j, ptr, {"tolerance", "thickness", "friction", "cloth_cloth"});
    optional(j, ptr, "tolerance", [&](const json& v, const std::string& p) { c.tolerance = number_f(v, p); });
    optional(j, ptr, "thickness", [&](const json& v, const std::string& p) { c.thickness = number_f(v, p); });
    optional(j, ptr, "friction", [&](const json& v, const std::string& p) { c.friction = number_f(v, p); });
    optional(j, ptr, "cloth_cloth", [&](const json& v, const std::string& p) { c.cloth_cloth = boolean(v, p); });
    return c;
  }

  OutputDef output(const json& j, const std::string& ptr) const {
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

  CameraDef camera(const json& j, const std::string& ptr) const {
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

  MaterialDef material(const json& j, const std::string& ptr) const {
    MaterialDef m;
    object(j, ptr, {"name", "fabric", "kes", "density", "stretch", "shear", "bend", "damping", "spring_damping"});
    required(j, ptr, "name", [&](const json& v, const std::string& p) { m.name = string(v, p); });
    // A fabric: a named preset, measurements ("kes"), or a preset with some measurements replaced.
    optional(j, ptr, "fabric", [&](const json& v, const std::string& p) {
      const std::string name = string(v, p);
      const fabric::Preset* preset = fabric::find_preset(name);
      if (!preset) fail(p, "unknown fabric '" + name + "' (expected " + fabric::preset_names() + ")");
      m.fabric = FabricDef{name, preset->W, preset->B, preset->G, preset->EMT};
    });
    optional(j, ptr, "kes", [&](const json& v, const std::string& p) {
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
    return m;
  }

  void transform(const json& j, const std::string& ptr, TransformDef& t) const {
    optional(j, ptr, "position", [&](const json& v, const std::string& p) { t.position = float3(v, p); });
    optional(j, ptr, "rotation", [&](const json& v, const std::string& p) { t.rotation = float3(v, p); });
    optional(j, ptr, "scale", [&](const json& v, const std::string& p) { t.scale = float3(v, p); });
  }

  // A panel is a rectangle (size and resolution), a mesh (an OBJ file) or a sewing pattern.
  PanelDef panel(const json& j, const std::string& ptr) const {
    PanelDef pd;
    object(j, ptr, {"name", "material", "size", "resolution", "mesh", "pattern", "position", "rotation", "scale"});
    required(j, ptr, "name", [&](const json& v, const std::string& p) { pd.name = string(v, p); });
    required(j, ptr, "material", [&](const json& v, const std::string& p) { pd.material = string(v, p); });
    const bool mesh = j.contains("mesh"), pattern = j.contains("pattern");
    if (mesh && pattern) fail(ptr, "a panel is a rectangle (size, resolution), a mesh or a pattern, not both mesh and pattern");
    if (mesh || pattern)
      for (const char* k : {"size", "resolution"})
        if (j.contains(k))
          fail(ptr + "/" + k, std::string("only for rectangle panels; this one is a ") + (mesh ? "mesh" : "pattern"));
    if (mesh) {
      pd.shape = PanelShape::Mesh;
      required(j, ptr, "mesh", [&](const json& v, const std::string& p) {
        const std::filesystem::path f = string(v, p);
        pd.mesh_file = (f.is_absolute() || dir_.empty() ? f : dir_ / f).lexically_normal().string();
      });
    } else if (pattern) {
      pd.shape = PanelShape::Pattern;
      required(j, ptr, "pattern", [&](const json& v, const std::string& p) { pd.pattern = pattern_def(v, p); });
    } else {
      required(j, ptr, "size", [&](const json& v, const std::string& p) {
        const auto s = float2(v, p);
        pd.width = s[0];
        pd.height = s[1];
      });
      required(j, ptr, "resolution", [&](const json& v, const std::string& p) {
        const auto r = int2(v, p);
        pd.resolution_u = r[0];
        pd.resolution_v = r[1];
      });
    }
    transform(j, ptr, pd.transform);
    return pd;
  }

  PatternDef pattern_def(const json& j, const std::string& ptr) const {
    PatternDef pd;
    object(j, ptr, {"outline", "edge_length", "wrap_radius"});
    list(j, ptr, "outline", true, [&](const json& v, const std::string& p, size_t) {
      OutlineSegment seg;
      object(v, p, {"name", "from", "control", "control2", "arc"});
      optional(v, p, "name", [&](const json& w, const std::string& q) { seg.name = string(w, q); });
      required(v, p, "from", [&](const json& w, const std::string& q) { seg.from = float2(w, q); });
      optional(v, p, "control", [&](const json& w, const std::string& q) { seg.control = float2(w, q); });
      optional(v, p, "control2", [&](const json& w, const std::string& q) { seg.control2 = float2(w, q); });
      optional(v, p, "arc", [&](const json& w, const std::string& q) {
        OutlineArc arc;
        object(w, q, {"radius", "large", "ccw"});
        required(w, q, "radius", [&](const json& x, const std::string& r) { arc.radius = number_f(x, r); });
        optional(w, q, "large", [&](const json& x, const std::string& r) { arc.large = boolean(x, r); });
        optional(w, q, "ccw", [&](const json& x, const std::string& r) { arc.ccw = boolean(x, r); });
        seg.arc = arc;
      });
      pd.outline.push_back(seg);
    });
    required(j, ptr, "edge_length", [&](const json& v, const std::string& p) { pd.edge_length = number_f(v, p); });
    optional(j, ptr, "wrap_radius", [&](const json& v, const std::string& p) { pd.wrap_radius = number_f(v, p); });
    return pd;
  }

  // A garment from a GarmentCode pattern file: its panels and stitches become pattern panels and
  // seams (src/scene/garmentcode.h).
  void garment(const json& j, const std::string& ptr, SceneDef& s) const {
    object(j, ptr, {"garmentcode", "material", "edge_length", "position", "rotation", "scale", "prefix",
                    "seam_stiffness", "panels", "body", "clear", "weld_at_start"});
    // On a body, the garment stays in the pattern's frame here; position and the rotation about the
    // vertical are applied after the fit (sim/garment_fit.h).
    GarmentFitDef fit;
    optional(j, ptr, "body", [&](const json& v, const std::string& p) { fit.body = string(v, p); });
    optional(j, ptr, "clear", [&](const json& v, const std::string& p) { fit.clear = boolean(v, p); });
    std::optional<bool> weld;
    optional(j, ptr, "weld_at_start", [&](const json& v, const std::string& p) { weld = boolean(v, p); });
    GarmentCodeOptions o;
    std::string file;
    required(j, ptr, "garmentcode", [&](const json& v, const std::string& p) {
      const std::filesystem::path f = string(v, p);
      file = (f.is_absolute() || dir_.empty() ? f : dir_ / f).lexically_normal().string();
    });
    required(j, ptr, "material", [&](const json& v, const std::string& p) { o.material = string(v, p); });
    optional(j, ptr, "edge_length", [&](const json& v, const std::string& p) {
      o.edge_length = number_f(v, p);
      if (!(o.edge_length > 0)) fail(p, "must be a positive number of metres");
    });
    optional(j, ptr, "position", [&](const json& v, const std::string& p) {
      (fit.body.empty() ? o.position : fit.position) = float3(v, p);
    });
    optional(j, ptr, "rotation", [&](const json& v, const std::string& p) {
      o.rotation = float3(v, p);
      if (!fit.body.empty()) {
        if (o.rotation[0] != 0 || o.rotation[2] != 0)
          fail(p, "a garment on a body turns only about the vertical: give [0, degrees, 0]");
        fit.rotation = o.rotation[1];
        o.rotation = {0, 0, 0};
      }
    });
    optional(j, ptr, "scale", [&](const json& v, const std::string& p) {
      o.scale = number_f(v, p);
      if (!(o.scale > 0)) fail(p, "must be a positive number");
    });
    optional(j, ptr, "prefix", [&](const json& v, const std::string& p) { o.prefix = string(v, p); });
    optional(j, ptr, "seam_stiffness", [&](const json& v, const std::string& p) { o.seam_stiffness = number_f(v, p); });
    optional(j, ptr, "panels", [&](const json& v, const std::string& p) {
      if (!v.is_object()) fail(p, std::string("expected an object of panel options by name, got ") + v.type_name());
      for (const auto& [name, pv] : v.items()) {
        const std::string q = p + "/" + json_pointer_token(name);
        GarmentCodePanelOptions po;
        object(pv, q, {"material", "edge_length", "offset"});
        optional(pv, q, "material", [&](const json& w, const std::string& r) { po.material = string(w, r); });
        optional(pv, q, "edge_length", [&](const json& w, const std::string& r) { po.edge_length = number_f(w, r); });
        optional(pv, q, "offset", [&](const json& w, const std::string& r) { po.offset = float3(w, r); });
        o.panels[name] = po;
      }
    });
    const GarmentCodeGarment g = read_garmentcode(file, o);
    for (const auto& [name, po] : o.panels) {
      bool known = false;
      for (const auto& n : g.file_panel_names) known = known || n == name;
      if (!known) fail(ptr + "/panels/" + json_pointer_token(name), "no panel '" + name + "' in '" + file + "'");
    }
    if (!fit.body.empty()) {
      fit.field = ptr;
      fit.first_panel = uint32_t(s.panels.size());
      fit.num_panels = uint32_t(g.panels.size());
      s.garment_fits.push_back(fit);
    }
    for (PanelDef pd : g.panels) {
      if (!fit.body.empty()) pd.min_mass_share = 0.25f;
      s.panels.push_back(pd);
    }
    for (SeamDef sd : g.seams) {
      if (weld) sd.weld_at_start = weld;
      s.seams.push_back(sd);
    }
  }

  // Which vertices of a panel: exactly one of a rectangle's edge, a pattern's segment or a mesh
  // panel's boundary path (and, where `range_too`, an index range).
  void path_fields(const json& j, const std::string& ptr, EdgeRef& e, std::optional<std::array<int, 2>>* range) const {
    const int kinds = int(j.contains("edge")) + int(j.contains("segment")) + int(j.contains("path")) +
                      int(range && j.contains("range"));
    if (kinds != 1)
      fail(ptr, range ? "needs exactly one of edge, segment or range" : "needs exactly one of edge, segment or path");
    optional(j, ptr, "edge", [&](const json& v, const std::string& p) {
      e.edge = string(v, p);
      if (!is_edge(e.edge)) fail(p, bad_edge(e.edge));
    });
    optional(j, ptr, "segment", [&](const json& v, const std::string& p) {
      e.segment = string(v, p);
      if (e.segment.empty()) fail(p, "must not be empty");
    });
    if (!range) optional(j, ptr, "path", [&](const json& v, const std::string& p) { e.path = int2(v, p); });
    if (range) optional(j, ptr, "range", [&](const json& v, const std::string& p) { *range = int2(v, p); });
  }

  EdgeRef edge_ref(const json& j, const std::string& ptr) const {
    EdgeRef e;
    object(j, ptr, {"panel", "edge", "segment", "path"});
    required(j, ptr, "panel", [&](const json& v, const std::string& p) { e.panel = string(v, p); });
    path_fields(j, ptr, e, nullptr);
    return e;
  }

  SeamDef seam(const json& j, const std::string& ptr) const {
    SeamDef sd;
    object(j, ptr, {"a", "b", "reverse", "stiffness", "weld_at_start"});
    required(j, ptr, "a", [&](const json& v, const std::string& p) { sd.a = edge_ref(v, p); });
    required(j, ptr, "b", [&](const json& v, const std::string& p) { sd.b = edge_ref(v, p); });
    optional(j, ptr, "reverse", [&](const json& v, const std::string& p) { sd.reverse = boolean(v, p); });
    optional(j, ptr, "stiffness", [&](const json& v, const std::string& p) { sd.stiffness = number_f(v, p); });
    optional(j, ptr, "weld_at_start", [&](const json& v, const std::string& p) { sd.weld_at_start = boolean(v, p); });
    return sd;
  }

  PinDef pin(const json& j, const std::string& ptr) const {
    PinDef pd;
    object(j, ptr, {"panel", "corner", "edge", "segment", "range"});
    required(j, ptr, "panel", [&](const json& v, const std::string& p) { pd.panel = string(v, p); });
    // Presence decides the kind of pin, so that "corner": "" is reported as a bad corner name
    // rather than as a missing one.
    const int kinds = int(j.contains("corner")) + int(j.contains("edge")) + int(j.contains("segment")) +
                      int(j.contains("range"));
    if (kinds != 1) fail(ptr, "a pin needs exactly one of corner, edge, segment or range");
    optional(j, ptr, "corner", [&](const json& v, const std::string& p) {
      pd.corner = string(v, p);
      if (!is_corner(pd.corner)) fail(p, bad_corner(pd.corner));
    });
    optional(j, ptr, "edge", [&](const json& v, const std::string& p) {
      pd.edge = string(v, p);
      if (!is_edge(pd.edge)) fail(p, bad_edge(pd.edge));
    });
    optional(j, ptr, "segment", [&](const json& v, const std::string& p) {
      pd.segment = string(v, p);
      if (pd.segment.empty()) fail(p, "must not be empty");
    });
    optional(j, ptr, "range", [&](const json& v, const std::string& p) { pd.range = int2(v, p); });
    return pd;
  }

  AttachmentDef attachment(const json& j, const std::string& ptr) const {
    AttachmentDef a;
    object(j, ptr, {"panel", "edge", "segment", "range", "obstacle", "obstacle_vertices", "stiffness", "damping", "lift"});
    required(j, ptr, "panel", [&](const json& v, const std::string& p) { a.panel = string(v, p); });
    EdgeRef e;
    path_fields(j, ptr, e, &a.range);
    a.edge = e.edge;
    a.segment = e.segment;
    required(j, ptr, "obstacle", [&](const json& v, const std::string& p) { a.obstacle = string(v, p); });
    optional(j, ptr, "obstacle_vertices", [&](const json& v, const std::string& p) {
      if (!v.is_array()) fail(p, std::string("expected an array of vertex numbers, got ") + v.type_name());
      for (size_t i = 0; i < v.size(); ++i) a.obstacle_vertices.push_back(integer(v[i], p + "/" + std::to_string(i)));
    });
    optional(j, ptr, "stiffness", [&](const json& v, const std::string& p) { a.stiffness = number_f(v, p); });
    optional(j, ptr, "damping", [&](const json& v, const std::string& p) { a.damping = number_f(v, p); });
    optional(j, ptr, "lift", [&](const json& v, const std::string& p) { a.lift = number_f(v, p); });
    return a;
  }

  ObstacleType obstacle_type(const json& j, const std::string& ptr) const {
    const std::string t = string(j, ptr);
    if (t == "uv_sphere") return ObstacleType::UvSphere;
    if (t == "box") return ObstacleType::Box;
    if (t == "plane") return ObstacleType::Plane;
    if (t == "mesh") return ObstacleType::Mesh;
    if (t == "skinned") return ObstacleType::Skinned;
    fail(ptr, "unknown obstacle type '" + t + "' (expected uv_sphere, box, plane, mesh or skinned)");
  }

  MotionDef motion(const json& j, const std::string& ptr) const {
    MotionDef m;
    object(j, ptr, {"velocity", "angular_velocity", "start"});
    optional(j, ptr, "velocity", [&](const json& v, const std::string& p) { m.velocity = float3(v, p); });
    optional(j, ptr, "angular_velocity",
             [&](const json& v, const std::string& p) { m.angular_velocity = float3(v, p); });
    optional(j, ptr, "start", [&](const json& v, const std::string& p) { m.start = number(v, p); });
    return m;
  }

  ObstacleDef obstacle(const json& j, const std::string& ptr, size_t index) const {
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
      required(j, ptr, "file", [&](const json& v, const std::string& p) {
        const std::filesystem::path f = string(v, p);
        od.file = (f.is_absolute() || dir_.empty() ? f : dir_ / f).lexically_normal().string();
      });
    transform(j, ptr, od.transform);
    optional(j, ptr, "motion", [&](const json& v, const std::string& p) { od.motion = motion(v, p); });
    return od;
  }

 public:
  static std::string bad_edge(const std::string& e) {
    return "unknown edge '" + e + "' (expected left, right, bottom or top)";
  }
  static std::string bad_corner(const std::string& c) {
    return "unknown corner '" + c + "' (expected bottom_left, bottom_right, top_left or top_right)";
  }

 private:
  std::string file_;
  std::filesystem::path dir_;
};


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
  Reader reader(origin, dir);
  SceneDef scene = reader.scene(j);
  validate_scene(scene);
  return scene;
}

void validate_output(const OutputDef& o, const std::string& source) {
  auto fail = [&](const std::string& field, const std::string& reason) { throw InputError(source, field, reason); };
  for (size_t i = 0; i < o.formats.size(); ++i) {
    const std::string p = "/output/formats/" + std::to_string(i);
    bool known = false;
    for (auto f : kOutputFormats) known = known || o.formats[i] == f;
    if (!known) fail(p, "unknown format '" + o.formats[i] + "' (expected obj, ply, pc2 or glb)");
    for (size_t k = 0; k < i; ++k)
      if (o.formats[k] == o.formats[i]) fail(p, "format '" + o.formats[i] + "' is listed twice");
  }
  const CameraDef& c = o.camera;
  if (c.position) {
    for (float x : *c.position)
      if (!std::isfinite(x)) fail("/output/camera/position", "must be finite (got " + num_list(*c.position) + ")");
  }
  if (c.target) {
    for (float x : *c.target)
      if (!std::isfinite(x)) fail("/output/camera/target", "must be finite (got " + num_list(*c.target) + ")");
  }
  if (c.position && c.target && *c.position == *c.target)
    fail("/output/camera/target", "must differ from the camera position");
  if (!(c.fov > 0 && c.fov < 180)) fail("/output/camera/fov", "must be between 0 and 180 degrees (got " + num(c.fov) + ")");
  if (c.width < 1 || c.height < 1 || c.width > 16384 || c.height > 16384)
    fail("/output/camera/resolution", "both must be between 1 and 16384 pixels (got " +
                                          num_list(std::array<int, 2>{c.width, c.height}) + ")");
  if (c.samples < 1 || c.samples > 1024)
    fail("/output/camera/samples", "must be between 1 and 1024 (got " + std::to_string(c.samples) + ")");
}

void validate_scene(const SceneDef& s) {
  auto fail = [&](const std::string& field, const std::string& reason) { throw InputError(s.source, field, reason); };
  auto positive = [&](double v, const std::string& field) {
    if (!(v > 0)) fail(field, "must be positive (got " + num(v) + ")");
  };
  auto non_negative = [&](double v, const std::string& field) {
    if (!(v >= 0)) fail(field, "must not be negative (got " + num(v) + ")");
  };
  auto finite3 = [&](const Float3& v, const std::string& field) {
    for (float x : v)
      if (!std::isfinite(x)) fail(field, "must be finite (got " + num_list(v) + ")");
  };
  auto positive3 = [&](const Float3& v, const std::string& field) {
    for (float x : v)
      if (!(x > 0)) fail(field, "all must be positive (got " + num_list(v) + ")");
  };
  auto check_transform = [&](const TransformDef& t, const std::string& ptr) {
    finite3(t.position, ptr + "/position");
    finite3(t.rotation, ptr + "/rotation");
    positive3(t.scale, ptr + "/scale");
  };
  auto idx = [](const char* list, size_t i) { return std::string("/") + list + "/" + std::to_string(i); };

  positive(s.time.dt, "/time/dt");
  if (s.time.iterations < 1 || s.time.iterations > 1000)
    fail("/time/iterations", "must be between 1 and 1000 (got " + std::to_string(s.time.iterations) + ")");
  positive(s.time.tolerance, "/time/tolerance");
  positive(s.time.duration, "/time/duration");
  positive(s.time.fps, "/time/fps");
  finite3(s.gravity, "/gravity");
  positive(s.collision.tolerance, "/collision/tolerance");
  non_negative(s.collision.thickness, "/collision/thickness");
  non_negative(s.collision.friction, "/collision/friction");

  for (size_t i = 0; i < s.materials.size(); ++i) {
    const MaterialDef& m = s.materials[i];
    const std::string p = idx("materials", i);
    if (m.name.empty()) fail(p + "/name", "must not be empty");
    for (size_t k = 0; k < i; ++k)
      if (s.materials[k].name == m.name)
        fail(p + "/name", "duplicate material name '" + m.name + "' (also " + idx("materials", k) + ")");
    positive(m.density, p + "/density");
    positive(m.stretch, p + "/stretch");
    non_negative(m.shear, p + "/shear");
    non_negative(m.bend, p + "/bend");
    non_negative(m.damping, p + "/damping");
    non_negative(m.spring_damping, p + "/spring_damping");
    if (m.fabric) {
      // Measurements that no fabric can have: zero, negative, not a number.
      const std::pair<const char*, double> kes[] = {{"W", m.fabric->W}, {"B", m.fabric->B}, {"G", m.fabric->G}, {"EMT", m.fabric->EMT}};
      for (const auto& [key, value] : kes)
        if (!(value > 0) || !std::isfinite(value))
          fail(p + "/kes/" + key, "must be a positive measurement (got " + num(value) + ")");
    }
  }

  // Input that would not fit in memory or never end is refused with its reason (and a limit) rather
  // than running out of memory or time.
  if (s.time.duration / s.time.dt > 1e12)
    fail("/time/dt", "the run would take more than 1e12 steps (duration " + num(s.time.duration) + " s, dt " + num(s.time.dt) + " s)");
  if (s.time.duration * s.time.fps > 1e6)
    fail("/time/fps", "the run would write more than 1000000 frames (duration " + num(s.time.duration) + " s, fps " + num(s.time.fps) + ")");
  int64_t cloth_vertices = 0;
  if (s.panels.empty()) fail("/panels", "the scene needs at least one panel");
  for (size_t i = 0; i < s.panels.size(); ++i) {
    const PanelDef& pd = s.panels[i];
    const std::string p = idx("panels", i);
    if (pd.name.empty()) fail(p + "/name", "must not be empty");
    for (size_t k = 0; k < i; ++k)
      if (s.panels[k].name == pd.name)
        fail(p + "/name", "duplicate panel name '" + pd.name + "' (also " + idx("panels", k) + ")");
    bool known = false;
    for (const auto& m : s.materials) known = known || m.name == pd.material;
    if (!known) fail(p + "/material", "unknown material '" + pd.material + "'");
    switch (pd.shape) {
      case PanelShape::Rectangle: {
        if (!(pd.width > 0 && pd.height > 0))
          fail(p + "/size", "both must be positive (got " + num_list(std::array<float, 2>{pd.width, pd.height}) + ")");
        const std::array<int, 2> res{pd.resolution_u, pd.resolution_v};
        if (res[0] < 2 || res[1] < 2) fail(p + "/resolution", "both must be at least 2 (got " + num_list(res) + ")");
        // Far below 32-bit vertex ids: a bigger cloth would not fit in memory or finish a step soon.
        if (int64_t(res[0]) * res[1] > kMaxVertices)
          fail(p + "/resolution", "too many vertices (got " + num_list(res) + ", at most " + std::to_string(kMaxVertices) + " in all)");
        cloth_vertices += int64_t(res[0]) * res[1];
        if (cloth_vertices > kMaxVertices)
          fail(p + "/resolution", "the panels have too many vertices in all (at most " + std::to_string(kMaxVertices) + ")");
        break;
      }
      case PanelShape::Mesh:
        if (pd.mesh_file.empty()) fail(p + "/mesh", "a mesh panel needs an OBJ file");
        if (const auto why = input_file_problem(pd.mesh_file); !why.empty()) fail(p + "/mesh", "OBJ file '" + pd.mesh_file + "' " + why);
        break;
      case PanelShape::Pattern: {
        const PatternDef& pat = pd.pattern;
        if (pat.outline.size() < 3)
          fail(p + "/pattern/outline", "needs at least 3 segments (got " + std::to_string(pat.outline.size()) + ")");
        positive(pat.edge_length, p + "/pattern/edge_length");
        if (pat.wrap_radius) positive(*pat.wrap_radius, p + "/pattern/wrap_radius");
        for (size_t k = 0; k < pat.outline.size(); ++k) {
          const std::string q = p + "/pattern/outline/" + std::to_string(k);
          if (!std::isfinite(pat.outline[k].from[0]) || !std::isfinite(pat.outline[k].from[1])) fail(q + "/from", "must be finite");
          for (size_t m = 0; m < k; ++m)
            if (!pat.outline[k].name.empty() && pat.outline[m].name == pat.outline[k].name)
              fail(q + "/name", "duplicate segment name '" + pat.outline[k].name + "' (also " + p + "/pattern/outline/" +
                                    std::to_string(m) + ")");
        }
        break;
      }
    }
    check_transform(pd.transform, p);
  }

  // A path must suit its panel: an edge of a rectangle, a segment of a pattern, a path of a mesh.
  auto check_path = [&](const EdgeRef& r, const PanelDef& pd, const std::string& p) {
    const int kinds = int(!r.edge.empty()) + int(!r.segment.empty()) + int(r.path.has_value());
    if (kinds != 1) fail(p, "needs exactly one of edge, segment or path");
    if (!r.edge.empty()) {
      if (pd.shape != PanelShape::Rectangle)
        fail(p + "/edge", "panel '" + pd.name + "' is not a rectangle; name an outline segment or a path");
      if (!is_edge(r.edge)) fail(p + "/edge", Reader::bad_edge(r.edge));
    }
    if (!r.segment.empty()) {
      if (pd.shape != PanelShape::Pattern) fail(p + "/segment", "panel '" + pd.name + "' is not a pattern");
      bool known = false;
      std::string names;
      for (const auto& seg : pd.pattern.outline) {
        known = known || seg.name == r.segment;
        if (!seg.name.empty()) names += (names.empty() ? "" : ", ") + seg.name;
      }
      if (!known)
        fail(p + "/segment", "panel '" + pd.name + "' has no segment '" + r.segment + "' (it has " +
                                 (names.empty() ? std::string("no named segments") : names) + ")");
    }
    if (r.path && pd.shape != PanelShape::Mesh) fail(p + "/path", "panel '" + pd.name + "' is not a mesh panel");
  };
  auto find_panel = [&](const std::string& name, const std::string& field) -> const PanelDef& {
    for (const auto& pd : s.panels)
      if (pd.name == name) return pd;
    fail(field, "unknown panel '" + name + "'");
    return s.panels.front();  // not reached
  };

  for (size_t i = 0; i < s.seams.size(); ++i) {
    const SeamDef& sd = s.seams[i];
    const std::string p = idx("seams", i);
    const PanelDef& pa = find_panel(sd.a.panel, p + "/a/panel");
    const PanelDef& pb = find_panel(sd.b.panel, p + "/b/panel");
    check_path(sd.a, pa, p + "/a");
    check_path(sd.b, pb, p + "/b");
    if (pa.shape == PanelShape::Rectangle && pb.shape == PanelShape::Rectangle) {
      const int na = edge_vertex_count(pa, sd.a.edge), nb = edge_vertex_count(pb, sd.b.edge);
      if (na != nb)
        fail(p, "edge '" + sd.a.edge + "' of panel '" + sd.a.panel + "' has " + std::to_string(na) +
                    " vertices but edge '" + sd.b.edge + "' of panel '" + sd.b.panel + "' has " + std::to_string(nb));
    }
    positive(sd.stiffness, p + "/stiffness");
  }

  for (size_t i = 0; i < s.pins.size(); ++i) {
    const PinDef& pd = s.pins[i];
    const std::string p = idx("pins", i);
    const PanelDef& panel = find_panel(pd.panel, p + "/panel");
    const int kinds = int(!pd.corner.empty()) + int(!pd.edge.empty()) + int(!pd.segment.empty()) + int(pd.range.has_value());
    if (kinds != 1) fail(p, "a pin needs exactly one of corner, edge, segment or range");
    if (!pd.corner.empty() && !is_corner(pd.corner)) fail(p + "/corner", Reader::bad_corner(pd.corner));
    if (!pd.corner.empty() && panel.shape != PanelShape::Rectangle)
      fail(p + "/corner", "panel '" + panel.name + "' is not a rectangle; pin a segment or a range");
    if (!pd.edge.empty() || !pd.segment.empty()) check_path(EdgeRef{pd.panel, pd.edge, pd.segment, std::nullopt}, panel, p);
    if (pd.range && panel.shape == PanelShape::Rectangle) {
      const auto [first, last] = *pd.range;
      const int64_t count = int64_t(panel.resolution_u) * panel.resolution_v;
      if (first < 0 || last < first || last >= count)
        fail(p + "/range", "range [" + std::to_string(first) + ", " + std::to_string(last) + "] is outside panel '" +
                               panel.name + "' (vertices 0 to " + std::to_string(count - 1) + ")");
    }
  }

  for (const GarmentFitDef& g : s.garment_fits) {
    bool known = false;
    std::string names;
    for (const ObstacleDef& o : s.obstacles) {
      known = known || o.name == g.body;
      names += (names.empty() ? "'" : ", '") + o.name + "'";
    }
    if (!known)
      fail(g.field + "/body", "no obstacle named '" + g.body + "' (the scene has " + (names.empty() ? "none" : names) + ")");
  }
  // Which garment (garments[] entry) each panel came from, -1 for the scene's own panels.
  if (!s.garment_fits.empty()) {
    std::map<std::string, int> garment_of;
    for (size_t g = 0; g < s.garment_fits.size(); ++g)
      for (uint32_t k = 0; k < s.garment_fits[g].num_panels; ++k)
        garment_of[s.panels[s.garment_fits[g].first_panel + k].name] = int(g);
    for (size_t i = 0; i < s.seams.size(); ++i) {
      const auto a = garment_of.find(s.seams[i].a.panel), b = garment_of.find(s.seams[i].b.panel);
      const int ga = a == garment_of.end() ? -1 : a->second, gb = b == garment_of.end() ? -1 : b->second;
      if (ga != gb)
        fail(idx("seams", i), "joins panel '" + s.seams[i].a.panel + "' of " +
                                  (ga < 0 ? std::string("the scene") : "garment " + s.garment_fits[ga].field) + " to panel '" +
                                  s.seams[i].b.panel + "' of " +
                                  (gb < 0 ? std::string("the scene") : "garment " + s.garment_fits[gb].field) +
                                  ": garments placed on a body are fitted separately, so a seam cannot join them");
    }
  }
  non_negative(s.sewing.close_time, "/sewing/close_time");
  if (s.sewing.close_tolerance) positive(*s.sewing.close_tolerance, "/sewing/close_tolerance");
  for (size_t i = 0; i < s.attachments.size(); ++i) {
    const AttachmentDef& a = s.attachments[i];
    const std::string p = idx("attachments", i);
    const PanelDef& panel = find_panel(a.panel, p + "/panel");
    const int kinds = int(!a.edge.empty()) + int(!a.segment.empty()) + int(a.range.has_value());
    if (kinds != 1) fail(p, "needs exactly one of edge, segment or range");
    if (!a.range) check_path(EdgeRef{a.panel, a.edge, a.segment, std::nullopt}, panel, p);
    bool known = false;
    for (const auto& od : s.obstacles) known = known || od.name == a.obstacle;
    if (!known) {
      std::string names;
      for (const auto& od : s.obstacles) names += (names.empty() ? "'" : ", '") + od.name + "'";
      fail(p + "/obstacle", "unknown obstacle '" + a.obstacle + "' (the scene has " + (names.empty() ? "none" : names) + ")");
    }
    positive(a.stiffness, p + "/stiffness");
    non_negative(a.damping, p + "/damping");
    if (!std::isfinite(a.lift)) fail(p + "/lift", "must be finite");
  }

  validate_output(s.output, s.source);

  for (size_t i = 0; i < s.obstacles.size(); ++i) {
    const ObstacleDef& od = s.obstacles[i];
    const std::string p = idx("obstacles", i);
    if (!od.name.empty())
      for (size_t k = 0; k < i; ++k)
        if (s.obstacles[k].name == od.name)
          fail(p + "/name", "duplicate obstacle name '" + od.name + "' (also " + idx("obstacles", k) + ")");
    switch (od.type) {
      case ObstacleType::UvSphere:
        positive(od.radius, p + "/radius");
        if (od.slices < 3) fail(p + "/slices", "must be at least 3 (got " + std::to_string(od.slices) + ")");
        if (od.stacks < 2) fail(p + "/stacks", "must be at least 2 (got " + std::to_string(od.stacks) + ")");
        if (int64_t(od.slices) * od.stacks > kMaxVertices)
          fail(p + "/slices", "too many vertices: slices x stacks is " + std::to_string(int64_t(od.slices) * od.stacks) +
                                  ", at most " + std::to_string(kMaxVertices));
        break;
      case ObstacleType::Box: positive3(od.size, p + "/size"); break;
      case ObstacleType::Plane:
        if (!(od.size[0] > 0 && od.size[2] > 0))
          fail(p + "/size", "x and z must be positive (got " + num_list(od.size) + ")");
        break;
      case ObstacleType::Mesh:
        if (od.file.empty()) fail(p + "/file", "a mesh obstacle needs an OBJ file");
        if (const auto why = input_file_problem(od.file); !why.empty()) fail(p + "/file", "OBJ file '" + od.file + "' " + why);
        break;
      case ObstacleType::Skinned:
        if (od.file.empty()) fail(p + "/file", "a skinned obstacle needs a glTF file");
        if (const auto why = input_file_problem(od.file); !why.empty()) fail(p + "/file", "glTF file '" + od.file + "' " + why);
        if (!(std::isfinite(od.speed) && od.speed >= 0.0f))
          fail(p + "/speed", "must be a number >= 0");
        if (od.offset && !std::isfinite(*od.offset)) fail(p + "/offset", "must be finite");
        non_negative(od.blend_in, p + "/blend_in");
        non_negative(od.hold, p + "/hold");
        break;
    }
    check_transform(od.transform, p);
    if (od.motion) {
      finite3(od.motion->velocity, p + "/motion/velocity");
      finite3(od.motion->angular_velocity, p + "/motion/angular_velocity");
      non_negative(od.motion->start, p + "/motion/start");
    }
  }
}

}  // namespace raycloth
