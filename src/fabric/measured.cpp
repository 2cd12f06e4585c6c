#include "fabric/measured.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

#include "fabric/kes.h"
#include "raycloth/error.h"

namespace raycloth::embedded {
// The ten files, in measured_fabrics()' order (CMakeLists.txt, raycloth_embed_text).
std::string_view wang2011_0();
std::string_view wang2011_1();
std::string_view wang2011_2();
std::string_view wang2011_3();
std::string_view wang2011_4();
std::string_view wang2011_5();
std::string_view wang2011_6();
std::string_view wang2011_7();
std::string_view wang2011_8();
std::string_view wang2011_9();
}  // namespace raycloth::embedded

namespace raycloth::fabric {

namespace {

using nlohmann::json;

std::string number_text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// Line and column (from 1) of a byte offset, for JSON syntax errors.
std::string where(std::string_view text, size_t byte) {
  size_t line = 1, column = 1;
  for (size_t i = 0; i < byte && i < text.size(); ++i) {
    if (text[i] == '\n') ++line, column = 1;
    else ++column;
  }
  return "line " + std::to_string(line) + ", column " + std::to_string(column);
}

template <size_t Rows, size_t Cols>
void read_table(const json& j, const std::string& file, const std::string& ptr, std::array<std::array<double, Cols>, Rows>& out) {
  const std::string shape = std::to_string(Rows) + " rows of " + std::to_string(Cols) + " numbers";
  if (!j.is_array()) throw InputError(file, ptr, "must be " + shape);
  if (j.size() != Rows) throw InputError(file, ptr, "must be " + shape + " (got " + std::to_string(j.size()) + " rows)");
  for (size_t r = 0; r < Rows; ++r) {
    const std::string rp = ptr + "/" + std::to_string(r);
    const json& row = j[r];
    if (!row.is_array() || row.size() != Cols)
      throw InputError(file, rp, "must be a row of " + std::to_string(Cols) + " numbers" +
                                     (row.is_array() ? " (got " + std::to_string(row.size()) + ")" : ""));
    for (size_t c = 0; c < Cols; ++c) {
      const std::string cp = rp + "/" + std::to_string(c);
      if (!row[c].is_number()) throw InputError(file, cp, "must be a number");
      const double v = row[c].get<double>();
      if (!std::isfinite(v)) throw InputError(file, cp, "must be finite");
      out[r][c] = v;
    }
  }
}

// Solves the normal equations of A x = b (n unknowns, m >= n rows) by Gaussian elimination with
// partial pivoting; false when singular.
bool least_squares(const std::vector<std::vector<double>>& a, const std::vector<double>& b, std::vector<double>& x) {
  const size_t m = a.size(), n = x.size();
  std::vector<std::vector<double>> q(n, std::vector<double>(n + 1, 0.0));
  double scale = 0;
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = 0; j < n; ++j)
      for (size_t r = 0; r < m; ++r) q[i][j] += a[r][i] * a[r][j];
    for (size_t r = 0; r < m; ++r) q[i][n] += a[r][i] * b[r];
    scale = std::max(scale, std::abs(q[i][i]));
  }
  for (size_t c = 0; c < n; ++c) {
    size_t p = c;
    for (size_t r = c + 1; r < n; ++r)
      if (std::abs(q[r][c]) > std::abs(q[p][c])) p = r;
    if (!(std::abs(q[p][c]) > 1e-12 * scale)) return false;
    std::swap(q[c], q[p]);
    for (size_t r = 0; r < n; ++r) {
      if (r == c) continue;
      const double f = q[r][c] / q[c][c];
      for (size_t k = c; k <= n; ++k) q[r][k] -= f * q[c][k];
    }
  }
  for (size_t i = 0; i < n; ++i) x[i] = q[i][n] / q[i][i];
  return true;
}

// Fits x >= floor to A x = b: families whose stiffness comes out below the floor get the floor and
// the rest are fitted again with them fixed (least squares), until none is below. The floor keeps
// every family a spring: a grid cell without its springs along one side is a mechanism.
bool fit_non_negative(const std::vector<std::vector<double>>& a, const std::vector<double>& b, std::vector<double>& x, int& clamped,
                      const std::vector<double>& floor) {
  const size_t n = x.size();
  std::vector<bool> fixed(n, false);
  for (size_t round = 0; round <= n; ++round) {
    std::vector<size_t> free;
    for (size_t i = 0; i < n; ++i)
      if (!fixed[i]) free.push_back(i);
    x = floor;
    if (free.empty()) return true;
    std::vector<std::vector<double>> af(a.size(), std::vector<double>(free.size()));
    std::vector<double> bf = b;
    for (size_t r = 0; r < a.size(); ++r) {
      for (size_t k = 0; k < free.size(); ++k) af[r][k] = a[r][free[k]];
      for (size_t i = 0; i < n; ++i)
        if (fixed[i]) bf[r] -= a[r][i] * floor[i];
    }
    std::vector<double> xf(free.size());
    if (!least_squares(af, bf, xf)) return false;
    bool negative = false;
    for (size_t k = 0; k < free.size(); ++k) {
      if (xf[k] < floor[free[k]]) fixed[free[k]] = true, negative = true, ++clamped;
      else x[free[k]] = xf[k];
    }
    if (!negative) return true;
  }
  return true;
}

double fold_quarter(double angle) { return std::abs(std::remainder(angle, kPi)); }  // [0, pi/2]

}  // namespace

MeasuredData parse_measured(std::string_view text, const std::string& file) {
  json j;
  try {
    j = json::parse(text.begin(), text.end(), nullptr, true, /*ignore_comments=*/true);
  } catch (const json::parse_error& e) {
    throw InputError(file, "", "not JSON (" + where(text, e.byte > 0 ? e.byte - 1 : 0) + ")");
  }
  if (!j.is_object()) throw InputError(file, "", "must be a JSON object with density, stretching and bending");
  for (const auto& [key, value] : j.items())
    if (key != "density" && key != "stretching" && key != "bending")
      throw InputError(file, "/" + key, "unknown field (expected density, stretching or bending)");
  for (const char* key : {"density", "stretching", "bending"})
    if (!j.contains(key)) throw InputError(file, std::string("/") + key, "missing required field");
  MeasuredData d;
  if (!j["density"].is_number()) throw InputError(file, "/density", "must be a number");
  d.density = j["density"].get<double>();
  if (!(d.density > 0) || !std::isfinite(d.density))
    throw InputError(file, "/density", "must be above 0 kg/m^2 (got " + number_text(d.density) + ")");
  read_table(j["stretching"], file, "/stretching", d.stretching);
  read_table(j["bending"], file, "/bending", d.bending);
  for (size_t r = 0; r < 3; ++r)
    for (size_t c = 0; c < 5; ++c)
      if (d.bending[r][c] < 0)
        throw InputError(file, "/bending/" + std::to_string(r) + "/" + std::to_string(c),
                         "must not be negative (got " + number_text(d.bending[r][c]) + ")");
  return d;
}

const std::vector<MeasuredFabric>& measured_fabrics() {
  static const std::vector<MeasuredFabric> list = [] {
    constexpr std::string_view src =
        "Wang, Ramamoorthi, O'Brien, Data-Driven Elastic Models for Cloth, TOG 30(4) 2011: measured; "
        "ARCSim 0.3 materials/";
    struct Entry {
      std::string_view name, file, use, fibre, source;
      std::string_view (*text)();
    };
    const Entry entries[] = {
        {"ivory_rib_knit", "ivory-rib-knit.json", "underwear", "95% cotton 5% spandex", "ivory-rib-knit.json", embedded::wang2011_0},
        {"pink_ribbon_brown", "pink-ribbon-brown.json", "blanket", "100% polyester", "pink-ribbon-brown.json", embedded::wang2011_1},
        {"white_dots_on_blk", "white-dots-on-blk.json", "tablecloth", "100% polyester", "white-dots-on-blk.json", embedded::wang2011_2},
        {"navy_sparkle_sweat", "navy-sparkle-sweat.json", "sweater", "96% polyester 4% spandex", "navy-sparkle-sweat.json", embedded::wang2011_3},
        {"camel_ponte_roma", "camel-ponte-roma.json", "jacket", "60% polyester 40% rayon", "camel-ponte-roma.json", embedded::wang2011_4},
        {"gray_interlock", "gray-interlock.json", "t-shirt", "60% cotton 40% polyester", "gray-interlock.json", embedded::wang2011_5},
        {"denim_11oz", "11oz-black-denim.json", "jeans", "99% cotton 1% spandex", "11oz-black-denim.json", embedded::wang2011_6},
        {"white_swim_solid", "white-swim-solid.json", "swimsuit", "87% nylon 13% spandex", "white-swim-solid.json", embedded::wang2011_7},
        {"tango_red_jet_set", "tango-red-jet-set.json", "jacket", "100% polyester", "tango-red-jet-set.json", embedded::wang2011_8},
        {"royal_target", "royal-target.json", "pants", "65% cotton 35% polyester", "royal-target.json", embedded::wang2011_9},
    };
    std::vector<MeasuredFabric> out;
    for (const Entry& e : entries)
      out.push_back({e.name, e.file, e.use, e.fibre, std::string(src) + std::string(e.source),
                     parse_measured(e.text(), "assets/fabrics/wang2011/" + std::string(e.file))});
    return out;
  }();
  return list;
}

const MeasuredFabric* find_measured(std::string_view name) {
  for (const MeasuredFabric& f : measured_fabrics())
    if (f.name == name) return &f;
  return nullptr;
}

std::string measured_names() {
  std::string s;
  const auto& list = measured_fabrics();
  for (size_t i = 0; i < list.size(); ++i) {
    if (i) s += i + 1 == list.size() ? " or " : ", ";
    s += list[i].name;
  }
  return s;
}

std::array<double, 4> stretch_coefficients(const MeasuredData& d, double strain, double angle) {
  // ARCSim: the angle weight is the principal direction's angle from the warp over 22.5 degrees
  // (folded into [0, 90]: its eigenvector has a non-negative warp component), the strain weight
  // (stretch - 1) * 6; row 0 stands for every angle at no strain.
  double aw = std::min(fold_quarter(angle) / kPi * 8.0, 4.0 - 1e-6);
  const int ai = int(aw);
  aw -= ai;
  const double sw = std::clamp(strain * 6.0, 0.0, 1.0 - 1e-6);
  std::array<double, 4> k{};
  for (int c = 0; c < 4; ++c) {
    const double at = d.stretching[1 + ai][c] * (1 - aw) + d.stretching[2 + ai][c] * aw;
    k[c] = 2.0 * std::max(0.0, d.stretching[0][c] * (1 - sw) + at * sw);
  }
  return k;
}

double strain_modulus(const std::array<double, 4>& k, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return k[0] * c * c * c * c + k[2] * s * s * s * s + 2.0 * (k[1] + k[3]) * c * c * s * s;
}

double measured_tension(const MeasuredData& d, double strain, double angle) {
  const double g = strain + 0.5 * strain * strain;
  return (1.0 + strain) * g * strain_modulus(stretch_coefficients(d, strain, angle), angle);
}

double measured_bending(const MeasuredData& d, double angle, int column) {
  // Hinges across a curvature along `angle` run at angle + 90 degrees; ARCSim's rows are 0, 45 and 90
  // degrees of the hinge's direction, interpolated.
  const double bias = fold_quarter(angle + 0.5 * kPi) / (0.25 * kPi);
  const int id = std::min(int(bias), 1);
  const double w = bias - id;
  const int col = std::clamp(column, 0, 4);
  return kHingeToSheet * std::max(0.0, d.bending[size_t(id)][size_t(col)] * (1 - w) + d.bending[size_t(id) + 1][size_t(col)] * w);
}

FamilyFit fit_families(const MeasuredData& d, const std::vector<double>& families, const std::vector<double>& pulls) {
  FamilyFit fit;
  const size_t n = families.size();
  fit.small.assign(n, 0.0);
  fit.stiff.assign(n, 0.0);
  // No strain: C(pull) = sum over families of rho cos^4(family - pull).
  std::vector<std::vector<double>> a(pulls.size(), std::vector<double>(n));
  std::vector<double> b(pulls.size());
  for (size_t j = 0; j < pulls.size(); ++j) {
    for (size_t f = 0; f < n; ++f) a[j][f] = std::pow(std::cos(families[f] - pulls[j]), 4);
    b[j] = strain_modulus(stretch_coefficients(d, 0.0, pulls[j]), pulls[j]);
  }
  // The floor: 2 % of the stiffest direction's modulus.
  const std::vector<double> floor(n, 0.02 * *std::max_element(b.begin(), b.end()));
  if (!fit_non_negative(a, b, fit.small, fit.clamped, floor)) return fit;
  // At kMeasuredStrain along each pull (held across: F = I + e m m^T), a family's springs stretch
  // to lambda = |F n| and pull with rho (s + (rho_stiff / rho - 1) s w) per rho, w = min(s / e, 1),
  // projected on the pull: the tension is linear in rho_stiff.
  const double e = kMeasuredStrain;
  for (size_t j = 0; j < pulls.size(); ++j) {
    const double mx = std::cos(pulls[j]), my = std::sin(pulls[j]);
    double linear = 0;
    for (size_t f = 0; f < n; ++f) {
      const double nx = std::cos(families[f]), ny = std::sin(families[f]);
      const double mn = mx * nx + my * ny;
      const double fx = nx + e * mn * mx, fy = ny + e * mn * my;  // F n
      const double lambda = std::hypot(fx, fy), s = lambda - 1.0;
      const double geo = (mx * fx + my * fy) * mn / lambda;
      const double w = std::clamp(s / e, 0.0, 1.0);
      linear += fit.small[f] * s * (1.0 - w) * geo;
      a[j][f] = s * w * geo;
    }
    b[j] = measured_tension(d, e, pulls[j]) - linear;
  }
  // A spring may soften with strain, but to no less than half its stiffness at no strain: below
  // that its force would fall as it stretches (a negative tangent, where the sheet tears apart).
  std::vector<double> stiff_floor(n);
  for (size_t f = 0; f < n; ++f) stiff_floor[f] = std::max(floor[f], 0.5 * fit.small[f]);
  if (!fit_non_negative(a, b, fit.stiff, fit.clamped, stiff_floor)) return fit;
  fit.solved = true;
  return fit;
}

namespace {

// Bend springs along one grid direction (kes.cpp's grid mapping for the rigidity along it), sharing
// with the stretch springs under them; `row_modulus` is the sheet's whole stretch stiffness along the
// row per spring (the diagonals hold a row together too, and a knit's row springs may carry none).
// Returns false where the row's stretch springs are too weak to give up the bend springs' pull (the
// grid is then stiffer in the plane than measured along the row).
// The bend springs are linear: a stretch spring that softens with strain (`stiff` < 0, its stiffness
// k + stiff w at w = strain / (1/6) up to 1) gives up 4 k_bend from k alone, so its own tangent
// k - 4 k_bend + 2 stiff w must stay >= 0 up to w = 1. Below that the row's springs still pull as
// measured together (the bend springs, two cells long, make it up), but the stretch springs alone
// pull less as they stretch: cells one in two stretch further and the row buckles in its plane
// (the swimsuit knit pulled at 45 degrees from its warp, cells of 5 mm: k 18.2, stiff -39.6 N/m, the
// row pushing back at -48 N/m instead of pulling 21 N/m). What the spring cannot give up it keeps.
bool grid_bend(double bending, double density, double along, double across, double row_modulus, double stiff, double& stretch,
               double& bend) {
  bend = 0;
  if (!(bending > 0)) return true;
  Continuum c;
  c.density = density;
  c.bending = bending;
  const double k2 = reference_curvature(c) * reference_curvature(c);
  const double wanted = 8.0 * bending * across / (k2 * std::pow(along, 5));
  double row = row_modulus;
  share_with_bend(row, bend, wanted);
  const double keep = -2.0 * std::min(stiff, 0.0);  // the least k that keeps k + 2 stiff >= 0
  const bool fits = stretch - 4.0 * bend >= keep;
  stretch = std::max(stretch - 4.0 * bend, keep);
  return fits;
}

}  // namespace

MeasuredGrid measured_grid(const MeasuredData& d, double density, double hx, double hy, double warp, bool bend_springs) {
  MeasuredGrid g;
  const double alpha = std::atan2(hy, hx);
  const std::vector<double> families{-warp, 0.5 * kPi - warp, alpha - warp, -alpha - warp};
  const std::vector<double> pulls{-warp, 0.25 * kPi - warp, 0.5 * kPi - warp, 0.75 * kPi - warp};
  const FamilyFit fit = fit_families(d, families, pulls);
  g.clamped = fit.clamped;
  const double area = hx * hy, diag2 = hx * hx + hy * hy;
  g.stretch_u = fit.small[0] * area / (hx * hx), g.stiff_u = (fit.stiff[0] - fit.small[0]) * area / (hx * hx);
  g.stretch_v = fit.small[1] * area / (hy * hy), g.stiff_v = (fit.stiff[1] - fit.small[1]) * area / (hy * hy);
  g.diag_a = fit.small[2] * area / diag2, g.stiff_a = (fit.stiff[2] - fit.small[2]) * area / diag2;
  g.diag_b = fit.small[3] * area / diag2, g.stiff_b = (fit.stiff[3] - fit.small[3]) * area / diag2;
  if (!bend_springs) return g;
  const double cu = strain_modulus(stretch_coefficients(d, 0.0, -warp), -warp) * area / (hx * hx);
  const double cv = strain_modulus(stretch_coefficients(d, 0.0, 0.5 * kPi - warp), 0.5 * kPi - warp) * area / (hy * hy);
  g.bend_fits = grid_bend(measured_bending(d, -warp), density, hx, hy, cu, g.stiff_u, g.stretch_u, g.bend_u);
  g.bend_fits &= grid_bend(measured_bending(d, 0.5 * kPi - warp), density, hy, hx, cv, g.stiff_v, g.stretch_v, g.bend_v);
  return g;
}

MembraneLaw membrane_law(const MeasuredData& d) {
  const double e = kMeasuredStrain, reach = e + 0.5 * e * e;
  const std::array<double, 4> k0 = stretch_coefficients(d, 0.0, 0.0);
  const double a0 = k0[0], a2 = k0[2], k1 = k0[1], a3 = k0[3];
  const double b0 = std::max(stretch_coefficients(d, e, 0.0)[0] - a0, -0.5 * a0);
  const double b2 = std::max(stretch_coefficients(d, e, 0.5 * kPi)[2] - a2, -0.5 * a2);
  // At 45 degrees the warp and the weft are strained by half the pull's Green strain, the shear by
  // half too (its reach): C = (k0(reach / 2) + k2(reach / 2) + 2 k1 + 2 (a3 + b3)) / 4.
  MembraneLaw law;
  law.measured_45 = measured_tension(d, e, 0.25 * kPi);
  const double c45 = law.measured_45 / ((1 + e) * reach);
  const double b3 = std::max((4 * c45 - (a0 + 0.5 * b0) - (a2 + 0.5 * b2) - 2 * k1) / 2 - a3, -0.5 * a3);
  law.fitted_45 = (1 + e) * reach * ((a0 + 0.5 * b0) + (a2 + 0.5 * b2) + 2 * k1 + 2 * (a3 + b3)) / 4;
  law.p = {float(a0), float(b0), float(a2), float(b2), float(k1), float(a3), float(b3), float(reach)};
  return law;
}

double measured_hinge_bend(const MeasuredData& d, double density, double area_sum, double length, double angle) {
  Continuum c;
  c.density = density;
  c.bending = measured_bending(d, angle);
  return c.bending > 0 ? hinge_bend(c, area_sum, length) : 0.0;
}

double angle_from_warp(Vec3 v, Vec3 normal, Vec3 warp) {
  const double nl = double(length(normal));
  if (!(nl > 0)) return std::atan2(double(v.y), double(v.x)) - std::atan2(double(warp.y), double(warp.x));
  const Vec3 n = normal / float(nl);
  Vec3 w = warp - n * dot(n, warp);
  if (!(double(length(w)) > 1e-6 * double(length(warp)))) w = cross(n, make_vec3(0, 0, 1));  // warp along the normal
  if (!(double(length(w)) > 0)) w = cross(n, make_vec3(1, 0, 0));
  w = w / length(w);
  const Vec3 b = cross(n, w);
  return std::atan2(double(dot(v, b)), double(dot(v, w)));
}

}  // namespace raycloth::fabric
