#include "lab/fabric_tests.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>

#include <unistd.h>

#include "fabric/kes.h"
#include "fabric/measured.h"
#include "fabric/stiffening.h"
#include "raycloth/error.h"
#include "raycloth/simulator.h"
#include "sim/membrane.h"
#include "sim/model.h"

namespace raycloth::lab {

using namespace fabric;

namespace {

// The test's time settings, the material's damping and no collisions: nothing in these tests meets
// anything but its clamps.
void set_stepping(SceneDef& s, const Stepping& st) {
  s.collision.cloth_cloth = false;
  s.materials.at(0).damping = float(st.damping);
  s.time.integrator = st.integrator;
  s.time.iterations = st.iterations;
  s.time.duration = st.settle;
  s.time.dt = st.dt;
  if (s.time.dt <= 0) {
    if (st.integrator == Integrator::Implicit) {
      s.time.dt = 2e-3;
    } else {
      const ClothModel m = build_cloth_model(s);
      // Half the mesh's limit and a third of the natural period, as the shipped scenes keep.
      s.time.dt = std::min(0.5 * m.stability_limit(), m.natural_period() / 3.0);
    }
  }
  s.time.fps = 1.0 / st.settle;
}

uint64_t settle(Simulator& sim) {
  const SceneDef& s = sim.scene();
  const int n = int(std::ceil(s.time.duration / s.time.dt));
  sim.step(n);
  return uint64_t(n);
}

Vec3 mid(Vec3 a, Vec3 b) { return (a + b) * 0.5f; }

}  // namespace

MaterialDef preset_material(const std::string& name) {
  const Preset* p = find_preset(name);
  MaterialDef m;
  m.name = name;
  if (const MeasuredFabric* f = p ? nullptr : find_measured(name)) {
    m.measured = name;
    m.density = float(f->data.density);
    return m;
  }
  if (!p)
    throw InputError("command line", "--fabric", "unknown fabric '" + name + "' (expected a KES-F preset, " + preset_names() +
                                                     ", or a measured fabric, " + measured_names() + ")");
  m.fabric = FabricDef{name, p->W, p->B, p->G, p->EMT};
  m.density = float(weight_to_density(p->W));
  return m;
}

// ---- Cantilever -----------------------------------------------------------------------------------

double cantilever_angle(const MaterialDef& material, double overhang, const CantileverOptions& o, uint64_t* steps) {
  SceneDef s;
  s.name = "cantilever";
  s.source = "cantilever";
  s.materials.push_back(material);
  const int n = o.segments;
  const double h = overhang / n;
  PanelDef p;
  p.name = "strip";
  p.material = material.name;
  p.width = float((n + 1) * h);  // one clamped cell behind the edge
  p.height = float(o.width);
  p.resolution_u = n + 2;
  p.resolution_v = 2;
  p.warp = float(o.warp);
  p.transform.position = {float(0.5 * (n + 1) * h - h), 0.0f, 0.0f};  // the edge (u = 1) at x = 0 (near the origin: float keeps the bend springs' small shortenings)
  s.panels.push_back(p);
  for (int v = 0; v < 2; ++v) {
    PinDef pin;
    pin.panel = "strip";
    pin.range = std::array<int, 2>{v * (n + 2), v * (n + 2) + 1};
    s.pins.push_back(pin);
  }
  set_stepping(s, o.stepping);
  Simulator sim(s);
  const uint64_t k = settle(sim);
  if (steps) *steps += k;
  const auto& x = sim.positions();
  const uint32_t nu = uint32_t(n + 2);
  const Vec3 edge = mid(x[1], x[nu + 1]), tip = mid(x[nu - 1], x[2 * nu - 1]);
  return std::atan2(double(edge.y - tip.y), double(tip.x - edge.x)) * 180.0 / kPi;
}

namespace {

CantileverResult cantilever_search(const MaterialDef& material, const CantileverOptions& o) {
  CantileverResult r;
  if (material.fabric) {
    const Continuum c = to_continuum(*material.fabric);
    Continuum cc = c;
    if (material.density_set) cc.density = material.density;
    r.predicted = bending_length(cc);
  }
  if (const MeasuredFabric* f = find_measured(material.measured)) {
    Continuum c;
    c.density = material.density;
    c.bending = measured_bending(f->data, -o.warp * kPi / 180.0);  // the strip runs along u, the warp o.warp from it
    r.predicted = bending_length(c);
  }
  // Start at the overhang the measurements predict (or 4 cm) and walk on log(angle) against
  // log(overhang): a secant, the first step with the small-deflection slope.
  double l = r.predicted > 0 ? 2 * r.predicted : 0.04;
  double a = cantilever_angle(material, l, o, &r.steps);
  r.tries.push_back({l, a});
  double slope = 5.0 / 3.0;
  for (int i = 1; i < o.max_tries && std::abs(a - kCantileverAngle) > o.tolerance; ++i) {
    const double next = l * std::pow(kCantileverAngle / std::max(a, 1e-3), 1.0 / slope);
    const double an = cantilever_angle(material, next, o, &r.steps);
    r.tries.push_back({next, an});
    if (std::abs(std::log(next / l)) > 1e-9 && an > 0 && a > 0)
      slope = std::clamp(std::log(an / a) / std::log(next / l), 0.5, 4.0);
    l = next, a = an;
  }
  // The last two tries bracket or approach 41.5 degrees: interpolate between them in log-log.
  if (r.tries.size() >= 2) {
    const auto& p = r.tries[r.tries.size() - 2];
    const auto& q = r.tries.back();
    if (p.angle > 0 && q.angle > 0 && std::abs(std::log(q.angle / p.angle)) > 1e-12) {
      const double t = std::log(kCantileverAngle / p.angle) / std::log(q.angle / p.angle);
      l = std::exp(std::log(p.overhang) + t * std::log(q.overhang / p.overhang));
    }
  }
  r.overhang = l;
  r.bending_length = l / 2;
  return r;
}

}  // namespace

CantileverResult cantilever_test(const MaterialDef& material, const CantileverOptions& options) {
  CantileverOptions o = options;
  if (o.segments <= 0) {
    o.segments = 16;
    if (material.fabric && !material.bend_set && !material.stretch_set) {
      Continuum c = to_continuum(*material.fabric);
      if (material.density_set) c.density = material.density;
      const double l = 2 * bending_length(c);
      while (o.segments > 6 && bend_stretch_ratio(c, l / o.segments, o.width) > 0.2) --o.segments;
    }
    if (const MeasuredFabric* f = find_measured(material.measured);
        f && !material.bend_set && !material.stretch_set && !material.bends_by_hinges()) {
      // The bend springs' pull against the row's whole stretch stiffness, as for KES-F fabrics.
      const double warp = o.warp * kPi / 180.0;
      Continuum c;
      c.density = material.density;
      c.bending = measured_bending(f->data, -warp);
      const double l = 2 * bending_length(c), modulus = strain_modulus(stretch_coefficients(f->data, 0, -warp), -warp);
      auto ratio = [&](int n) {
        const double h = l / n;
        return 4.0 * measured_grid(f->data, c.density, h, o.width, warp).bend_u / (modulus * o.width / h);
      };
      // The measured stretch moduli are 3 to 300 times below the KES-F wovens': few cells fit
      // (docs/materials.md), down to 2.
      while (o.segments > 2 && ratio(o.segments) > 0.2) --o.segments;
    }
  }
  CantileverResult r = cantilever_search(material, o);
  r.segments = o.segments;
  r.bending_length_fine = r.bending_length;
  if (o.extrapolate && o.segments >= 4) {
    CantileverOptions coarse = o;
    coarse.segments = o.segments / 2;
    const CantileverResult rc = cantilever_search(material, coarse);
    r.bending_length_coarse = rc.bending_length;
    r.steps += rc.steps;
    // c(n) = c + a / n: from n_f and n_c cells, c = (n_f c_f - n_c c_c) / (n_f - n_c).
    const double nf = o.segments, nc = coarse.segments;
    r.bending_length = (nf * r.bending_length_fine - nc * r.bending_length_coarse) / (nf - nc);
    r.overhang = 2 * r.bending_length;
  }
  const double w_kes = material.fabric && !material.density_set ? material.fabric->W : material.density * 100.0;
  r.flexural_rigidity = w_kes * std::pow(r.bending_length * 100.0, 3);
  return r;
}

// ---- Drape ----------------------------------------------------------------------------------------

uint32_t write_drape_specimen(const std::filesystem::path& obj, const DrapeOptions& o) {
  std::vector<double> radii{o.disk_radius / 3, 2 * o.disk_radius / 3, o.disk_radius - o.ring_spacing, o.disk_radius};
  const uint32_t clamped_rings = uint32_t(radii.size());
  const int free_rings = std::max(1, int(std::lround((o.specimen_radius - o.disk_radius) / o.ring_spacing)));
  for (int k = 1; k <= free_rings; ++k) radii.push_back(o.disk_radius + (o.specimen_radius - o.disk_radius) * k / free_rings);
  const int n = o.sectors;
  std::string text = "# Cusick drape specimen: rings of vertices, the clamped ones first\nv 0 0 0\n";
  uint32_t seed = o.seed;
  for (size_t k = 0; k < radii.size(); ++k)
    for (int i = 0; i < n; ++i) {
      const double phi = 2 * kPi * i / n;
      double y = 0;
      if (k >= clamped_rings) {
        seed = seed * 1664525u + 1013904223u;
        y = o.perturbation * (double(seed >> 8) / double(1u << 24) - 0.5) * 2;
      }
      text += fmt::format("v {:.9g} {:.9g} {:.9g}\n", radii[k] * std::cos(phi), y, -radii[k] * std::sin(phi));
    }
  auto at = [&](size_t ring, int i) { return 2 + ring * n + size_t((i + n) % n); };  // OBJ numbers from 1
  for (int i = 0; i < n; ++i) text += fmt::format("f 1 {} {}\n", at(0, i), at(0, i + 1));
  for (size_t k = 0; k + 1 < radii.size(); ++k)
    for (int i = 0; i < n; ++i) {
      const size_t a = at(k, i), b = at(k, i + 1), c = at(k + 1, i + 1), d = at(k + 1, i);
      text += fmt::format("f {} {} {}\nf {} {} {}\n", a, b, c, a, c, d);
    }
  std::ofstream f(obj, std::ios::binary | std::ios::trunc);
  f << text;
  if (!f) throw std::runtime_error(obj.string() + ": cannot write the drape specimen");
  return 1 + clamped_rings * uint32_t(n);
}

SceneDef drape_scene(const MaterialDef& material, const std::filesystem::path& specimen_obj, const DrapeOptions& o) {
  SceneDef s;
  s.name = "cusick_drape";
  s.source = "drape";
  s.materials.push_back(material);
  PanelDef p;
  p.name = "specimen";
  p.material = material.name;
  p.shape = PanelShape::Mesh;
  p.mesh_file = specimen_obj.string();
  p.transform.position = {0.0f, 0.5f, 0.0f};
  s.panels.push_back(p);
  PinDef pin;
  pin.panel = "specimen";
  pin.range = std::array<int, 2>{0, int(1 + 4 * o.sectors) - 1};
  s.pins.push_back(pin);
  if (!o.gravity) s.gravity = {0, 0, 0};
  set_stepping(s, o.stepping);
  return s;
}

double shadow_area(const std::vector<Vec3>& x, const std::vector<uint32_t>& tris, double pixel) {
  double x0 = INFINITY, x1 = -INFINITY, z0 = INFINITY, z1 = -INFINITY;
  for (const Vec3& p : x) x0 = std::min(x0, double(p.x)), x1 = std::max(x1, double(p.x)), z0 = std::min(z0, double(p.z)), z1 = std::max(z1, double(p.z));
  if (!(x1 > x0 && z1 > z0)) return 0;
  const int nx = int(std::ceil((x1 - x0) / pixel)) + 1, nz = int(std::ceil((z1 - z0) / pixel)) + 1;
  std::vector<uint8_t> covered(size_t(nx) * size_t(nz), 0);
  for (size_t t = 0; t + 2 < tris.size(); t += 3) {
    const double ax = x[tris[t]].x, az = x[tris[t]].z, bx = x[tris[t + 1]].x, bz = x[tris[t + 1]].z;
    const double cx = x[tris[t + 2]].x, cz = x[tris[t + 2]].z;
    const double area2 = (bx - ax) * (cz - az) - (bz - az) * (cx - ax);
    if (area2 == 0) continue;
    const int i0 = std::max(0, int(std::floor((std::min({ax, bx, cx}) - x0) / pixel)));
    const int i1 = std::min(nx - 1, int(std::ceil((std::max({ax, bx, cx}) - x0) / pixel)));
    const int j0 = std::max(0, int(std::floor((std::min({az, bz, cz}) - z0) / pixel)));
    const int j1 = std::min(nz - 1, int(std::ceil((std::max({az, bz, cz}) - z0) / pixel)));
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const double px = x0 + (i + 0.5) * pixel, pz = z0 + (j + 0.5) * pixel;
        const double w0 = (bx - px) * (cz - pz) - (bz - pz) * (cx - px);
        const double w1 = (cx - px) * (az - pz) - (cz - pz) * (ax - px);
        const double w2 = (ax - px) * (bz - pz) - (az - pz) * (bx - px);
        if (area2 > 0 ? (w0 >= 0 && w1 >= 0 && w2 >= 0) : (w0 <= 0 && w1 <= 0 && w2 <= 0))
          covered[size_t(j) * nx + i] = 1;
      }
  }
  size_t count = 0;
  for (uint8_t c : covered) count += c;
  return double(count) * pixel * pixel;
}

int count_folds(const std::vector<Vec3>& rim, double prominence) {
  const int n = int(rim.size());
  if (n < 8) return 0;
  std::vector<std::pair<double, double>> polar;
  for (const Vec3& p : rim) polar.emplace_back(std::atan2(double(p.z), double(p.x)), std::hypot(double(p.x), double(p.z)));
  std::sort(polar.begin(), polar.end());
  // A fold is a rim point farthest out within 22.5 degrees either side, standing `prominence` above
  // the lowest rim point within 45 degrees either side.
  const int w = std::max(1, n / 16);
  int folds = 0;
  for (int i = 0; i < n; ++i) {
    const double r = polar[size_t(i)].second;
    bool peak = true;
    double low = r;
    for (int d = -2 * w; d <= 2 * w && peak; ++d) {
      const double q = polar[size_t(((i + d) % n + n) % n)].second;
      if (std::abs(d) <= w && d != 0 && (q > r || (q == r && d < 0))) peak = false;
      low = std::min(low, q);
    }
    if (peak && r - low > prominence) ++folds;
  }
  return folds;
}

DrapeResult drape_test(const MaterialDef& material, const DrapeOptions& o) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path();
  const std::filesystem::path obj = dir / fmt::format("raycloth_drape_{}_{}.obj", material.name, ::getpid());
  write_drape_specimen(obj, o);
  DrapeResult r;
  try {
    const SceneDef s = drape_scene(material, obj, o);
    Simulator sim(s);
    r.steps = settle(sim);
    r.positions = sim.positions();
    r.triangles = sim.model().triangles;
  } catch (...) {
    std::filesystem::remove(obj);
    throw;
  }
  std::filesystem::remove(obj);
  r.shadow_area = shadow_area(r.positions, r.triangles);
  const double disk = kPi * o.disk_radius * o.disk_radius, specimen = kPi * o.specimen_radius * o.specimen_radius;
  r.drape_coefficient = (r.shadow_area - disk) / (specimen - disk);
  const std::vector<Vec3> rim(r.positions.end() - o.sectors, r.positions.end());
  r.folds = count_folds(rim);
  r.min_radius = INFINITY;
  for (const Vec3& p : rim) {
    const double d = std::hypot(double(p.x), double(p.z));
    r.min_radius = std::min(r.min_radius, d), r.max_radius = std::max(r.max_radius, d);
  }
  return r;
}

void write_drape_scene(const MaterialDef& material, const DrapeOptions& o, const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  const uint32_t clamped = write_drape_specimen(dir / "specimen.obj", o);
  const SceneDef s = drape_scene(material, dir / "specimen.obj", o);
  // The support disk: a closed cylinder of the disk's radius, its top 3 mm under the specimen.
  {
    const int n = o.sectors;
    const double top = 0.5 - 0.003, bottom = top - 0.01;
    std::string text = "# Cusick drape tester's support disk\n";
    for (double y : {top, bottom}) {
      text += fmt::format("v 0 {:.9g} 0\n", y);
      for (int i = 0; i < n; ++i)
        text += fmt::format("v {:.9g} {:.9g} {:.9g}\n", o.disk_radius * std::cos(2 * kPi * i / n), y,
                            -o.disk_radius * std::sin(2 * kPi * i / n));
    }
    const int b = n + 1;  // the bottom centre's number - 1
    for (int i = 0; i < n; ++i) {
      const int a0 = 2 + i, a1 = 2 + (i + 1) % n, c0 = b + 2 + i, c1 = b + 2 + (i + 1) % n;
      text += fmt::format("f 1 {} {}\nf {} {} {}\nf {} {} {}\nf {} {} {}\n", a0, a1, b + 1, c1, c0, a0, c0, c1, a0, c1, a1);
    }
    std::ofstream f(dir / "disk.obj", std::ios::binary | std::ios::trunc);
    f << text;
    if (!f) throw std::runtime_error((dir / "disk.obj").string() + ": cannot write the support disk");
  }
  nlohmann::ordered_json m = {{"name", material.name}};
  if (material.fabric && !material.fabric->preset.empty()) m["fabric"] = material.fabric->preset;
  if (!material.measured.empty()) m["fabric"] = material.measured;
  if (material.fabric)
    m["kes"] = {{"W", material.fabric->W}, {"B", material.fabric->B}, {"G", material.fabric->G}, {"EMT", material.fabric->EMT}};
  m["damping"] = s.materials[0].damping;
  nlohmann::ordered_json j = {
      {"name", "cusick_drape_" + material.name},
      {"time", {{"dt", s.time.dt}, {"duration", s.time.duration}, {"fps", 1.0 / s.time.duration}}},
      {"collision", {{"cloth_cloth", false}}},
      {"materials", {m}},
      {"panels", {{{"name", "specimen"}, {"material", material.name}, {"mesh", "specimen.obj"}, {"position", {0, 0.5, 0}}}}},
      {"pins", {{{"panel", "specimen"}, {"range", {0, int(clamped) - 1}}}}},
      {"obstacles",
       {{{"name", "disk"}, {"type", "mesh"}, {"file", "disk.obj"}},
        // The tester's column, so that the floor of rendered images lies far below.
        {{"name", "column"}, {"type", "box"}, {"size", {0.04, 0.48, 0.04}}, {"position", {0, 0.245, 0}}}}},
  };
  std::ofstream f(dir / "scene.json", std::ios::binary | std::ios::trunc);
  f << "// The Cusick drape test (ISO 9073-9): written by raycloth fabric-test drape --scene\n" << j.dump(2) << "\n";
  if (!f) throw std::runtime_error((dir / "scene.json").string() + ": cannot write the scene");
}

// ---- Uniaxial pull --------------------------------------------------------------------------------

namespace {

// The share of a built model's in-plane stiffness (sum of k l^2) its bend springs hold, before the
// stretch springs gave it up (they give it up to half: model.cpp).
double bend_share(const ClothModel& m) {
  double st = 0, bt = 0;
  for (const Spring& sp : m.springs) (sp.type == SpringType::Bend ? bt : st) += double(sp.k) * sp.rest * sp.rest;
  const double after = st > 0 ? bt / st : 0;
  return after / (1 + after);
}

}  // namespace

namespace {

// A pulled specimen's scene, without gravity and with the fabric, and its panel "specimen" of that
// fabric (the caller shapes and pins it).
SceneDef pull_scene(const char* name, const MaterialDef& material, PanelDef& specimen) {
  SceneDef s;
  s.name = name;
  s.source = "tensile";
  s.gravity = {0, 0, 0};
  s.materials.push_back(material);
  specimen = PanelDef();
  specimen.name = "specimen";
  specimen.material = material.name;
  return s;
}

}  // namespace

std::vector<TensilePoint> tensile_test(const MaterialDef& material, const TensileOptions& options) {
  std::vector<TensilePoint> out;
  TensileOptions o = options;
  const bool choose = o.edge <= 0;
  if (choose) o.edge = 0.005;
  for (double strain : o.strains) {
    PanelDef p;
    SceneDef s = pull_scene("tensile", material, p);
    p.shape = PanelShape::Pattern;
    const float hl = float(o.length / 2), hw = float(o.width / 2);
    p.pattern.outline = {{"bottom", {-hl, -hw}, std::nullopt}, {"right", {hl, -hw}, std::nullopt},
                         {"top", {hl, hw}, std::nullopt}, {"left", {-hl, hw}, std::nullopt}};
    p.pattern.edge_length = float(o.edge);
    p.transform.scale = {float(1 + strain), 1.0f, 1.0f};  // placed stretched; the rest shape is the pattern
    s.panels.push_back(p);
    for (const char* seg : {"left", "right"}) {
      PinDef pin;
      pin.panel = "specimen";
      pin.segment = seg;
      s.pins.push_back(pin);
    }
    if (choose)
      while (o.edge < 0.5 * std::min(o.length, o.width) && bend_share(build_cloth_model(s)) > 0.3)
        s.panels[0].pattern.edge_length = float(o.edge *= 1.25);
    set_stepping(s, o.stepping);
    Simulator sim(s);
    settle(sim);
    const ClothModel& m = sim.model();
    const auto& x = sim.positions();
    auto left = [&](uint32_t i) { return m.inv_mass[i] == 0.0f && x[i].x < 0; };
    double force = 0;
    for (const Spring& sp : m.springs) {
      const bool la = left(sp.a), lb = left(sp.b);
      if (la == lb) continue;
      const uint32_t a = la ? sp.a : sp.b, b = la ? sp.b : sp.a;
      const Vec3 d = x[b] - x[a];
      const double len = length(d);
      if (len > 0) force += double(sp.k) * (len - double(sp.rest)) * double(d.x) / len;
    }
    out.push_back({strain, force / o.width, o.edge});
  }
  return out;
}

// ---- Pull along a direction, held across -----------------------------------------------------------

std::vector<DirectionalPoint> directional_tensile(const MaterialDef& material, double angle, const DirectionalOptions& options) {
  const MeasuredFabric* f = find_measured(material.measured);
  if (!f) throw InputError("command line", "--fabric", "the pull along a direction needs a measured fabric (" + measured_names() + ")");
  std::vector<DirectionalPoint> out;
  DirectionalOptions o = options;
  const bool choose = o.edge <= 0;
  if (choose) o.edge = 0.005;
  const double half = 0.5 * o.size;
  for (double strain : o.strains) {
    PanelDef p;
    SceneDef s = pull_scene("directional_tensile", material, p);
    p.warp = float(angle);  // the pull runs along x: the warp `angle` from it
    if (o.grid) {
      p.width = p.height = float(o.size);
      p.resolution_u = p.resolution_v = int(std::lround(o.size / o.edge)) + 1;
    } else {
      p.shape = PanelShape::Pattern;
      const float h = float(half);
      p.pattern.outline = {{"bottom", {-h, -h}, std::nullopt}, {"right", {h, -h}, std::nullopt},
                           {"top", {h, h}, std::nullopt}, {"left", {-h, h}, std::nullopt}};
      p.pattern.edge_length = float(o.edge);
    }
    // A pattern is placed stretched (its rest shape is the square); a grid's rest shape is where it is
    // placed, so it is stretched once the simulator has it.
    if (!o.grid) p.transform.scale = {float(1 + strain), 1.0f, 1.0f};
    s.panels.push_back(p);
    for (const char* side : {"left", "right", "bottom", "top"}) {
      PinDef pin;
      pin.panel = "specimen";
      (o.grid ? pin.edge : pin.segment) = side;
      s.pins.push_back(pin);
    }
    if (choose && !o.grid)
      while (o.edge < 0.25 * o.size && bend_share(build_cloth_model(s)) > 0.3)
        s.panels[0].pattern.edge_length = float(o.edge *= 1.25);
    if (choose && o.grid && !material.bend_set && !material.stretch_set) {
      // Cells no smaller than the fabric's bending lets the stretch springs carry (MeasuredGrid::bend_fits).
      const double warp = angle * kPi / 180.0, density = material.density_set ? material.density : f->data.density;
      auto cell = [&] { return o.size / double(s.panels[0].resolution_u - 1); };
      while (cell() < 0.25 * o.size && !measured_grid(f->data, density, cell(), cell(), warp, !material.bends_by_hinges()).bend_fits)
        s.panels[0].resolution_u = s.panels[0].resolution_v = s.panels[0].resolution_u - 1;
      o.edge = cell();
    }
    set_stepping(s, o.stepping);
    Simulator sim(s);
    if (o.grid) {
      std::vector<Vec3> x = sim.positions();
      for (Vec3& q : x) q.x *= float(1 + strain);
      sim.set_state(x, std::vector<Vec3>(x.size(), Vec3{0, 0, 0}));
    }
    settle(sim);
    const ClothModel& m = sim.model();
    const auto& x = sim.positions();
    // The force across the line through the middle, off any vertex, per unstretched width.
    const double cut = 1e-4 * o.size;
    double force = 0;
    for (const Spring& sp : m.springs) {
      const bool la = x[sp.a].x < cut, lb = x[sp.b].x < cut;
      if (la == lb) continue;
      const uint32_t a = la ? sp.a : sp.b, b = la ? sp.b : sp.a;
      const Vec3 d = x[b] - x[a];
      const float len = length(d), stretch = len - sp.rest;
      if (len > 0) force += double(stiffened(sp.k, sp.k_stiff, stretch, sp.rest) * stretch) * double(d.x) / double(len);
    }
    // Membrane triangles across the line: their pull on their corners left of it (a triangle's
    // forces sum to zero, so those wholly on one side add nothing).
    const ModelView view = m.view();
    for (uint32_t t = 0; t < m.num_membranes(); ++t) {
      const uint32_t* v = &m.membrane_vertex[3 * t];
      const int left = int(x[v[0]].x < cut) + int(x[v[1]].x < cut) + int(x[v[2]].x < cut);
      if (left == 0 || left == 3) continue;
      const MembraneState st = membrane_state(view, x.data(), t);
      for (uint32_t c = 0; c < 3; ++c)
        if (x[v[c]].x < cut) force += double(membrane_corner_force(st, c).x);
    }
    DirectionalPoint pt;
    pt.strain = strain;
    pt.angle = angle;
    pt.tension = force / o.size;
    pt.measured = measured_tension(f->data, strain, -angle * kPi / 180.0);
    pt.edge = o.edge;
    out.push_back(pt);
  }
  return out;
}

}  // namespace raycloth::lab
