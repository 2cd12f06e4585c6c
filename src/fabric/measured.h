// Measured fabrics: the ten fabrics of Wang, Ramamoorthi and O'Brien, "Data-Driven Elastic Models
// for Cloth: Modeling and Measurement" (TOG 30(4), 2011), in the files the ARCSim simulator reads
// (assets/fabrics/wang2011/, compiled in, with their license beside them); the model those files
// define, as ARCSim evaluates it; and the mapping from that model to this model's springs, which
// carries warp and weft apart (docs/materials.md derives every formula here).
#pragma once
#include <array>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "raycloth/vec3.h"

namespace raycloth::fabric {

// The strain (stretch - 1) at which the files' rows 1-5 were sampled: ARCSim interpolates between
// row 0 (no strain) and them by (stretch - 1) * 6, clamped to [0, 1].
inline constexpr double kMeasuredStrain = 1.0 / 6.0;
// A sheet bent into a cylinder in ARCSim's model stores (1/2) (k_e / 4) kappa^2 per unit area, k_e
// the files' hinge coefficient (checked on equilateral and right-triangle meshes by
// tests/test_fabric_measured.cpp): the sheet's bending rigidity is k_e / 4.
inline constexpr double kHingeToSheet = 0.25;

// One ARCSim material file (docs/materials.md, "Measured fabrics").
struct MeasuredData {
  double density = 0;  // kg/m^2
  // N/m, [c0 warp, c1 warp-weft coupling, c2 weft, c3 shear]: row 0 at no strain; rows 1-5 at a
  // principal strain of 1/6 along 0, 22.5, 45, 67.5 and 90 degrees from the warp.
  std::array<std::array<double, 4>, 6> stretching{};
  // N m, ARCSim's hinge coefficient: rows by the hinge edge's direction from the warp (0, 45, 90
  // degrees), column j at ARCSim's curvature measure 10 j per metre.
  std::array<std::array<double, 5>, 3> bending{};
};

// Reads a file's text. Errors are InputError(file, JSON pointer, reason): not JSON, a missing or
// unknown field, rows of the wrong count or length, a number that is not finite, a density or a
// bending value not above 0.
MeasuredData parse_measured(std::string_view text, const std::string& file);

struct MeasuredFabric {
  std::string_view name;    // as a scene names it: "gray_interlock"
  std::string_view file;    // in assets/fabrics/wang2011/
  std::string_view use, fibre;
  std::string source;       // where the numbers come from
  MeasuredData data;
};
// The ten, read from the compiled-in files at first use.
const std::vector<MeasuredFabric>& measured_fabrics();
const MeasuredFabric* find_measured(std::string_view name);
// "a, b, c or d": their names, for error messages.
std::string measured_names();

// ---- The measured model, as ARCSim evaluates it (src/dde.cpp, src/physics.cpp of ARCSim 0.3) ----
// The four coefficients k = 2 c (N/m, negative ones taken as 0) at a principal strain (stretch - 1)
// along `angle` (radians from the warp; the model is symmetric about warp and weft).
std::array<double, 4> stretch_coefficients(const MeasuredData& d, double strain, double angle);
// The modulus under uniaxial strain along `angle` (held across): the forces ARCSim applies derive
// from W = k0 G00^2 / 2 + k1 G00 G11 + k2 G11^2 / 2 + k3 G01^2 (G the Green strain in the warp frame),
// so C(angle) = k0 c^4 + k2 s^4 + 2 (k1 + k3) c^2 s^2.
double strain_modulus(const std::array<double, 4>& k, double angle);
// Force per unpulled width (N/m) of a sheet stretched by `strain` along `angle` and held across:
// (1 + e) G C(angle), G = e + e^2 / 2, the coefficients at that strain and direction.
double measured_tension(const MeasuredData& d, double strain, double angle);
// The sheet's bending rigidity (N m) for a curvature along `angle` (radians from the warp): the
// hinge coefficient of hinges across that direction (interpolated between the rows as ARCSim does),
// at curvature column `column`, times kHingeToSheet.
double measured_bending(const MeasuredData& d, double angle, int column = 0);

// ---- To springs -----------------------------------------------------------------------------------
// A spring of stiffness k at no strain whose stiffness grows to k + dk at kMeasuredStrain (linearly
// in its strain, as the measured coefficients grow; constant beyond, as ARCSim clamps): the law is in
// stiffening.h. Families of parallel springs, each with its sheet stiffness rho = k l^2 / A (A the
// area the family's springs cover one each), are fitted so that the sheet pulls along each of
// `pulls` (radians from the warp, as many as families, at most 4) as the measured model does, at no
// strain (the moduli C) and at kMeasuredStrain (the tensions). A family that would need less than
// 2 % of the stiffest direction's modulus (or a negative one) gets that floor (`clamped` counts
// them) and the others are fitted with it fixed; at kMeasuredStrain likewise, the floor there at
// least half the family's stiffness at no strain (a spring whose force fell as it stretched would
// tear the sheet apart).
struct FamilyFit {
  std::vector<double> small, stiff;  // rho at no strain and at kMeasuredStrain, N/m
  int clamped = 0;
  bool solved = false;               // false: the directions left the system singular (small = stiff = 0)
};
FamilyFit fit_families(const MeasuredData& d, const std::vector<double>& families, const std::vector<double>& pulls);

// A rectangle's grid of hx x hy cells whose warp runs at `warp` (radians from u towards v): stretch
// springs along u and v, the diagonals a ((u,v)-(u+1,v+1)) and b ((u+1,v)-(u,v+1)), each with its
// added stiffness at kMeasuredStrain, and the bend springs along u and v for the bending rigidity
// along those directions (kes.cpp's bend mapping, the stretch springs giving up the bend springs' pull).
struct MeasuredGrid {
  double stretch_u = 0, stretch_v = 0, diag_a = 0, diag_b = 0;  // N/m at no strain
  double stiff_u = 0, stiff_v = 0, stiff_a = 0, stiff_b = 0;    // N/m added at kMeasuredStrain
  double bend_u = 0, bend_v = 0;
  int clamped = 0;
  // False where a row's stretch springs are weaker than the pull of its bend springs (4 k_bend):
  // they give up all they can and the grid is stiffer in the plane than measured along that row
  // (its cells too small for the fabric's bending). A stretch spring that softens with strain
  // (stiff < 0) can give up only down to k = -2 stiff: every stretch spring keeps a tangent
  // k + 2 stiff w >= 0 for w in [0, 1] (fabric/stiffening.h), or the row buckles in its plane.
  bool bend_fits = true;
};
// bend_springs false: the grid bends by hinges (sim/hinges.h), its stretch springs keep their whole
// stiffness and bend_u = bend_v = 0.
MeasuredGrid measured_grid(const MeasuredData& d, double density, double hx, double hy, double warp,
                           bool bend_springs = true);

// A triangle membrane's law (sim/membrane.h): a0, b0 along the warp, a2, b2 along the weft, the
// coupling k1, a3, b3 of the shear (stiffness a at no strain growing to a + b at `reach`, the Green
// strain of a pull to kMeasuredStrain: half of it for the shear) and reach. At no strain a = k of
// row 0 (the measured model in every direction); at kMeasuredStrain the measured tension along 0, 90
// and 45 degrees; b no less than -a / 2 (a stress that grows as it stretches). `fitted_45` is the
// 45-degree tension the law gives (N/m: the measured one unless the shear's floor bit).
struct MembraneLaw {
  std::array<float, 8> p{};
  double fitted_45 = 0, measured_45 = 0;
};
MembraneLaw membrane_law(const MeasuredData& d);

// The angle (radians) of `v` from `warp` laid into the plane of normal `normal`.
double angle_from_warp(Vec3 v, Vec3 normal, Vec3 warp);
// A triangle mesh's bend spring (kes.cpp's hinge_bend) for the rigidity along the spring's
// direction `angle` (radians from the warp).
double measured_hinge_bend(const MeasuredData& d, double density, double area_sum, double length, double angle);

}  // namespace raycloth::fabric
