// The checks every scene goes through, whether read from a file (scene_json.cpp) or built in code:
// values and cross references, one validator per section, in the order of the scene's sections, so
// that the first problem reported is the same as before the split. Every error is an InputError
// naming the scene's file, the JSON pointer of the field and the reason.
#include <cmath>
#include <cstdint>
#include <map>
#include <string>

#include "fabric/measured.h"
#include "raycloth/error.h"
#include "raycloth/scene.h"
#include "scene/mesh.h"
#include "scene/scene_reader.h"

namespace raycloth {

namespace {

using scene_json::num;
using scene_json::num_list;
using scene_json::kMaxVertices;

// The scene being checked and the checks its sections share; each fails with the scene's file.
struct Checks {
  const SceneDef& s;

  [[noreturn]] void fail(const std::string& field, const std::string& reason) const {
    throw InputError(s.source, field, reason);
  }
  void positive(double v, const std::string& field) const {
    if (!(v > 0)) fail(field, "must be positive (got " + num(v) + ")");
  }
  void non_negative(double v, const std::string& field) const {
    if (!(v >= 0)) fail(field, "must not be negative (got " + num(v) + ")");
  }
  void finite3(const Float3& v, const std::string& field) const {
    for (float x : v)
      if (!std::isfinite(x)) fail(field, "must be finite (got " + num_list(v) + ")");
  }
  void positive3(const Float3& v, const std::string& field) const {
    for (float x : v)
      if (!(x > 0)) fail(field, "all must be positive (got " + num_list(v) + ")");
  }
  void transform(const TransformDef& t, const std::string& ptr) const {
    finite3(t.position, ptr + "/position");
    finite3(t.rotation, ptr + "/rotation");
    positive3(t.scale, ptr + "/scale");
  }
  // The panel named `name`; fails at `field` when there is none.
  const PanelDef& panel(const std::string& name, const std::string& field) const {
    for (const auto& pd : s.panels)
      if (pd.name == name) return pd;
    fail(field, "unknown panel '" + name + "'");
  }
};

// The pointer of entry i of a list: "/panels/3".
std::string idx(const char* list, size_t i) { return std::string("/") + list + "/" + std::to_string(i); }

// Vertices along an edge: left/right run along v, bottom/top along u.
int edge_vertex_count(const PanelDef& p, const std::string& edge) {
  return edge == "left" || edge == "right" ? p.resolution_v : p.resolution_u;
}

void validate_time_and_collision(const Checks& c) {
  const SceneDef& s = c.s;
  c.positive(s.time.dt, "/time/dt");
  if (s.time.iterations < 1 || s.time.iterations > 1000)
    c.fail("/time/iterations", "must be between 1 and 1000 (got " + std::to_string(s.time.iterations) + ")");
  c.positive(s.time.tolerance, "/time/tolerance");
  c.positive(s.time.duration, "/time/duration");
  c.positive(s.time.fps, "/time/fps");
  c.finite3(s.gravity, "/gravity");
  c.positive(s.collision.tolerance, "/collision/tolerance");
  c.non_negative(s.collision.thickness, "/collision/thickness");
  c.non_negative(s.collision.friction, "/collision/friction");
}

void validate_materials(const Checks& c) {
  const SceneDef& s = c.s;
  for (size_t i = 0; i < s.materials.size(); ++i) {
    const MaterialDef& m = s.materials[i];
    const std::string p = idx("materials", i);
    if (m.name.empty()) c.fail(p + "/name", "must not be empty");
    for (size_t k = 0; k < i; ++k)
      if (s.materials[k].name == m.name)
        c.fail(p + "/name", "duplicate material name '" + m.name + "' (also " + idx("materials", k) + ")");
    c.positive(m.density, p + "/density");
    c.positive(m.stretch, p + "/stretch");
    c.non_negative(m.shear, p + "/shear");
    c.non_negative(m.bend, p + "/bend");
    c.non_negative(m.damping, p + "/damping");
    c.non_negative(m.spring_damping, p + "/spring_damping");
    if (m.bending == MaterialDef::Bending::Hinges && m.measured.empty())
      c.fail(p + "/bending", "hinges take their bending rigidity from a measured fabric (\"fabric\": one of " +
                                 fabric::measured_names() + ")");
    if (m.bending == MaterialDef::Bending::Hinges && m.bend_set)
      c.fail(p + "/bend", "is the stiffness of bend springs (N/m); with \"bending\": \"hinges\" the measured fabric gives the bending");
    if (m.fabric) {
      // Measurements that no fabric can have: zero, negative, not a number.
      const std::pair<const char*, double> kes[] = {{"W", m.fabric->W}, {"B", m.fabric->B}, {"G", m.fabric->G}, {"EMT", m.fabric->EMT}};
      for (const auto& [key, value] : kes)
        if (!(value > 0) || !std::isfinite(value))
          c.fail(p + "/kes/" + key, "must be a positive measurement (got " + num(value) + ")");
    }
  }
}

// Input that would not fit in memory or never end is refused with its reason (and a limit) rather
// than running out of memory or time.
void validate_run_length(const Checks& c) {
  const TimeDef& t = c.s.time;
  if (t.duration / t.dt > 1e12)
    c.fail("/time/dt", "the run would take more than 1e12 steps (duration " + num(t.duration) + " s, dt " + num(t.dt) + " s)");
  if (t.duration * t.fps > 1e6)
    c.fail("/time/fps", "the run would write more than 1000000 frames (duration " + num(t.duration) + " s, fps " + num(t.fps) + ")");
}

// A rectangle's size and resolution, with the cloth's running vertex count.
void validate_rectangle(const Checks& c, const PanelDef& pd, const std::string& p, int64_t& cloth_vertices) {
  if (!(pd.width > 0 && pd.height > 0))
    c.fail(p + "/size", "both must be positive (got " + num_list(std::array<float, 2>{pd.width, pd.height}) + ")");
  const std::array<int, 2> res{pd.resolution_u, pd.resolution_v};
  if (res[0] < 2 || res[1] < 2) c.fail(p + "/resolution", "both must be at least 2 (got " + num_list(res) + ")");
  // Far below 32-bit vertex ids: a bigger cloth would not fit in memory or finish a step soon.
  if (int64_t(res[0]) * res[1] > kMaxVertices)
    c.fail(p + "/resolution", "too many vertices (got " + num_list(res) + ", at most " + std::to_string(kMaxVertices) + " in all)");
  cloth_vertices += int64_t(res[0]) * res[1];
  if (cloth_vertices > kMaxVertices)
    c.fail(p + "/resolution", "the panels have too many vertices in all (at most " + std::to_string(kMaxVertices) + ")");
}

void validate_pattern(const Checks& c, const PatternDef& pat, const std::string& p) {
  if (pat.outline.size() < 3)
    c.fail(p + "/pattern/outline", "needs at least 3 segments (got " + std::to_string(pat.outline.size()) + ")");
  c.positive(pat.edge_length, p + "/pattern/edge_length");
  if (pat.wrap_radius) c.positive(*pat.wrap_radius, p + "/pattern/wrap_radius");
  for (size_t k = 0; k < pat.outline.size(); ++k) {
    const std::string q = p + "/pattern/outline/" + std::to_string(k);
    if (!std::isfinite(pat.outline[k].from[0]) || !std::isfinite(pat.outline[k].from[1])) c.fail(q + "/from", "must be finite");
    for (size_t m = 0; m < k; ++m)
      if (!pat.outline[k].name.empty() && pat.outline[m].name == pat.outline[k].name)
        c.fail(q + "/name", "duplicate segment name '" + pat.outline[k].name + "' (also " + p + "/pattern/outline/" +
                                std::to_string(m) + ")");
  }
}

void validate_panels(const Checks& c) {
  const SceneDef& s = c.s;
  int64_t cloth_vertices = 0;
  if (s.panels.empty()) c.fail("/panels", "the scene needs at least one panel");
  for (size_t i = 0; i < s.panels.size(); ++i) {
    const PanelDef& pd = s.panels[i];
    const std::string p = idx("panels", i);
    if (pd.name.empty()) c.fail(p + "/name", "must not be empty");
    for (size_t k = 0; k < i; ++k)
      if (s.panels[k].name == pd.name)
        c.fail(p + "/name", "duplicate panel name '" + pd.name + "' (also " + idx("panels", k) + ")");
    bool known = false;
    for (const auto& m : s.materials) known = known || m.name == pd.material;
    if (!known) c.fail(p + "/material", "unknown material '" + pd.material + "'");
    switch (pd.shape) {
      case PanelShape::Rectangle: validate_rectangle(c, pd, p, cloth_vertices); break;
      case PanelShape::Mesh:
        if (pd.mesh_file.empty()) c.fail(p + "/mesh", "a mesh panel needs an OBJ file");
        if (const auto why = input_file_problem(pd.mesh_file); !why.empty()) c.fail(p + "/mesh", "OBJ file '" + pd.mesh_file + "' " + why);
        break;
      case PanelShape::Pattern: validate_pattern(c, pd.pattern, p); break;
    }
    c.transform(pd.transform, p);
  }
}

// A path must suit its panel: an edge of a rectangle, a segment of a pattern, a path of a mesh.
void validate_path(const Checks& c, const EdgeRef& r, const PanelDef& pd, const std::string& p) {
  const int kinds = int(!r.edge.empty()) + int(!r.segment.empty()) + int(r.path.has_value());
  if (kinds != 1) c.fail(p, "needs exactly one of edge, segment or path");
  if (!r.edge.empty()) {
    if (pd.shape != PanelShape::Rectangle)
      c.fail(p + "/edge", "panel '" + pd.name + "' is not a rectangle; name an outline segment or a path");
    if (!scene_json::is_edge(r.edge)) c.fail(p + "/edge", scene_json::bad_edge(r.edge));
  }
  if (!r.segment.empty()) {
    if (pd.shape != PanelShape::Pattern) c.fail(p + "/segment", "panel '" + pd.name + "' is not a pattern");
    bool known = false;
    std::string names;
    for (const auto& seg : pd.pattern.outline) {
      known = known || seg.name == r.segment;
      if (!seg.name.empty()) names += (names.empty() ? "" : ", ") + seg.name;
    }
    if (!known)
      c.fail(p + "/segment", "panel '" + pd.name + "' has no segment '" + r.segment + "' (it has " +
                                 (names.empty() ? std::string("no named segments") : names) + ")");
  }
  if (r.path && pd.shape != PanelShape::Mesh) c.fail(p + "/path", "panel '" + pd.name + "' is not a mesh panel");
}

void validate_seams(const Checks& c) {
  const SceneDef& s = c.s;
  for (size_t i = 0; i < s.seams.size(); ++i) {
    const SeamDef& sd = s.seams[i];
    const std::string p = idx("seams", i);
    const PanelDef& pa = c.panel(sd.a.panel, p + "/a/panel");
    const PanelDef& pb = c.panel(sd.b.panel, p + "/b/panel");
    validate_path(c, sd.a, pa, p + "/a");
    validate_path(c, sd.b, pb, p + "/b");
    if (pa.shape == PanelShape::Rectangle && pb.shape == PanelShape::Rectangle) {
      const int na = edge_vertex_count(pa, sd.a.edge), nb = edge_vertex_count(pb, sd.b.edge);
      if (na != nb)
        c.fail(p, "edge '" + sd.a.edge + "' of panel '" + sd.a.panel + "' has " + std::to_string(na) +
                      " vertices but edge '" + sd.b.edge + "' of panel '" + sd.b.panel + "' has " + std::to_string(nb));
    }
    c.positive(sd.stiffness, p + "/stiffness");
  }
}

void validate_pins(const Checks& c) {
  const SceneDef& s = c.s;
  for (size_t i = 0; i < s.pins.size(); ++i) {
    const PinDef& pd = s.pins[i];
    const std::string p = idx("pins", i);
    const PanelDef& panel = c.panel(pd.panel, p + "/panel");
    const int kinds = int(!pd.corner.empty()) + int(!pd.edge.empty()) + int(!pd.segment.empty()) + int(pd.range.has_value());
    if (kinds != 1) c.fail(p, "a pin needs exactly one of corner, edge, segment or range");
    if (!pd.corner.empty() && !scene_json::is_corner(pd.corner)) c.fail(p + "/corner", scene_json::bad_corner(pd.corner));
    if (!pd.corner.empty() && panel.shape != PanelShape::Rectangle)
      c.fail(p + "/corner", "panel '" + panel.name + "' is not a rectangle; pin a segment or a range");
    if (!pd.edge.empty() || !pd.segment.empty()) validate_path(c, EdgeRef{pd.panel, pd.edge, pd.segment, std::nullopt}, panel, p);
    if (pd.range && panel.shape == PanelShape::Rectangle) {
      const auto [first, last] = *pd.range;
      const int64_t count = int64_t(panel.resolution_u) * panel.resolution_v;
      if (first < 0 || last < first || last >= count)
        c.fail(p + "/range", "range [" + std::to_string(first) + ", " + std::to_string(last) + "] is outside panel '" +
                                 panel.name + "' (vertices 0 to " + std::to_string(count - 1) + ")");
    }
  }
}

// Garments placed on a body: the body exists, and no seam joins two garments (or a garment and the
// scene's own panels), since each is fitted on its own.
void validate_garment_fits(const Checks& c) {
  const SceneDef& s = c.s;
  for (const GarmentFitDef& g : s.garment_fits) {
    bool known = false;
    std::string names;
    for (const ObstacleDef& o : s.obstacles) {
      known = known || o.name == g.body;
      names += (names.empty() ? "'" : ", '") + o.name + "'";
    }
    if (!known)
      c.fail(g.field + "/body", "no obstacle named '" + g.body + "' (the scene has " + (names.empty() ? "none" : names) + ")");
  }
  if (s.garment_fits.empty()) return;
  // Which garment (garments[] entry) each panel came from, -1 for the scene's own panels.
  std::map<std::string, int> garment_of;
  for (size_t g = 0; g < s.garment_fits.size(); ++g)
    for (uint32_t k = 0; k < s.garment_fits[g].num_panels; ++k)
      garment_of[s.panels[s.garment_fits[g].first_panel + k].name] = int(g);
  for (size_t i = 0; i < s.seams.size(); ++i) {
    const auto a = garment_of.find(s.seams[i].a.panel), b = garment_of.find(s.seams[i].b.panel);
    const int ga = a == garment_of.end() ? -1 : a->second, gb = b == garment_of.end() ? -1 : b->second;
    if (ga != gb)
      c.fail(idx("seams", i), "joins panel '" + s.seams[i].a.panel + "' of " +
                                  (ga < 0 ? std::string("the scene") : "garment " + s.garment_fits[ga].field) + " to panel '" +
                                  s.seams[i].b.panel + "' of " +
                                  (gb < 0 ? std::string("the scene") : "garment " + s.garment_fits[gb].field) +
                                  ": garments placed on a body are fitted separately, so a seam cannot join them");
  }
}

void validate_sewing(const Checks& c) {
  c.non_negative(c.s.sewing.close_time, "/sewing/close_time");
  if (c.s.sewing.gravity_waits == true && c.s.sewing.ease_gravity == false)
    c.fail("/sewing/gravity_waits", "needs ease_gravity: with ease_gravity false gravity acts from the start and does not wait");
  if (!c.s.sewing.close_tolerance) return;
  const double tol = *c.s.sewing.close_tolerance, thickness = c.s.collision.thickness;
  c.positive(tol, "/sewing/close_tolerance");
  // The two sides of an open stitch are cloth to each other: the contact holds them a thickness apart.
  if (tol < thickness)
    c.fail("/sewing/close_tolerance", "must be at least the collision thickness " + num(thickness) + " m (got " + num(tol) +
                                          "): the contact keeps the two sides of a stitch that far apart, so it would never close");
}

void validate_attachments(const Checks& c) {
  const SceneDef& s = c.s;
  for (size_t i = 0; i < s.attachments.size(); ++i) {
    const AttachmentDef& a = s.attachments[i];
    const std::string p = idx("attachments", i);
    const PanelDef& panel = c.panel(a.panel, p + "/panel");
    const int kinds = int(!a.edge.empty()) + int(!a.segment.empty()) + int(a.range.has_value());
    if (kinds != 1) c.fail(p, "needs exactly one of edge, segment or range");
    if (!a.range) validate_path(c, EdgeRef{a.panel, a.edge, a.segment, std::nullopt}, panel, p);
    bool known = false;
    for (const auto& od : s.obstacles) known = known || od.name == a.obstacle;
    if (!known) {
      std::string names;
      for (const auto& od : s.obstacles) names += (names.empty() ? "'" : ", '") + od.name + "'";
      c.fail(p + "/obstacle", "unknown obstacle '" + a.obstacle + "' (the scene has " + (names.empty() ? "none" : names) + ")");
    }
    c.positive(a.stiffness, p + "/stiffness");
    c.non_negative(a.damping, p + "/damping");
    if (!std::isfinite(a.lift)) c.fail(p + "/lift", "must be finite");
  }
}

// An obstacle's shape fields for its type: a sphere's tessellation, a box's or plane's size, the
// file of a mesh or a skinned body (and a skinned body's animation settings).
void validate_obstacle_shape(const Checks& c, const ObstacleDef& od, const std::string& p) {
  switch (od.type) {
    case ObstacleType::UvSphere:
      c.positive(od.radius, p + "/radius");
      if (od.slices < 3) c.fail(p + "/slices", "must be at least 3 (got " + std::to_string(od.slices) + ")");
      if (od.stacks < 2) c.fail(p + "/stacks", "must be at least 2 (got " + std::to_string(od.stacks) + ")");
      if (int64_t(od.slices) * od.stacks > kMaxVertices)
        c.fail(p + "/slices", "too many vertices: slices x stacks is " + std::to_string(int64_t(od.slices) * od.stacks) +
                                  ", at most " + std::to_string(kMaxVertices));
      break;
    case ObstacleType::Box: c.positive3(od.size, p + "/size"); break;
    case ObstacleType::Plane:
      if (!(od.size[0] > 0 && od.size[2] > 0))
        c.fail(p + "/size", "x and z must be positive (got " + num_list(od.size) + ")");
      break;
    case ObstacleType::Mesh:
      if (od.file.empty()) c.fail(p + "/file", "a mesh obstacle needs an OBJ file");
      if (const auto why = input_file_problem(od.file); !why.empty()) c.fail(p + "/file", "OBJ file '" + od.file + "' " + why);
      break;
    case ObstacleType::Skinned:
      if (od.file.empty()) c.fail(p + "/file", "a skinned obstacle needs a glTF file");
      if (const auto why = input_file_problem(od.file); !why.empty()) c.fail(p + "/file", "glTF file '" + od.file + "' " + why);
      if (!(std::isfinite(od.speed) && od.speed >= 0.0f))
        c.fail(p + "/speed", "must be a number >= 0");
      if (od.offset && !std::isfinite(*od.offset)) c.fail(p + "/offset", "must be finite");
      c.non_negative(od.blend_in, p + "/blend_in");
      c.non_negative(od.hold, p + "/hold");
      break;
  }
}

void validate_obstacles(const Checks& c) {
  const SceneDef& s = c.s;
  for (size_t i = 0; i < s.obstacles.size(); ++i) {
    const ObstacleDef& od = s.obstacles[i];
    const std::string p = idx("obstacles", i);
    if (!od.name.empty())
      for (size_t k = 0; k < i; ++k)
        if (s.obstacles[k].name == od.name)
          c.fail(p + "/name", "duplicate obstacle name '" + od.name + "' (also " + idx("obstacles", k) + ")");
    validate_obstacle_shape(c, od, p);
    c.transform(od.transform, p);
    if (od.motion) {
      c.finite3(od.motion->velocity, p + "/motion/velocity");
      c.finite3(od.motion->angular_velocity, p + "/motion/angular_velocity");
      c.non_negative(od.motion->start, p + "/motion/start");
    }
  }
}

}  // namespace

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
  const Checks c{s};
  validate_time_and_collision(c);
  validate_materials(c);
  validate_run_length(c);
  validate_panels(c);
  validate_seams(c);
  validate_pins(c);
  validate_garment_fits(c);
  validate_sewing(c);
  validate_attachments(c);
  validate_output(s.output, s.source);
  validate_obstacles(c);
}

}  // namespace raycloth
