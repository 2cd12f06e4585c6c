// The scene description: plain "def" structs with defaults, filled from a JSON scene file
// (docs/scenes.md) or built in code. Nothing here simulates; see simulator.h.
#pragma once
#include <array>
#include <filesystem>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace raycloth {

using Float3 = std::array<float, 3>;

enum class Integrator { Explicit, Implicit };

struct TimeDef {
  double dt = 4e-4;        // seconds per step
  // A scene file without "dt" leaves the step to the mesh (Simulator): dt (or max_dt, when given),
  // or where the explicit step cannot take that, the largest step of two significant digits below
  // 0.9 of the mesh's limit. Scenes built in code give dt.
  bool dt_given = true;
  double max_dt = 0;       // seconds; 0: none given
  double duration = 3.0;   // simulated seconds
  double fps = 30.0;       // output frames per simulated second
  // The paper's explicit Euler (eq. 3; dt below its stability limit), or implicit Euler by vertex
  // block descent (sim/physics.h: stable at any dt), with its sweeps per step and the largest last
  // sweep's step (metres) counted as converged.
  Integrator integrator = Integrator::Explicit;
  int iterations = 10;
  double tolerance = 1e-4;
};

struct CollisionDef {
  float tolerance = 0.005f;  // ray length of the paper's collision rays, metres
  float thickness = 0.002f;  // distance kept from any surface, metres
  float friction = 0.4f;     // Coulomb coefficient
  bool cloth_cloth = true;   // cast against the cloth itself too
};

// A fabric's measurements in KES-F units (docs/materials.md): weight W (mg/cm^2), bending rigidity
// B (gf cm^2/cm), shear stiffness G (gf/(cm deg)), tensile strain EMT (%) at 500 gf/cm. A material
// with them gets its density and springs from them, each spring's stiffness computed from the mesh
// around it (src/fabric/kes.h), except for the fields given explicitly.
struct FabricDef {
  std::string preset;  // the named preset they started from ("" for none)
  double W = 0, B = 0, G = 0, EMT = 0;
};

struct MaterialDef {
  std::string name;
  std::optional<FabricDef> fabric;
  // A measured fabric by name (src/fabric/measured.h: "gray_interlock", ...): density and springs
  // from its data, warp and weft apart (each panel says where its warp runs), the stretch springs
  // stiffening with strain; density, stretch, shear and bend given explicitly override as above.
  std::string measured;
  // Which of density, stretch, shear and bend were given explicitly: with a fabric, only those
  // override what the measurements give.
  bool density_set = false, stretch_set = false, shear_set = false, bend_set = false;
  float density = 0.2f;      // kg / m^2
  float stretch = 200.0f;    // N/m, stiffness of stretch springs
  float shear = 40.0f;       // N/m
  float bend = 4.0f;         // N/m
  float damping = 1.0f;      // 1/s: viscous force -damping * m * v
  float spring_damping = 0.0f;  // N s/m along each spring (0 = the paper's model)
  // How the cloth resists bending: bend springs that skip a vertex (the paper's, `bend` N/m each),
  // or hinges across every interior edge with the measured fabric's bending rigidity (sim/model.h,
  // Hinge). Auto: hinges for a measured fabric whose `bend` is not given, bend springs otherwise.
  enum class Bending : uint8_t { Auto, Springs, Hinges };
  Bending bending = Bending::Auto;
  bool bends_by_hinges() const {
    return bending == Bending::Hinges || (bending == Bending::Auto && !measured.empty() && !bend_set);
  }
};

struct TransformDef {
  Float3 position{0, 0, 0};
  Float3 rotation{0, 0, 0};  // degrees, applied X then Y then Z
  Float3 scale{1, 1, 1};
};

// A circular arc from a segment's start to its end: the circle of `radius` through both ends
// (a radius under half the chord is taken as half the chord), the arc of more than 180 degrees when
// `large`, run counter-clockwise in the pattern's plane when `ccw` (centre left of the direction of
// travel for a small arc, so the arc bulges to the right of the chord).
struct OutlineArc {
  float radius = 0;  // metres
  bool large = false;
  bool ccw = false;
};

// One piece of a pattern outline: from `from` to the next segment's `from` (the last segment
// closes the outline), a straight line, a quadratic Bezier curve when `control` is given, a cubic
// one when `control2` is given too, or a circular arc when `arc` is given.
struct OutlineSegment {
  std::string name;                                // how seams, pins and attachments refer to it
  std::array<float, 2> from{0, 0};                 // metres, in the pattern's plane
  std::optional<std::array<float, 2>> control;     // curve control point (a cubic's first)
  std::optional<std::array<float, 2>> control2;    // a cubic's second control point
  std::optional<OutlineArc> arc;
};

// A sewing-pattern piece: a closed outline meshed to a target edge length. The pattern's plane
// (x, y) becomes the panel's local (x, y, 0) (y up, normal +z), or with `wrap_radius` the outline
// is wrapped around a vertical cylinder about the local y axis: x runs along the circumference,
// the piece's middle (x = 0) at local (0, y, radius), normal outwards.
struct PatternDef {
  std::vector<OutlineSegment> outline;
  float edge_length = 0.02f;                       // metres
  std::optional<float> wrap_radius;                // metres
};

enum class PanelShape { Rectangle, Mesh, Pattern };

// A panel. Rectangle: an l x n grid of mass points, u along width (local x), v along height
// (local z), in its local y = 0 plane, normal +y. Mesh: the triangles of an OBJ file (its
// coordinates are the rest shape). Pattern: see PatternDef.
struct PanelDef {
  std::string name;
  std::string material;
  PanelShape shape = PanelShape::Rectangle;
  float width = 1.0f, height = 1.0f;     // metres
  int resolution_u = 2, resolution_v = 2;  // vertices along u and v
  std::string mesh_file;                 // mesh: OBJ path (resolved against the scene file's folder)
  PatternDef pattern;                    // pattern
  TransformDef transform;
  // Where a measured fabric's warp runs, degrees: a rectangle's from u towards v, a pattern's from its
  // x axis towards its y axis, a mesh's (an OBJ) from its x axis towards -z about its y axis, each
  // triangle taking that direction laid into its plane. Only measured fabrics are anisotropic.
  float warp = 0;
  // Mesh and pattern panels: no vertex lighter than this share of the panel's median vertex mass
  // (the others give up the difference in proportion, the panel's mass unchanged). Slivers where a
  // short outline piece or a seam's inserted vertex meets the mesh otherwise leave vertices a
  // hundredth of the median, which the explicit step's limit follows. Garments placed on a body: 0.25.
  float min_mass_share = 0;
};

// A path of panel vertices: a rectangle's edge (left (u = 0), right (u = max), bottom (v = 0),
// top (v = max)), a pattern's outline segment by name, or a mesh panel's boundary from one vertex
// to another (OBJ vertex numbers from 0, following the boundary in the triangles' winding).
struct EdgeRef {
  std::string panel;
  std::string edge;
  std::string segment;
  std::optional<std::array<int, 2>> path;
};

// Seams join two paths. Paths of different lengths (patterns and meshes) are matched by arc
// length: each side gets the other side's vertices inserted where it has none near. Then each pair
// is sewn from apart (a stitch: a spring of rest length 0 between the two vertices, its rest length
// easing from the pair's start distance to 0 over sewing.close_time while collision acts; the
// panels' own triangles never span the gap) or, with weld_at_start, welded into one vertex at its
// midpoint in the first step.
struct SeamDef {
  EdgeRef a, b;
  bool reverse = false;     // pair a's first vertex with b's last
  float stiffness = 200.0f; // N/m, the stitches' springs (rest length 0)
  std::optional<bool> weld_at_start;  // unset: sewing.weld_at_start
};

// While seams close: every spring's rest length goes from its length in the placed start state to
// its length in the panel's own shape (a stitch's to 0) over close_time seconds (smoothstep), so
// panels placed apart are drawn together gently. 0: the rest lengths hold from the start.
// weld_at_start: the seams that do not say otherwise weld at the start instead of being sewn.
// A stitch whose two vertices are further apart than close_tolerance (metres; default twice the
// collision thickness, the contact keeping the two sides one thickness apart) at the end of the
// close time is an open seam: run.json lists it and the run warns.
// ease_gravity: gravity grows from 0 with the same smoothstep over the close time, so that panels
// placed around a body do not fall before their seams hold them (default: on when a seam is sewn
// from apart, off otherwise). gravity_waits: gravity is off while the seams close instead, and grows
// with a smoothstep over the next half of the close time (a garment hanging from its shoulders, eased
// in over the close time, slides down the body before its shoulder seams close). Default: on where a
// seam is sewn from apart (0.5.4; off before), as ease_gravity.
struct SewingDef {
  double close_time = 0.0;
  bool weld_at_start = false;
  std::optional<float> close_tolerance;
  std::optional<bool> ease_gravity;
  std::optional<bool> gravity_waits;
};

// Pins hold vertices in place: a corner ("bottom_left", ...), a whole edge or outline segment, or an
// index range [first, last] of the panel's vertices (index = v * resolution_u + u on a rectangle).
struct PinDef {
  std::string panel;
  std::string corner;
  std::string edge;
  std::string segment;
  std::optional<std::array<int, 2>> range;
};

// Cloth vertices that follow points of an obstacle's surface: each is pulled by a spring of rest
// length 0 (with damping along the relative velocity) to its body point, lifted `lift` metres
// along the surface normal. The body points are the given obstacle vertices (one per cloth vertex)
// or, when none are given, the nearest surface points at the start.
struct AttachmentDef {
  std::string panel;
  std::string edge, segment;
  std::optional<std::array<int, 2>> range;
  std::string obstacle;
  std::vector<int> obstacle_vertices;
  float stiffness = 50.0f;  // N/m
  float damping = 0.01f;    // N s/m
  float lift = 0.004f;      // metres
};

enum class ObstacleType { UvSphere, Box, Plane, Mesh, Skinned };

struct MotionDef {
  Float3 velocity{0, 0, 0};          // m/s
  Float3 angular_velocity{0, 0, 0};  // degrees/s about the obstacle's position
  double start = 0.0;                // simulated seconds before the motion starts
};

struct ObstacleDef {
  std::string name;
  ObstacleType type = ObstacleType::UvSphere;
  float radius = 0.5f;          // uv_sphere
  int slices = 24, stacks = 25; // uv_sphere
  Float3 size{1, 1, 1};         // box: full extents; plane: size[0] x size[2]
  std::string file;             // mesh: OBJ path; skinned: glTF path (resolved against the scene file's folder)
  // skinned: the animation (empty: the file's first), its playback speed, whether it loops, the
  // animation time at t = 0 (seconds; default the first key), and the time over which the pose goes
  // from the rest (bind) pose into the animation.
  std::string animation;
  float speed = 1.0f;
  bool loop = true;
  std::optional<double> offset;
  double blend_in = 0.0;
  // skinned: simulated seconds the body stands in its rest pose before the blend and the animation
  // begin (a garment settles on a standing body, then it walks).
  double hold = 0.0;
  // mesh and skinned: whether the step closes the mesh's openings (sim/holes: boundary loops small
  // against their piece) so that cloth cannot slip into an open body part; outputs and the exact
  // check see the mesh as it is.
  bool close_holes = true;
  // Which way the body faces in the scene (a horizontal direction; glTF's models face +z): garments
  // placed on it (garments[].body) are turned from their pattern's front (+z) to this.
  Float3 front{0, 0, 1};
  TransformDef transform;
  std::optional<MotionDef> motion;
};

// The camera of rendered images. Position and target left unset frame the whole scene by themselves.
struct CameraDef {
  std::optional<Float3> position;  // metres
  std::optional<Float3> target;    // metres
  float fov = 40.0f;               // vertical field of view, degrees
  int width = 1280, height = 720;  // pixels
  int samples = 4;                 // antialiasing samples per pixel
};

// What a run writes besides run.json and obstacles.obj.
struct OutputDef {
  std::vector<std::string> formats{"obj"};  // any of obj, ply, pc2, glb
  bool render = false;                      // images/frame_NNNN.png
  bool video = false;                       // video.mp4 from the images (needs ffmpeg)
  CameraDef camera;
};

// Names of the mesh formats a run can write, in the order `formats` accepts them.
inline constexpr std::array<std::string_view, 4> kOutputFormats{"obj", "ply", "pc2", "glb"};

// A garment placed on a body (garments[].body, sim/garment_fit.h): its panels arrive in the pattern
// file's own frame (GarmentCode's body: 1.72 m tall, feet at y = 0, neck line at 1.457 m, front +z)
// and are fitted at the start to obstacle `body` in its rest pose: turned to face its front, lifted
// so that the garment's anchor (the neck line for a garment that reaches above GarmentCode's chest,
// the waist otherwise) meets the body's, centred on its torso, then `position` added and each panel
// that starts inside or through the body moved out along its normal until it clears it.
struct GarmentFitDef {
  std::string body;               // obstacle name
  std::string field;              // "/garments/<i>": where errors point
  uint32_t first_panel = 0, num_panels = 0;  // into SceneDef::panels
  Float3 position{0, 0, 0};       // metres, added after the fit
  float rotation = 0;             // degrees about the vertical, after the fit
  bool clear = true;              // move panels out of the body
};

struct SceneDef {
  std::string name = "scene";
  std::string source;  // file it came from ("" for built-in)
  TimeDef time;
  Float3 gravity{0, -9.81f, 0};
  CollisionDef collision;
  std::vector<MaterialDef> materials;
  std::vector<PanelDef> panels;
  std::vector<SeamDef> seams;
  std::vector<PinDef> pins;
  SewingDef sewing;
  std::vector<AttachmentDef> attachments;
  std::vector<ObstacleDef> obstacles;
  std::vector<GarmentFitDef> garment_fits;
  OutputDef output;
};

// Parses a scene file; throws InputError naming the file, the JSON path and the reason.
SceneDef load_scene_file(const std::string& path);
// Parses scene text; `origin` names it in errors and resolves relative mesh paths.
SceneDef parse_scene(const std::string& text, const std::string& origin);
// Parses a scene already read as JSON (a sweep's case): `origin` names it in errors, `dir` resolves
// relative mesh paths.
SceneDef parse_scene(const nlohmann::json& scene, const std::string& origin, const std::filesystem::path& dir);
// The paper's experiment (scenes/seed_drape.json, compiled in).
SceneDef default_scene();
// Checks cross-references and ranges; throws InputError. parse_scene calls it.
void validate_scene(const SceneDef& scene);
// Checks the output section alone (the CLI's --format and --camera options go through it too);
// `source` names the file in errors.
void validate_output(const OutputDef& output, const std::string& source);

}  // namespace raycloth
