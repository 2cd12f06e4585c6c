#include "fabric/kes.h"

#include <algorithm>
#include <cmath>
#include <functional>

namespace raycloth::fabric {

Continuum to_continuum(const FabricDef& f) {
  Continuum c;
  c.density = weight_to_density(f.W);
  c.bending = bending_to_si(f.B);
  c.shear = shear_to_si(f.G);
  c.tensile = emt_to_modulus(f.EMT);
  return c;
}

double bending_length(const Continuum& c) { return std::cbrt(c.bending / (c.density * kStandardGravity)); }

double reference_curvature(const Continuum& c) { return kBendCalibration / bending_length(c); }

// Stretch and shear: a cell's springs give the sheet the stiffness tensor sum k l^2 / A (n x n x n x n)
// over its springs; with diagonals of stiffness s and length d, C_xyxy = 2 s hx hy / d^2 = G, and
// C_xxxx = k_u hx / hy + G hx^2 / hy^2. The strip of the tensile test contracts freely across, so its
// modulus is C_xxxx - G^2 / C_yyyy; setting it to E with C_xxxx = C_yyyy = a gives
// a = (E + sqrt(E^2 + 4 G^2)) / 2. Bending: a bend spring of rest length 2h over a hinge turned by
// theta = kappa h shortens by h theta^2 / 4, so a row of them carries M = k h^4 kappa^3 / 8 per row
// (per unit width: times 1/h across): matched to B kappa at kappa_ref.
// The bend springs in compression push apart the ends of the stretch springs under them: across any
// cut of a row, two bend springs push and one stretch spring pulls, so that spring stretches by
// 2 F / k_s and the bend spring keeps only 1 / (1 + 4 k_b / k_s) of its shortening.
// Stretched, a row's bend springs (length 2h, one per vertex) pull like stretch springs of 4 k_b:
// the stretch springs give up that much, k_s' = k_s - 4 k_b, so that the row keeps the modulus. With
// the series correction on k_s', k_b (1 - 4 k / k_s') = k, that is 4 k_b^2 - k_s k_b + k k_s = 0:
// k_b = (k_s - sqrt(k_s^2 - 16 k k_s)) / 8, which exists while 16 k <= k_s. Past that, the grid is
// too fine for the fabric: k_b = k_s / 8 and k_s' = k_s / 2, which bend with k_s / 16 < k.
void share_with_bend(double& stretch, double& bend, double k) {
  const double ks = stretch;
  const double disc = ks * ks - 16.0 * k * ks;
  bend = disc >= 0 ? (ks - std::sqrt(disc)) / 8.0 : ks / 8.0;
  stretch = ks - 4.0 * bend;
}

double bend_stretch_ratio(const Continuum& c, double hx, double hy) {
  const double E = c.tensile, G = c.shear;
  const double a = 0.5 * (E + std::sqrt(E * E + 4.0 * G * G));
  const double stretch = std::max((a - G * hx * hx / (hy * hy)) * hy / hx, 0.01 * E * hy / hx);
  const double k2 = reference_curvature(c) * reference_curvature(c);
  return 4.0 * 8.0 * c.bending * hy / (k2 * std::pow(hx, 5)) / stretch;
}

GridSprings grid_springs(const Continuum& c, double hx, double hy) {
  GridSprings g;
  const double E = c.tensile, G = c.shear;
  const double a = 0.5 * (E + std::sqrt(E * E + 4.0 * G * G));
  const double floor_u = 0.01 * E * hy / hx, floor_v = 0.01 * E * hx / hy;
  g.stretch_u = std::max((a - G * hx * hx / (hy * hy)) * hy / hx, floor_u);
  g.stretch_v = std::max((a - G * hy * hy / (hx * hx)) * hx / hy, floor_v);
  g.shear = G * (hx * hx + hy * hy) / (2.0 * hx * hy);
  const double k2 = reference_curvature(c) * reference_curvature(c);
  share_with_bend(g.stretch_u, g.bend_u, 8.0 * c.bending * hy / (k2 * std::pow(hx, 5)));
  share_with_bend(g.stretch_v, g.bend_v, 8.0 * c.bending * hx / (k2 * std::pow(hy, 5)));
  return g;
}

// An equilateral lattice of springs k has the 2D modulus E = 2 k / sqrt(3) (Poisson's ratio 1/3);
// k = E (sum of the edge's triangle areas) / l^2 gives exactly that on it, and scales with any mesh.
double edge_stretch(const Continuum& c, double area_sum, double length) {
  return c.tensile * area_sum / (length * length);
}

// A bend spring of rest length L across a hinge shortens by kappa_n^2 L^3 / 32 under a normal
// curvature kappa_n along it; summed over springs whose directions are spread evenly (mean cos^8 =
// 35/128) with a third of each triangle's area per edge, the sheet carries M = B kappa^3 / kappa_ref^2.
double hinge_bend(const Continuum& c, double area_sum, double length) {
  const double k2 = reference_curvature(c) * reference_curvature(c);
  const double share = area_sum / 3.0;
  return 512.0 * (128.0 / 35.0) * c.bending * share / (k2 * std::pow(length, 6));
}

const std::vector<Preset>& presets() {
  static const std::vector<Preset> list = {
      {"cotton_shirting", "plain-weave cotton shirting (broadcloth), about 115 g/m^2", 11.5, 0.045, 0.55, 4.5,
       "representative KES-F values for cotton shirting; see docs/materials.md"},
      {"wool_suiting", "worsted wool men's suiting, about 220 g/m^2", 22.0, 0.10, 0.55, 6.0,
       "representative KES-F values for men's winter suiting; see docs/materials.md"},
      {"polyester_plain", "light plain-weave polyester, about 90 g/m^2", 9.0, 0.030, 0.35, 8.0,
       "representative KES-F values for polyester plain weaves; see docs/materials.md"},
      {"silk_crepe", "silk crepe de chine, about 60 g/m^2", 6.0, 0.015, 0.25, 8.0,
       "representative KES-F values for silk dress fabrics; see docs/materials.md"},
      {"denim", "heavy cotton denim (3/1 twill), about 400 g/m^2", 40.0, 0.90, 3.0, 4.0,
       "representative KES-F values for denim; see docs/materials.md"},
      {"cotton_jersey", "single cotton jersey (weft knit), about 150 g/m^2", 15.0, 0.025, 0.45, 40.0,
       "representative KES-F values for cotton single jersey; see docs/materials.md"},
      {"linen_plain", "plain-weave linen, about 180 g/m^2", 18.0, 0.18, 1.6, 4.0,
       "representative KES-F values for linen plain weaves; see docs/materials.md"},
  };
  return list;
}

const Preset* find_preset(std::string_view name) {
  for (const Preset& p : presets())
    if (p.name == name) return &p;
  return nullptr;
}

std::string preset_names() {
  std::string s;
  const auto& list = presets();
  for (size_t i = 0; i < list.size(); ++i) {
    if (i) s += i + 1 == list.size() ? " or " : ", ";
    s += list[i].name;
  }
  return s;
}

namespace {

struct ShotEnd {
  double moment, x, y;
};

// From the clamp (s = 0, level, moment m0) to the free end by RK4 on phi' = kappa(M),
// M' = -w (l - s) cos(phi); returns the moment left at the free end and where the end is.
ShotEnd shoot(double l, double w, double m0, const std::function<double(double)>& curvature, int n) {
  const double h = l / n;
  double phi = 0, m = m0, x = 0, y = 0, s = 0;
  auto dphi = [&](double mm) { return curvature(mm); };
  auto dm = [&](double ss, double p) { return -w * (l - ss) * std::cos(p); };
  for (int i = 0; i < n; ++i) {
    const double k1p = dphi(m), k1m = dm(s, phi);
    const double k2p = dphi(m + 0.5 * h * k1m), k2m = dm(s + 0.5 * h, phi + 0.5 * h * k1p);
    const double k3p = dphi(m + 0.5 * h * k2m), k3m = dm(s + 0.5 * h, phi + 0.5 * h * k2p);
    const double k4p = dphi(m + h * k3m), k4m = dm(s + h, phi + h * k3p);
    const double nphi = phi + h / 6 * (k1p + 2 * k2p + 2 * k3p + k4p);
    x += h * std::cos(0.5 * (phi + nphi)), y -= h * std::sin(0.5 * (phi + nphi));
    phi = nphi;
    m += h / 6 * (k1m + 2 * k2m + 2 * k3m + k4m);
    s += h;
  }
  return {m, x, y};
}

}  // namespace

double elastica_chord_angle(double length, double w, double bending, bool cubic, double kappa_ref) {
  const std::function<double(double)> curvature = [&](double m) {
    if (!cubic) return m / bending;
    return std::cbrt(m * kappa_ref * kappa_ref / bending);
  };
  // The clamp's moment lies between 0 and that of the strip held straight (w l^2 / 2): bisect on it
  // until the free end carries none.
  double lo = 0, hi = w * length * length;
  const int n = 2000;
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (shoot(length, w, mid, curvature, n).moment > 0) hi = mid;
    else lo = mid;
  }
  const ShotEnd e = shoot(length, w, 0.5 * (lo + hi), curvature, n);
  return std::atan2(-e.y, e.x) * 180.0 / kPi;
}

}  // namespace raycloth::fabric
