// Fabrics from measurements: KES-F values (Kawabata Evaluation System) converted to SI, the named
// presets, and the mapping from a sheet's measured moduli to this model's springs for a given mesh
// (docs/materials.md derives every formula here).
#pragma once
#include <string>
#include <string_view>
#include <vector>

#include "raycloth/scene.h"

namespace raycloth::fabric {

inline constexpr double kGramForce = 9.80665e-3;  // N per gram-force
inline constexpr double kStandardGravity = 9.80665;  // m/s^2: the weight W turns into a load with it
inline constexpr double kPi = 3.14159265358979323846;
// The KES-F tensile test stops at 500 gf/cm; EMT is the strain there.
inline constexpr double kKesMaxLoad = 500.0;  // gf/cm
// The cantilever's bend springs are calibrated so that the mass-spring strip bends to the test's
// 41.5 degrees at an overhang of 2c, c = (B / w)^(1/3): kappa_ref = kBendCalibration / c (see
// reference_curvature and docs/materials.md; tests/test_fabric.cpp re-derives the constant).
inline constexpr double kBendCalibration = 0.8028;
inline constexpr double kCantileverAngle = 41.5;  // degrees (ASTM D1388, ISO 9073-7)

// KES units to SI.
inline double weight_to_density(double w_mg_per_cm2) { return w_mg_per_cm2 * 1e-6 / 1e-4; }     // -> kg/m^2
inline double bending_to_si(double b_gf_cm2_per_cm) { return b_gf_cm2_per_cm * kGramForce * 1e-2; }  // -> N m
inline double shear_to_si(double g_gf_per_cm_deg) { return g_gf_per_cm_deg * kGramForce / 1e-2 * 180.0 / kPi; }  // -> N/m per radian
// The secant tensile modulus of the KES curve: 500 gf/cm over the strain EMT (%) there, N/m.
inline double emt_to_modulus(double emt_percent) { return kKesMaxLoad * kGramForce / 1e-2 / (emt_percent / 100.0); }

// A sheet's moduli in SI: areal density (kg/m^2), bending rigidity (N m), in-plane shear modulus
// (N/m), tensile modulus (N/m).
struct Continuum {
  double density = 0, bending = 0, shear = 0, tensile = 0;
};
Continuum to_continuum(const FabricDef& f);

// Bending length c = (B / (rho g))^(1/3), metres, and the curvature the bend springs are matched at.
double bending_length(const Continuum& c);
double reference_curvature(const Continuum& c);

// The springs of a rectangle's grid of hx x hy cells (metres): stretch along u and v, each cell's
// two diagonals, and the bend springs that skip a vertex along u and v (N/m each).
struct GridSprings {
  double stretch_u = 0, stretch_v = 0, shear = 0, bend_u = 0, bend_v = 0;
};
GridSprings grid_springs(const Continuum& c, double hx, double hy);
// A grid row's stretch springs (k_stretch in, k_stretch' out) and bend springs (out) for a wanted
// bending stiffness k: the bend springs' pull taken off the stretch springs, the stretch springs'
// give taken into the bend springs (see kes.cpp).
void share_with_bend(double& stretch, double& bend, double k);
// 4 k / k_stretch along u for cells of hx x hy, k the bend springs' wanted stiffness: above 1/4
// the bend springs cannot carry the measured rigidity (share_with_bend); the finest grid a fabric
// can have is where it reaches that.
double bend_stretch_ratio(const Continuum& c, double hx, double hy);
// A triangle mesh's stretch spring on an edge of rest length `length` whose triangles have areas
// summing to `area_sum` (one triangle on a boundary), and its bend spring of rest length `length`
// across an edge whose two triangles have areas summing to `area_sum`.
double edge_stretch(const Continuum& c, double area_sum, double length);
double hinge_bend(const Continuum& c, double area_sum, double length);

// A named fabric with its measurements and where they come from.
struct Preset {
  std::string_view name, description;
  double W, B, G, EMT;           // KES units: mg/cm^2, gf cm^2/cm, gf/(cm deg), %
  std::string_view source;       // docs/materials.md has the full references
};
const std::vector<Preset>& presets();
const Preset* find_preset(std::string_view name);
// "a, b, c or d": the preset names, for error messages.
std::string preset_names();

// The heavy elastica: a cantilever of length l (m), weight w per unit area (N/m^2), clamped
// level at one end, with a moment law M(kappa) per unit width. Returns the angle (degrees) below
// the horizontal of the chord from the clamp to the free end. `cubic` selects the law of this model's
// bend springs, M = B kappa^3 / kappa_ref^2; otherwise M = B kappa.
double elastica_chord_angle(double length, double w, double bending, bool cubic, double kappa_ref = 0);

}  // namespace raycloth::fabric
