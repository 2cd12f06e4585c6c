// The standard fabric tests, simulated: the cantilever bending test (ASTM D1388 / ISO 9073-7), the
// Cusick drape test (ISO 9073-9 / BS 5058) and a uniaxial pull. Each builds a scene from a material,
// runs the simulator to rest, and measures what the standard measures (docs/materials.md).
// The lab sits above the simulator (it runs it); src/fabric/ below the scene only maps measurements
// to springs.
#pragma once
#include <filesystem>
#include <string>
#include <vector>

#include "raycloth/scene.h"
#include "raycloth/vec3.h"

namespace raycloth::lab {

// How a test steps: the integrator, its time step (0: half the explicit step's stability limit,
// or 2 ms implicit), sweeps per implicit step, simulated seconds to settle, and viscous damping (1/s).
struct Stepping {
  Integrator integrator = Integrator::Explicit;
  double dt = 0;
  int iterations = 30;
  double settle = 1.0;
  double damping = 20.0;
};

// ---- Cantilever: the strip, 2.5 cm wide, clamped level at the platform's edge, hangs over it; the
// overhang is searched until the chord from the edge to the tip falls 41.5 degrees; the bending
// length is half the overhang and the flexural rigidity G = W c^3.
struct CantileverOptions {
  // Grid cells along the overhang; 0: 16, or fewer where the bend springs would be too stiff for
  // the stretch springs under them (4 k_bend / k_stretch above 0.2: see fabric::share_with_bend).
  int segments = 0;
  double width = 0.025;  // metres
  double tolerance = 0.1;  // degrees off 41.5 at which the search stops
  int max_tries = 8;
  // Also search with half the segments and extrapolate the bending length to fine cells (Richardson:
  // the strip's error is first order in the cell length; docs/materials.md).
  bool extrapolate = true;
  // Where the warp runs from the strip's length, degrees (measured fabrics: 0 cuts the strip along
  // the warp, 90 along the weft).
  double warp = 0;
  Stepping stepping;
};
struct CantileverTry {
  double overhang = 0, angle = 0;  // metres, degrees below the horizontal
};
struct CantileverResult {
  double overhang = 0;        // metres, at 41.5 degrees
  double bending_length = 0;  // metres, c = overhang / 2 (extrapolated when asked)
  double bending_length_fine = 0, bending_length_coarse = 0;  // metres, at segments and segments / 2
  double flexural_rigidity = 0;  // G = W c^3, mg cm (KES W in mg/cm^2, c in cm)
  double predicted = 0;       // metres, (B / W)^(1/3) from the material's own measurements
  std::vector<CantileverTry> tries;
  int segments = 0;           // cells along the overhang, as chosen
  uint64_t steps = 0;
};
// The strip's chord angle (degrees) at rest for one overhang (metres).
double cantilever_angle(const MaterialDef& material, double overhang, const CantileverOptions& options,
                        uint64_t* steps = nullptr);
CantileverResult cantilever_test(const MaterialDef& material, const CantileverOptions& options = {});

// ---- Cusick drape: a 30 cm disc clamped between two 18 cm disks; the drape coefficient is the
// shadow's area beyond the disk over the specimen's: (A_shadow - A_disk) / (A_specimen - A_disk).
struct DrapeOptions {
  double specimen_radius = 0.15, disk_radius = 0.09;
  int sectors = 96;         // vertices around each ring
  double ring_spacing = 0.006;  // metres between rings outside the disk
  double perturbation = 2e-4;   // metres: a small seeded vertical noise that lets the folds choose where to form
  uint32_t seed = 12345u;       // of that noise
  bool gravity = true;          // false: the specimen stays flat (the test of the shadow's area)
  Stepping stepping;
};
struct DrapeResult {
  double shadow_area = 0;       // m^2
  double drape_coefficient = 0; // 0..1
  int folds = 0;
  double min_radius = 0, max_radius = 0;  // metres, the rim's projected distance from the axis
  uint64_t steps = 0;
  std::vector<Vec3> positions;      // the specimen at rest
  std::vector<uint32_t> triangles;
};
// The specimen's mesh as an OBJ (rings of `sectors` vertices, the clamped ones first); returns how
// many vertices the disks clamp.
uint32_t write_drape_specimen(const std::filesystem::path& obj, const DrapeOptions& options);
SceneDef drape_scene(const MaterialDef& material, const std::filesystem::path& specimen_obj, const DrapeOptions& options);
DrapeResult drape_test(const MaterialDef& material, const DrapeOptions& options = {});
// The drape test as a scene file `raycloth run` takes: dir/scene.json with the specimen dir/specimen.obj
// and the 18 cm support disk dir/disk.obj (a 1 cm thick cylinder under the clamped part) on a column, the
// material by its preset name, the time step the test takes; one frame at the start, one at rest.
void write_drape_scene(const MaterialDef& material, const DrapeOptions& options, const std::filesystem::path& dir);
// The area of the union of the triangles' shadows on the horizontal plane (m^2), rasterised at
// `pixel` metres.
double shadow_area(const std::vector<Vec3>& x, const std::vector<uint32_t>& triangles, double pixel = 5e-4);
// Folds: the rim's local maxima of distance from the axis, at least `separation` degrees apart and
// `prominence` metres above the lowest rim point between them.
int count_folds(const std::vector<Vec3>& rim, double prominence = 0.003);

// ---- Uniaxial pull: a 5 cm x 5 cm specimen (a sewing pattern, meshed in triangles) clamped along
// two edges, pulled to each strain, and the clamp's force per width measured at rest.
struct TensileOptions {
  // edge: the triangles' target edge, metres; 0: 5 mm, or longer (by 1.25 each time) while the bend
  // springs would hold more than 0.3 of the in-plane stiffness (the model's stretch springs give it
  // up only to half; docs/materials.md).
  double length = 0.05, width = 0.05, edge = 0;
  std::vector<double> strains{0.01, 0.02, 0.03, 0.04, 0.05};
  Stepping stepping;
};
struct TensilePoint {
  double strain = 0, stress = 0;  // stress in N/m (force per width)
  double edge = 0;                // metres, the mesh's target edge
};
std::vector<TensilePoint> tensile_test(const MaterialDef& material, const TensileOptions& options = {});

// ---- Pull along a direction, held across (measured fabrics): a square (a grid, or a sewing pattern
// in triangles) whose warp runs `angle` degrees from the pull, every side clamped on the map
// x -> ((1 + e) x, y): stretched by e along the pull and held across. At rest, the force across the
// middle line per unstretched width against the measured model's at that strain and direction
// (fabric::measured_tension): both sides under the same deformation.
struct DirectionalOptions {
  double size = 0.05;  // metres
  // The grid's cell (or the triangles' target edge), metres; 0: 5 mm (triangles: longer, by 1.25
  // each time, while the bend springs would hold more than 0.3 of the in-plane stiffness).
  double edge = 0;
  // A grid's four spring directions follow any warp and weft; a triangle mesh of a measured fabric
  // carries the measured model on each triangle (sim/membrane.h; docs/materials.md).
  bool grid = true;
  std::vector<double> strains{1.0 / 12.0, 1.0 / 6.0};
  Stepping stepping{Integrator::Explicit, 0, 30, 0.2, 20.0};
};
struct DirectionalPoint {
  double strain = 0, angle = 0;  // angle: degrees from the warp to the pull
  double tension = 0;            // N/m, simulated
  double measured = 0;           // N/m, the measured model
  double edge = 0;               // metres, the mesh's target edge
};
std::vector<DirectionalPoint> directional_tensile(const MaterialDef& material, double angle, const DirectionalOptions& options = {});

// The material of a preset (density and springs from its measurements), named after it: a KES-F
// preset or a measured fabric.
MaterialDef preset_material(const std::string& name);

}  // namespace raycloth::lab
