#include "scene/garmentcode.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "raycloth/error.h"
#include "scene/json_text.h"
#include "scene/mesh.h"
#include "scene/pattern.h"
#include "scene/transform.h"

namespace raycloth {

namespace {

using json = nlohmann::ordered_json;

// Euler angles (degrees) of R = Rz·Ry·Rx, the convention of TransformDef::rotation.
Float3 euler_xyz_degrees(const Mat3& r) {
  const double deg = 180.0 / M_PI;
  const double sy = std::clamp(-double(r.r2.x), -1.0, 1.0);
  const double ry = std::asin(sy);
  double rx, rz;
  if (std::abs(sy) < 0.999999) {
    rx = std::atan2(double(r.r2.y), double(r.r2.z));
    rz = std::atan2(double(r.r1.x), double(r.r0.x));
  } else {  // gimbal lock: only rx - rz (or rx + rz) is defined; take rz = 0
    rz = 0;
    rx = std::atan2(sy > 0 ? double(r.r0.y) : -double(r.r0.y), double(r.r1.y));
  }
  return {float(rx * deg), float(ry * deg), float(rz * deg)};
}

Mat3 mat_mul(const Mat3& a, const Mat3& b) {
  auto col = [&](int c) {
    return c == 0 ? make_vec3(b.r0.x, b.r1.x, b.r2.x) : c == 1 ? make_vec3(b.r0.y, b.r1.y, b.r2.y) : make_vec3(b.r0.z, b.r1.z, b.r2.z);
  };
  Mat3 m;
  const Vec3 c0 = col(0), c1 = col(1), c2 = col(2);
  m.r0 = make_vec3(dot(a.r0, c0), dot(a.r0, c1), dot(a.r0, c2));
  m.r1 = make_vec3(dot(a.r1, c0), dot(a.r1, c1), dot(a.r1, c2));
  m.r2 = make_vec3(dot(a.r2, c0), dot(a.r2, c1), dot(a.r2, c2));
  return m;
}

class GcReader {
 public:
  GcReader(std::string file, const GarmentCodeOptions& opt) : file_(std::move(file)), opt_(opt) {}

  GarmentCodeGarment read(const json& j) {
    if (!j.is_object()) fail("", std::string("expected an object, got ") + j.type_name());
    double units = 100.0;
    if (auto p = j.find("properties"); p != j.end()) {
      if (!p->is_object()) fail("/properties", std::string("expected an object, got ") + p->type_name());
      if (auto u = p->find("units_in_meter"); u != p->end()) {
        units = number(*u, "/properties/units_in_meter");
        if (!(units > 0)) fail("/properties/units_in_meter", "must be a positive number");
      }
      if (auto c = p->find("curvature_coords"); c != p->end()) {
        const std::string coords = string(*c, "/properties/curvature_coords");
        if (coords != "relative") fail("/properties/curvature_coords", "only 'relative' is read (got '" + coords + "')");
      }
    }
    const auto pat = j.find("pattern");
    if (pat == j.end()) fail("/pattern", "missing required field");
    if (!pat->is_object()) fail("/pattern", std::string("expected an object, got ") + pat->type_name());
    const auto panels = pat->find("panels");
    if (panels == pat->end()) fail("/pattern/panels", "missing required field");
    if (!panels->is_object() || panels->empty()) fail("/pattern/panels", "expected an object of panels by name");
    const double to_m = double(opt_.scale) / units;
    const Mat3 garment_rot = rotation_xyz_degrees(opt_.rotation);

    GarmentCodeGarment g;
    for (const auto& [name, pj] : panels->items()) {
      const std::string p = "/pattern/panels/" + json_pointer_token(name);
      g.file_panel_names.push_back(name);
      g.panels.push_back(panel(pj, p, name, to_m, garment_rot));
      edge_counts_[name] = g.panels.back().pattern.outline.size();
    }
    if (auto st = pat->find("stitches"); st != pat->end()) {
      if (!st->is_array()) fail("/pattern/stitches", std::string("expected an array, got ") + st->type_name());
      std::map<std::pair<std::string, int>, size_t> used;
      for (size_t i = 0; i < st->size(); ++i) {
        const json& s = (*st)[i];
        const std::string p = "/pattern/stitches/" + std::to_string(i);
        if (!s.is_array() || s.size() < 2 || s.size() > 3)
          fail(p, "expected [side, side] or [side, side, \"right_wrong\"]");
        bool right_wrong = false;
        if (s.size() == 3) {
          if (!s[2].is_string() || s[2].get<std::string>() != "right_wrong")
            fail(p + "/2", "expected \"right_wrong\"");
          right_wrong = true;
        }
        SeamDef sd;
        EdgeRef* ref[2] = {&sd.a, &sd.b};
        for (int k = 0; k < 2; ++k) {
          const std::string q = p + "/" + std::to_string(k);
          const json& side = s[k];
          if (!side.is_object()) fail(q, std::string("expected an object with panel and edge, got ") + side.type_name());
          const auto pn = side.find("panel");
          if (pn == side.end()) fail(q + "/panel", "missing required field");
          const std::string pname = string(*pn, q + "/panel");
          const auto it = edge_counts_.find(pname);
          if (it == edge_counts_.end()) fail(q + "/panel", "no panel '" + pname + "'");
          const auto en = side.find("edge");
          if (en == side.end()) fail(q + "/edge", "missing required field");
          const int e = integer(*en, q + "/edge");
          if (e < 0 || size_t(e) >= it->second)
            fail(q + "/edge", "panel '" + pname + "' has no edge " + std::to_string(e) + " (it has " +
                                  std::to_string(it->second) + ")");
          const auto [at, fresh] = used.emplace(std::make_pair(pname, e), i);
          if (!fresh)
            fail(q, "edge " + std::to_string(e) + " of panel '" + pname + "' is already in stitch " +
                        std::to_string(at->second));
          ref[k]->panel = opt_.prefix + pname;
          ref[k]->segment = "e" + std::to_string(e);
        }
        sd.reverse = !right_wrong;
        sd.stiffness = opt_.seam_stiffness;
        g.seams.push_back(sd);
      }
    }
    return g;
  }

  [[noreturn]] void fail(const std::string& field, const std::string& reason) const {
    throw InputError(file_, field, reason);
  }

 private:
  double number(const json& j, const std::string& p) const {
    if (!j.is_number()) fail(p, std::string("expected a number, got ") + j.type_name());
    const double v = j.get<double>();
    if (!std::isfinite(v)) fail(p, "must be finite");
    return v;
  }
  int integer(const json& j, const std::string& p) const {
    if (!j.is_number_integer()) fail(p, std::string("expected an integer, got ") + j.type_name());
    const auto v = j.get<int64_t>();
    if (v < -(int64_t(1) << 30) || v > (int64_t(1) << 30)) fail(p, "is out of range");
    return int(v);
  }
  std::string string(const json& j, const std::string& p) const {
    if (!j.is_string()) fail(p, std::string("expected a string, got ") + j.type_name());
    return j.get<std::string>();
  }
  bool flag(const json& j, const std::string& p) const {
    if (j.is_boolean()) return j.get<bool>();
    if (j.is_number()) return j.get<double>() != 0;
    fail(p, std::string("expected true or false, got ") + j.type_name());
  }
  std::array<double, 2> pair(const json& j, const std::string& p) const {
    if (!j.is_array() || j.size() != 2) fail(p, "expected 2 numbers");
    return {number(j[0], p + "/0"), number(j[1], p + "/1")};
  }
  Float3 triple(const json& j, const std::string& p) const {
    if (!j.is_array() || j.size() != 3) fail(p, "expected 3 numbers");
    return {float(number(j[0], p + "/0")), float(number(j[1], p + "/1")), float(number(j[2], p + "/2"))};
  }

  PanelDef panel(const json& j, const std::string& p, const std::string& name, double to_m, const Mat3& garment_rot) const {
    if (!j.is_object()) fail(p, std::string("expected an object, got ") + j.type_name());
    const auto vj = j.find("vertices");
    if (vj == j.end()) fail(p + "/vertices", "missing required field");
    if (!vj->is_array() || vj->size() < 3) fail(p + "/vertices", "expected an array of at least 3 points");
    std::vector<std::array<double, 2>> v;
    for (size_t i = 0; i < vj->size(); ++i) v.push_back(pair((*vj)[i], p + "/vertices/" + std::to_string(i)));
    const auto ej = j.find("edges");
    if (ej == j.end()) fail(p + "/edges", "missing required field");
    if (!ej->is_array() || ej->size() < 2) fail(p + "/edges", "expected an array of at least 2 edges");

    const GarmentCodePanelOptions* po = nullptr;
    if (auto it = opt_.panels.find(name); it != opt_.panels.end()) po = &it->second;
    PanelDef pd;
    pd.name = opt_.prefix + name;
    pd.material = po && po->material ? *po->material : opt_.material;
    pd.shape = PanelShape::Pattern;
    pd.pattern.edge_length = po && po->edge_length ? *po->edge_length : opt_.edge_length;

    const size_t n = ej->size();
    std::vector<std::array<int, 2>> ends(n);
    for (size_t k = 0; k < n; ++k) {
      const std::string q = p + "/edges/" + std::to_string(k);
      const json& e = (*ej)[k];
      if (!e.is_object()) fail(q, std::string("expected an object, got ") + e.type_name());
      const auto ep = e.find("endpoints");
      if (ep == e.end()) fail(q + "/endpoints", "missing required field");
      if (!ep->is_array() || ep->size() != 2) fail(q + "/endpoints", "expected 2 vertex numbers");
      for (int s = 0; s < 2; ++s) {
        ends[k][s] = integer((*ep)[s], q + "/endpoints/" + std::to_string(s));
        if (ends[k][s] < 0 || size_t(ends[k][s]) >= v.size())
          fail(q + "/endpoints/" + std::to_string(s), "no vertex " + std::to_string(ends[k][s]) + " (the panel has " +
                                                          std::to_string(v.size()) + ")");
      }
    }
    for (size_t k = 0; k < n; ++k)
      if (ends[k][1] != ends[(k + 1) % n][0])
        fail(p + "/edges/" + std::to_string((k + 1) % n) + "/endpoints/0",
             "the edges do not form one closed loop: edge " + std::to_string(k) + " ends at vertex " +
                 std::to_string(ends[k][1]) + " but edge " + std::to_string((k + 1) % n) + " starts at vertex " +
                 std::to_string(ends[(k + 1) % n][0]));

    for (size_t k = 0; k < n; ++k) {
      const std::string q = p + "/edges/" + std::to_string(k);
      const json& e = (*ej)[k];
      OutlineSegment seg;
      seg.name = "e" + std::to_string(k);
      const auto a = v[ends[k][0]], b = v[ends[k][1]];
      seg.from = {float(a[0] * to_m), float(a[1] * to_m)};
      auto control = [&](const std::array<double, 2>& uv) -> std::array<float, 2> {
        // start + u (end - start) + v perp, perp = (-dy, dx), then to metres
        const double dx = b[0] - a[0], dy = b[1] - a[1];
        return {float((a[0] + uv[0] * dx - uv[1] * dy) * to_m), float((a[1] + uv[0] * dy + uv[1] * dx) * to_m)};
      };
      if (auto c = e.find("curvature"); c != e.end() && c->is_array()) {
        // The older files' form: a bare [u, v], one relative quadratic control point.
        const std::string cp = q + "/curvature";
        if (c->size() != 2)
          fail(cp, "a curvature list is one relative control point [u, v] (got " + std::to_string(c->size()) +
                       (c->size() == 1 ? " value)" : " values)"));
        seg.control = control({number((*c)[0], cp + "/0"), number((*c)[1], cp + "/1")});
      } else if (c != e.end()) {
        const std::string cp = q + "/curvature";
        if (!c->is_object())
          fail(cp, std::string("expected an object with type and params or a [u, v] list, got ") + c->type_name());
        const auto t = c->find("type");
        if (t == c->end()) fail(cp + "/type", "missing required field");
        const std::string type = string(*t, cp + "/type");
        const auto pr = c->find("params");
        if (type != "quadratic" && type != "cubic" && type != "circle")
          fail(cp + "/type", "unknown curvature type '" + type + "' (expected quadratic, cubic or circle)");
        if (pr == c->end()) fail(cp + "/params", "missing required field");
        if (!pr->is_array()) fail(cp + "/params", std::string("expected an array, got ") + pr->type_name());
        if (type == "quadratic") {
          if (pr->size() != 1) fail(cp + "/params", "a quadratic curve has 1 control point (got " + std::to_string(pr->size()) + ")");
          seg.control = control(pair((*pr)[0], cp + "/params/0"));
        } else if (type == "cubic") {
          if (pr->size() != 2) fail(cp + "/params", "a cubic curve has 2 control points (got " + std::to_string(pr->size()) + ")");
          seg.control = control(pair((*pr)[0], cp + "/params/0"));
          seg.control2 = control(pair((*pr)[1], cp + "/params/1"));
        } else {
          if (pr->size() != 3) fail(cp + "/params", "a circle arc has [radius, large_arc, right] (got " + std::to_string(pr->size()) + " values)");
          const double r = number((*pr)[0], cp + "/params/0");
          if (!(r > 0)) fail(cp + "/params/0", "the radius must be positive");
          OutlineArc arc;
          arc.radius = float(r * to_m);
          arc.large = flag((*pr)[1], cp + "/params/1");
          arc.ccw = flag((*pr)[2], cp + "/params/2");  // "right": bulges to the right of start -> end
          seg.arc = arc;
        }
      }
      pd.pattern.outline.push_back(seg);
    }
    for (size_t k = 0; k < n; ++k) {
      const auto& a = v[ends[k][0]];
      const auto& b = v[ends[k][1]];
      if (a[0] == b[0] && a[1] == b[1])
        fail(p + "/edges/" + std::to_string(k), "the edge has no length (both ends at vertex " + std::to_string(ends[k][0]) + ")");
    }
    if (!outline_is_simple(pd.pattern)) fail(p + "/edges", "the outline crosses or touches itself");

    // Placement: x = R_g (R_p p + t_p) + t_g with p and t_p in metres (scaled).
    Float3 t{0, 0, 0}, r{0, 0, 0};
    if (auto tj = j.find("translation"); tj != j.end()) t = triple(*tj, p + "/translation");
    if (auto rj = j.find("rotation"); rj != j.end()) r = triple(*rj, p + "/rotation");
    const Mat3 rot = mat_mul(garment_rot, rotation_xyz_degrees(r));
    const Vec3 tp = mul(garment_rot, make_vec3(float(t[0] * to_m), float(t[1] * to_m), float(t[2] * to_m)));
    pd.transform.rotation = euler_xyz_degrees(rot);
    pd.transform.position = {tp.x + opt_.position[0], tp.y + opt_.position[1], tp.z + opt_.position[2]};
    if (po)
      for (int k = 0; k < 3; ++k) pd.transform.position[k] += po->offset[k];
    return pd;
  }

  std::string file_;
  const GarmentCodeOptions& opt_;
  std::map<std::string, size_t> edge_counts_;
};

}  // namespace

GarmentCodeGarment parse_garmentcode(const std::string& text, const std::string& origin, const GarmentCodeOptions& opt) {
  json j;
  try {
    j = json::parse(text, nullptr, /*allow_exceptions=*/true, /*ignore_comments=*/true);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(origin, "", without_json_exception_tags(e.what()));
  }
  return GcReader(origin, opt).read(j);
}

GarmentCodeGarment read_garmentcode(const std::string& path, const GarmentCodeOptions& opt) {
  if (const std::string why = input_file_problem(path); !why.empty())
    throw InputError(path, "", "GarmentCode file " + why);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", std::string("cannot open GarmentCode file: ") + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  return parse_garmentcode(text.str(), path, opt);
}

}  // namespace raycloth
