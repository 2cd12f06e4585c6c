// Scene files, the cloth's sections: panels (rectangles, OBJ meshes, sewing patterns), garments
// from GarmentCode pattern files, seams, pins and attachments (scene_json.cpp reads the rest).
#include <filesystem>
#include <optional>

#include "raycloth/scene.h"
#include "scene/garmentcode.h"
#include "scene/json_text.h"
#include "scene/scene_reader.h"

namespace raycloth::scene_json {

// A panel is a rectangle (size and resolution), a mesh (an OBJ file) or a sewing pattern.
PanelDef SceneReader::panel(const json& j, const std::string& ptr) const {
  PanelDef pd;
  object(j, ptr, {"name", "material", "size", "resolution", "mesh", "pattern", "position", "rotation", "scale", "warp"});
  required(j, ptr, "name", [&](const json& v, const std::string& p) { pd.name = string(v, p); });
  optional(j, ptr, "warp", [&](const json& v, const std::string& p) { pd.warp = number_f(v, p); });
  required(j, ptr, "material", [&](const json& v, const std::string& p) { pd.material = string(v, p); });
  const bool mesh = j.contains("mesh"), pattern = j.contains("pattern");
  if (mesh && pattern) fail(ptr, "a panel is a rectangle (size, resolution), a mesh or a pattern, not both mesh and pattern");
  if (mesh || pattern)
    for (const char* k : {"size", "resolution"})
      if (j.contains(k))
        fail(ptr + "/" + k, std::string("only for rectangle panels; this one is a ") + (mesh ? "mesh" : "pattern"));
  if (mesh) {
    pd.shape = PanelShape::Mesh;
    required(j, ptr, "mesh", [&](const json& v, const std::string& p) { pd.mesh_file = file_path(v, p); });
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

PatternDef SceneReader::pattern_def(const json& j, const std::string& ptr) const {
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
void SceneReader::garment(const json& j, const std::string& ptr, SceneDef& s) const {
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
  required(j, ptr, "garmentcode", [&](const json& v, const std::string& p) { file = file_path(v, p); });
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
void SceneReader::path_fields(const json& j, const std::string& ptr, EdgeRef& e, std::optional<std::array<int, 2>>* range) const {
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

EdgeRef SceneReader::edge_ref(const json& j, const std::string& ptr) const {
  EdgeRef e;
  object(j, ptr, {"panel", "edge", "segment", "path"});
  required(j, ptr, "panel", [&](const json& v, const std::string& p) { e.panel = string(v, p); });
  path_fields(j, ptr, e, nullptr);
  return e;
}

SeamDef SceneReader::seam(const json& j, const std::string& ptr) const {
  SeamDef sd;
  object(j, ptr, {"a", "b", "reverse", "stiffness", "weld_at_start"});
  required(j, ptr, "a", [&](const json& v, const std::string& p) { sd.a = edge_ref(v, p); });
  required(j, ptr, "b", [&](const json& v, const std::string& p) { sd.b = edge_ref(v, p); });
  optional(j, ptr, "reverse", [&](const json& v, const std::string& p) { sd.reverse = boolean(v, p); });
  optional(j, ptr, "stiffness", [&](const json& v, const std::string& p) { sd.stiffness = number_f(v, p); });
  optional(j, ptr, "weld_at_start", [&](const json& v, const std::string& p) { sd.weld_at_start = boolean(v, p); });
  return sd;
}

PinDef SceneReader::pin(const json& j, const std::string& ptr) const {
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

AttachmentDef SceneReader::attachment(const json& j, const std::string& ptr) const {
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

}  // namespace raycloth::scene_json
