// Seams sewn from apart (stitches whose pull eases in while collision acts) and garments placed on
// a body from the pattern file alone (sim/garment_fit.h): the stitches close without crossing, the
// fit puts the neck line at the body's, a panel through the body is moved clear, and every new
// message word for word.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "core/bytes.h"
#include "fixtures.h"
#include "raycloth/error.h"
#include "raycloth/simulator.h"
#include "sim/garment_fit.h"
#include "sim/model.h"
#include "sim/model_check.h"
#include "sim/seams.h"

using namespace raycloth;
namespace fs = std::filesystem;

namespace {

// A w x w pattern square (bottom, right, top, left) meshed at e, standing in the x-y plane at `at`.
PanelDef square(const std::string& name, float w, float e, Float3 at) { return test::rect_pattern(name, w, w, e, at); }

// Two 0.2 m squares side by side with a 10 cm gap, no gravity; a's right side sewn to b's left
// (closing over 0.4 s).
SceneDef two_squares_sewn() {
  SceneDef s = test::panel_scene(2, 0.1f, 0.0f, 1.0f);
  s.time.dt = 2e-4;
  s.gravity = {0, 0, 0};
  s.panels = {square("a", 0.2f, 0.025f, {-0.15f, 0.5f, 0}), square("b", 0.2f, 0.025f, {0.15f, 0.5f, 0})};
  SeamDef seam;
  seam.a = {"a", "", "right", std::nullopt};
  seam.b = {"b", "", "left", std::nullopt};
  seam.reverse = true;
  s.seams.push_back(seam);
  s.sewing.close_time = 0.4;
  return s;
}

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("raycloth_sewing_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

void write(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

// One box's OBJ lines: centred on (cx, z = 0), half width hx, half depth hz, from y0 to y1, its first
// vertex numbered `base` (1-based), faces wound outward.
std::string box_obj(float cx, float hx, float hz, float y0, float y1, int base) {
  std::string s;
  for (int k = 0; k < 8; ++k) s += fmt::format("v {} {} {}\n", cx + ((k & 1) ? hx : -hx), (k & 2) ? y1 : y0, (k & 4) ? hz : -hz);
  const int f[12][3] = {{0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}, {0, 1, 5}, {0, 5, 4},
                        {2, 6, 7}, {2, 7, 3}, {0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}};
  for (const auto& t : f) s += fmt::format("f {} {} {}\n", base + t[0], base + t[1], base + t[2]);
  return s;
}

// An OBJ of boxes stacked on the y axis: {half width (x), half depth (z), bottom, top} each.
std::string boxes_obj(const std::vector<std::array<float, 4>>& boxes) {
  std::string s;
  int base = 1;
  for (const auto& [hx, hz, y0, y1] : boxes) s += box_obj(0.0f, hx, hz, y0, y1, base), base += 8;
  return s;
}

// A GarmentCode file of one square panel (side `cm`) standing in its x-y plane, its bottom edge's
// middle at `at` (cm).
std::string one_panel(float cm, std::array<float, 3> at) {
  return fmt::format(R"({{"pattern": {{"panels": {{"front": {{"translation": [{}, {}, {}], "rotation": [0, 0, 0],
    "vertices": [[{}, 0], [{}, 0], [{}, {}], [{}, {}]],
    "edges": [{{"endpoints": [0, 1]}}, {{"endpoints": [1, 2]}}, {{"endpoints": [2, 3]}}, {{"endpoints": [3, 0]}}]}}}},
    "stitches": []}}, "properties": {{"units_in_meter": 100, "curvature_coords": "relative"}}}})",
                     at[0], at[1], at[2], -cm / 2, cm / 2, cm / 2, cm, -cm / 2, cm);
}

// A scene on a body made of boxes (torso 0.4 x 0.24 up to 1.45 m, neck 0.1 wide to 1.6 m, head to
// 1.75 m), facing +z, with one garment read from `garment_file`.
std::string body_scene(const std::string& garment_extra) {
  return R"({"time": {"dt": 0.0002, "duration": 0.01},
    "materials": [{"name": "m", "density": 0.2, "stretch": 100, "shear": 40, "bend": 2}],
    "garments": [{"garmentcode": "g.json", "material": "m", "edge_length": 0.04)" +
         garment_extra + R"(}],
    "sewing": {"close_time": 0.3},
    "obstacles": [{"name": "body", "type": "mesh", "file": "body.obj"}]})";
}

const std::vector<std::array<float, 4>> kBody = {{0.2f, 0.12f, 0.0f, 1.45f}, {0.05f, 0.05f, 1.45f, 1.6f}, {0.1f, 0.1f, 1.6f, 1.75f}};

// A body standing with its feet apart: two legs (0.12 m across, 0.08 m deep, their outer sides 0.23 m
// out) up to 0.8 m under a narrow torso, neck and head, facing +z.
const float kLegOuter = 0.23f;
std::string legs_apart_obj() {
  return boxes_obj({{0.12f, 0.08f, 0.8f, 1.45f}, {0.05f, 0.05f, 1.45f, 1.6f}, {0.1f, 0.1f, 1.6f, 1.75f}}) +
         box_obj(-0.17f, 0.06f, 0.04f, 0.0f, 0.8f, 25) + box_obj(0.17f, 0.06f, 0.04f, 0.0f, 0.8f, 33);
}

// A straight skirt of two 46 x 50 cm panels 20 cm in front of and behind the middle, its top at
// GarmentCode's waist, sewn at both sides: its sides do not clear the legs (0.92 m around them: 1.08 m).
std::string straight_skirt() {
  const std::string sq = R"("vertices": [[-23, 0], [23, 0], [23, 50], [-23, 50]],
    "edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": [2, 3]}, {"endpoints": [3, 0]}])";
  return R"({"pattern": {"panels": {
    "front": {"translation": [0, 58.8, 20], "rotation": [0, 0, 0], )" + sq + R"(},
    "back": {"translation": [0, 58.8, -20], "rotation": [0, 180, 0], )" + sq + R"(}},
    "stitches": [[{"panel": "front", "edge": 1}, {"panel": "back", "edge": 3}],
                 [{"panel": "front", "edge": 3}, {"panel": "back", "edge": 1}]]},
    "properties": {"units_in_meter": 100, "curvature_coords": "relative"}})";
}

// Whether the segment a-b passes through one of the legs (sampled every 2 mm).
bool through_a_leg(Vec3 a, Vec3 b) {
  for (int k = 0; k <= 200; ++k) {
    const Vec3 p = a + (b - a) * (float(k) / 200.0f);
    if (p.y < 0.8f && std::abs(p.z) < 0.04f && std::abs(std::abs(p.x) - 0.17f) < 0.06f) return true;
  }
  return false;
}

// A garment file fitted on the legs-apart body (in folder d): its scene, its model after the fit and
// the fit of each panel.
struct Fitted {
  SceneDef scene;
  ClothModel model;
  std::vector<PanelFit> fits;
};
Fitted fit_on_legs(const fs::path& d, const std::string& garment) {
  write(d / "body.obj", legs_apart_obj());
  write(d / "g.json", garment);
  Fitted r;
  r.scene = parse_scene(body_scene(", \"body\": \"body\""), (d / "scene.json").string());
  r.model = build_cloth_model(r.scene);
  const ObstacleSet o = build_obstacles(r.scene);
  r.fits = fit_garments(r.model, o, r.scene);
  return r;
}

// Two 30 x 20 cm panels a and b of one garment file, standing in their x-y planes with their bottom
// edges' middles at `at_a` and `at_b` (cm), sewn as `stitches` says (a GarmentCode stitches list),
// meshed at `edge_length` and fitted on the box body (in folder d).
Fitted fit_two_squares(const fs::path& d, std::array<float, 3> at_a, std::array<float, 3> at_b, const std::string& stitches,
                       float edge_length) {
  write(d / "body.obj", boxes_obj(kBody));
  const std::string sq = R"("rotation": [0, 0, 0], "vertices": [[-15, 0], [15, 0], [15, 20], [-15, 20]],
    "edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": [2, 3]}, {"endpoints": [3, 0]}])";
  write(d / "g.json", fmt::format(R"({{"pattern": {{"panels": {{
    "a": {{"translation": [{}, {}, {}], {}}},
    "b": {{"translation": [{}, {}, {}], {}}}}},
    "stitches": {}}}, "properties": {{"units_in_meter": 100, "curvature_coords": "relative"}}}})",
                                  at_a[0], at_a[1], at_a[2], sq, at_b[0], at_b[1], at_b[2], sq, stitches));
  std::string text = body_scene(", \"body\": \"body\"");
  const std::string edge = "\"edge_length\": 0.04";
  text.replace(text.find(edge), edge.size(), fmt::format("\"edge_length\": {}", edge_length));
  Fitted r;
  r.scene = parse_scene(text, (d / "scene.json").string());
  r.model = build_cloth_model(r.scene);
  const ObstacleSet o = build_obstacles(r.scene);
  r.fits = fit_garments(r.model, o, r.scene);
  return r;
}

// The stitches that start beside the legs (below 0.8 m); each one that starts through a leg fails.
size_t stitches_beside_the_legs(const ClothModel& m) {
  size_t low = 0;
  for (size_t k = 0; k < m.stitch_seam.size(); ++k) {
    const Vec3 a = m.initial_positions[m.stitches[2 * k]], b = m.initial_positions[m.stitches[2 * k + 1]];
    low += a.y < 0.8f;
    EXPECT_FALSE(through_a_leg(a, b)) << "stitch " << k << " at y " << a.y;
  }
  return low;
}

}  // namespace

TEST(Sewing, StitchesCloseTwoPanelsPlacedTenCentimetresApartWithoutCrossing) {
  const SceneDef s = two_squares_sewn();
  Simulator sim(s);
  const ClothModel& m = sim.model();
  // Not welded: every pair is a stitch, the panels keep their own vertices.
  for (uint32_t i = 0; i < m.num_vertices(); ++i) ASSERT_EQ(m.alias[i], i);
  ASSERT_GE(m.stitch_seam.size(), 9u);
  EXPECT_NEAR(largest_stitch_gap(m, sim.positions()), 0.1f, 1e-5f);
  // The report of an open seam: every stitch open, the widest one's two ends (run.json's
  // largest_gap_at is their middle).
  const float tol = seam_close_tolerance(s);
  const std::vector<SeamGap> open = seam_gaps(m, sim.positions(), tol);
  ASSERT_EQ(open.size(), 1u);
  EXPECT_EQ(open[0].open, open[0].stitches);
  EXPECT_EQ(size_t(open[0].stitches), m.stitch_seam.size());
  EXPECT_NEAR(length(open[0].a - open[0].b), open[0].largest, 1e-6f);
  EXPECT_NEAR(open[0].largest, 0.1f, 1e-5f);
  // Every step checked exactly while the seam closes, then held for 0.2 s more.
  ASSERT_EQ(test::step_checked(sim, 3000, 1), "");
  EXPECT_LE(largest_stitch_gap(m, sim.positions()), tol);
  // Closed by the end of the close time, every stitch was welded into one vertex then.
  EXPECT_EQ(sim.stitches_welded(), m.stitch_seam.size());
  size_t joined = 0;
  for (uint32_t i = 0; i < m.num_vertices(); ++i) joined += m.alias[i] != i;
  EXPECT_EQ(joined, m.stitch_seam.size());
  for (const SeamGap& g : seam_gaps(m, sim.positions(), tol)) {
    EXPECT_LE(g.largest, tol) << "seam " << g.seam;
    EXPECT_EQ(g.open, 0u) << "seam " << g.seam;
  }
  // The two panels stay side by side: the sewn width is the two widths.
  float lo = 1e9f, hi = -1e9f;
  for (const Vec3& p : sim.positions()) lo = std::min(lo, p.x), hi = std::max(hi, p.x);
  EXPECT_NEAR(hi - lo, 0.4f, 0.01f);
}

// Two 0.3 x 0.6 m panels hung 10 cm in front of and behind a horizontal bar (4 cm square, its top at
// 1.02 m), their tops 8 cm above it and sewn together, closing over 0.5 s under gravity: a garment
// hanging from its shoulders. Where gravity waits for the seam (sewing.gravity_waits, sim/backend.h)
// the seam closes over the bar and the panels hang from it. Eased in over the close time, the panels
// slid 7 cm down before they met the bar, the seam closed under it (the stitches are springs that
// pull straight through a body) and the sewn panels fell off (checked: the stitches at y = 0.09 m).
namespace {

SceneDef panels_over_a_bar() {
  SceneDef s = test::panel_scene(2, 0.1f, 0.0f, 1.0f);
  s.time.dt = 2e-4;
  s.panels = {test::rect_pattern("front", 0.3f, 0.6f, 0.025f, {0, 0.5f, 0.1f}),
              test::rect_pattern("back", 0.3f, 0.6f, 0.025f, {0, 0.5f, -0.1f})};
  s.obstacles.push_back(test::box_obstacle({0.5f, 0.04f, 0.04f}, {0, 1.0f, 0}));
  SeamDef seam;
  seam.a = {"front", "", "top", std::nullopt};
  seam.b = {"back", "", "top", std::nullopt};
  s.seams.push_back(seam);
  s.sewing.close_time = 0.5;
  return s;
}

// The lowest stitch after 1 s, every 100th step checked exactly.
float lowest_stitch_after_a_second(const SceneDef& s) {
  Simulator sim(s);
  EXPECT_TRUE(sim.model().ease_gravity);
  EXPECT_EQ(test::step_checked(sim, 5000, 100), "");
  const ClothModel& m = sim.model();
  EXPECT_LE(largest_stitch_gap(m, sim.positions()), seam_close_tolerance(s));
  float lowest = INFINITY;
  for (size_t k = 0; k < m.stitch_seam.size(); ++k) lowest = std::min(lowest, sim.positions()[m.stitches[2 * k]].y);
  return lowest;
}

}  // namespace

TEST(Sewing, PanelsHungFromASeamOverABarCloseOverItNotUnderIt) {
  // sewing.gravity_waits, the default since 0.5.4: every stitch lies on the bar's top (1.02 m), none
  // under it.
  const SceneDef waits = panels_over_a_bar();
  EXPECT_GT(lowest_stitch_after_a_second(waits), 1.02f);
  // With gravity eased in over the close time (the default until 0.5.3): they slide off.
  SceneDef eased = panels_over_a_bar();
  eased.sewing.gravity_waits = false;
  EXPECT_LT(lowest_stitch_after_a_second(eased), 0.5f);
}

TEST(Sewing, WeldAtStartKeepsOneVertexPerPairAndPairsThatStartTogetherWeld) {
  SceneDef s = two_squares_sewn();
  s.seams[0].weld_at_start = true;
  ClothModel welded = build_cloth_model(s);
  EXPECT_TRUE(welded.stitches.empty());
  EXPECT_EQ(welded.spring_counts[size_t(SpringType::Seam)], 0u);
  // Edge to edge (no gap): closed already, welded without being asked.
  s.seams[0].weld_at_start.reset();
  s.panels[1].transform.position = {0.2f, 0.5f, 0};
  s.panels[0].transform.position = {0.0f, 0.5f, 0};
  ClothModel touching = build_cloth_model(s);
  EXPECT_TRUE(touching.stitches.empty());
  size_t joined = 0;
  for (uint32_t i = 0; i < touching.num_vertices(); ++i) joined += touching.alias[i] != i;
  EXPECT_GE(joined, 9u);
}

// Stitches close at different times, so the model is welded again at each weld check. Partners of
// an earlier weld have given their mass to their representative; welding again must not take their
// zero inverse mass for a pin (it once did: every seam closed before the last weld check was nailed
// in place, and a garment on a walking body stayed where it was while he walked through it).
TEST(Sewing, WeldingAgainAsStitchesCloseLeavesEveryGroupFree) {
  SceneDef s = two_squares_sewn();
  PinDef pin;  // one real pin: it must still pin its group
  pin.panel = "a";
  pin.segment = "top";
  s.pins.push_back(pin);
  ClothModel m = build_cloth_model(s);
  ASSERT_GE(m.stitches.size(), 6u);
  double mass = 0;
  for (float w : m.mass) mass += w;
  auto weld_pair = [&](size_t k) {  // as Simulator::weld_closed_stitches joins a closed stitch
    const uint32_t ra = m.alias[m.stitches[2 * k]], rb = m.alias[m.stitches[2 * k + 1]];
    const uint32_t lo = std::min(ra, rb), hi = std::max(ra, rb);
    for (uint32_t& r : m.alias)
      if (r == hi) r = lo;
    weld_seams(m);
    build_adjacency(m);
  };
  weld_pair(0);
  weld_pair(1);
  weld_pair(2);
  double after = 0;
  for (float w : m.mass) after += w;
  EXPECT_NEAR(after, mass, 1e-6 * mass);
  size_t pinned = 0, pinned_on_top = 0;
  for (uint32_t i = 0; i < m.num_vertices(); ++i) {
    if (m.alias[i] != i) continue;
    EXPECT_GT(m.mass[i], 0.0f) << "vertex " << i;
    if (m.inv_mass[i] != 0.0f) continue;
    ++pinned;
    pinned_on_top += m.initial_positions[i].y > 0.69f;  // a's top edge, at y = 0.7
  }
  EXPECT_GT(pinned, 0u);
  EXPECT_EQ(pinned, pinned_on_top) << "a group welded from a closed stitch is pinned";
}

// The two squares sewn, their stitches not pulling (only the weld check closes them), panel b moved
// onto a's right side so that every stitch is closed but `open` of them in the middle, whose b sides
// stand 9 mm off: beyond the 6 mm tolerance, nearer than the welded stitches either side are to each
// other (25 mm or more). Then stepped to the first weld check: how many stitches of how many are
// welded, and whether 50 further steps are clean (checked every 10).
namespace {
struct OpenInTheMiddle {
  size_t welded = 0, count = 0;
  std::string after;
};
OpenInTheMiddle weld_with_open_in_the_middle(size_t open) {
  SceneDef s = two_squares_sewn();
  s.sewing.close_time = 0;
  s.seams[0].stiffness = 1e-6f;
  Simulator sim(s);
  const ClothModel& m = sim.model();
  OpenInTheMiddle r;
  r.count = m.stitch_seam.size();
  if (r.count < open + 4) return r;
  std::vector<Vec3> x = sim.positions();
  for (Vec3& p : x)
    if (p.x > 0) p.x -= 0.1f;
  for (size_t k = r.count / 2; k < r.count / 2 + open; ++k) {
    const uint32_t side_b = x[m.stitches[2 * k]].x > -0.05f ? m.stitches[2 * k] : m.stitches[2 * k + 1];
    x[side_b].z += 0.009f;
  }
  sim.set_state(x, std::vector<Vec3>(x.size(), make_vec3(0, 0, 0)));
  sim.step(int(std::lround(0.002 / s.time.dt)));  // to the first weld check
  r.welded = sim.stitches_welded();
  r.after = test::step_checked(sim, 50, 10);
  return r;
}
}  // namespace

// A stitch still open between two welded neighbours is welded with them at the next weld check, when
// it is no wider than they are apart: where its two sides lie crossed, the bound lets them touch but
// never pass, and they froze there (the pencil dress's skirt on the walking man: four vertices, from
// 0.45 s to the end, one of them inside a thigh once he walked).
TEST(Sewing, AStitchLeftOpenBetweenTwoWeldedOnesIsWeldedWithThem) {
  const OpenInTheMiddle r = weld_with_open_in_the_middle(1);
  ASSERT_GE(r.count, 5u);
  EXPECT_EQ(r.welded, r.count);
  EXPECT_EQ(r.after, "");
}

TEST(Sewing, StitchesLeftOpenInARunBetweenTwoWeldedOnesAreWeldedWithThem) {
  // As above with two neighbouring stitches left open (rand_1KMN65OI4O's gathered cuff left four).
  const OpenInTheMiddle r = weld_with_open_in_the_middle(2);
  ASSERT_GE(r.count, 6u);
  EXPECT_EQ(r.welded, r.count);
  EXPECT_EQ(r.after, "");
}

// A weld moves both sides of a stitch to their centre, a jump nothing bounded. Here a third sheet
// lies between the sides (1 mm above a, b 5 mm above a): welding would drag a's seam through it, so
// the welds are put off, and the run stays uncrossed on every step.
TEST(Sewing, AWeldThatWouldPutTheSeamThroughClothIsPutOff) {
  SceneDef s = two_squares_sewn();
  s.sewing.close_time = 0;
  s.sewing.close_tolerance = 0.006f;
  s.collision.thickness = 0.0005f;
  s.seams[0].stiffness = 1e-6f;  // the stitches do not pull: only the weld check closes them
  s.time.dt = 1e-4;              // c's small cells
  s.panels[1].transform.position = {0.05f, 0.5f, 0.005f};                                // b's left side 5 mm behind a's right
  s.panels.push_back(test::rect_pattern("c", 0.06f, 0.2f, 0.02f, {-0.05f, 0.5f, 0.001f}));  // between them
  Simulator sim(s);
  ASSERT_EQ(sim.stitches_welded(), 0u);
  EXPECT_EQ(test::step_checked(sim, 50, 1), "");  // two weld checks
  EXPECT_GT(sim.welds_put_off(), 0u);
}

// Nor may a weld put the welded vertex inside a body: here a 4 mm slab stands between the two sides
// (1 mm from each), so their centre would be inside it; the welds are put off.
TEST(Sewing, AWeldThatWouldPutTheSeamInsideABodyIsPutOff) {
  SceneDef s = two_squares_sewn();
  s.sewing.close_time = 0;
  s.sewing.close_tolerance = 0.006f;
  s.collision.thickness = 0.0005f;
  s.seams[0].stiffness = 1e-6f;
  s.panels[1].transform.position = {0.05f, 0.5f, 0.006f};                         // b's left side 6 mm behind a's right
  s.obstacles.push_back(test::box_obstacle({0.04f, 0.3f, 0.004f}, {-0.05f, 0.6f, 0.003f}));  // between them
  Simulator sim(s);
  EXPECT_EQ(test::step_checked(sim, 30, 1), "");  // three weld checks
  EXPECT_EQ(sim.stitches_welded(), 0u);
  EXPECT_GT(sim.welds_put_off(), 0u);
}

// A weld rebuilds the backend mid-run. The rebuilt one must start from the bodies where they are:
// posed at t = 0 instead, its first step saw each body jump from its starting pose to its present
// one (a walking man's arm 10 to 30 cm), and took that for the step's move: the contact's reach and
// gaps grew with it and cloth was thrown in front of faces of the far side of the body (the
// garments on the walking man: 4 to 27 vertices inside him from the first weld of the walk on).
TEST(Sewing, AWeldWhileABodyMovesLeavesEachStepTheBodysOwnMove) {
  SceneDef s = two_squares_sewn();
  ObstacleDef box = test::box_obstacle({0.1f, 0.1f, 0.1f}, {0, -1.0f, 0});  // far below the cloth
  MotionDef motion;
  motion.velocity = {1, 0, 0};
  box.motion = motion;
  s.obstacles.push_back(box);
  Simulator sim(s);
  sim.step(2500);  // 0.5 s: the seam welds at about 0.4 s, the box 0.4 m from where it started
  ASSERT_GT(sim.stitches_welded(), 0u);
  EXPECT_NEAR(sim.totals().max_obstacle_move, 1.0 * s.time.dt, 1e-6);
}

// A checkpoint taken after stitches have welded resumes byte for byte. Each weld rebuilds the model
// from the positions then (its start positions, the groups' masses summed weld by weld, and the mean
// edge length, the scale of the bound's look-ahead). A restore that welded the pattern's own start
// positions in one go instead put each group midway across its 10 cm gap, so the resumed run's mean
// edge and masses were not the run's and its frames went another way (the GarmentCodeData top
// rand_2CRQTA16NZ on the walking man: every frame from the first after the resume).
TEST(Sewing, ARunResumedAfterItsWeldsGoesOnByteForByte) {
  SceneDef s = two_squares_sewn();
  s.gravity = {0, -9.81f, 0};
  s.sewing.close_time = 0.2;
  Simulator a(s);
  a.step(1500);  // 0.3 s: the seam welds at about 0.2 s
  ASSERT_GT(a.stitches_welded(), 0u);
  ByteWriter checkpoint;
  a.save_state(checkpoint);
  a.step(500);
  Simulator b(s);
  ByteReader in(checkpoint.bytes(), "checkpoint");
  b.restore_state(in);
  EXPECT_EQ(b.model().mean_edge, a.model().mean_edge);
  EXPECT_EQ(b.model().mass, a.model().mass);
  EXPECT_EQ(b.model().bound_witness, a.model().bound_witness);  // chosen in the panels' own shapes
  b.step(500);
  ASSERT_EQ(a.steps(), b.steps());
  const std::vector<Vec3>&xa = a.positions(), &xb = b.positions();
  ASSERT_EQ(xa.size(), xb.size());
  EXPECT_EQ(std::memcmp(xa.data(), xb.data(), xa.size() * sizeof(Vec3)), 0);
}

TEST(GarmentFit, TheNeckLineOfAGarmentOnABodyIsTheBodys) {
  const fs::path d = temp_dir("neck");
  write(d / "body.obj", boxes_obj(kBody));
  // A square whose top edge is at GarmentCode's neck line (145.7 cm).
  write(d / "g.json", one_panel(40, {0, 105.7f, 20}));
  const SceneDef s = parse_scene(body_scene(", \"body\": \"body\""), (d / "scene.json").string());
  ASSERT_EQ(s.garment_fits.size(), 1u);
  ClothModel m = build_cloth_model(s);
  const ObstacleSet o = build_obstacles(s);
  std::vector<Vec3> x, v;
  o.pose_at(0, x, v);
  const BodyFrame f = body_frame(o, 0, x, o.defs[0].front);
  // The narrowest cut between 80 % and 92 % of the height is the neck box (1.45 m to 1.6 m).
  EXPECT_GT(f.neck, 1.45);
  EXPECT_LT(f.neck, 1.4525 + 1e-6);
  EXPECT_NEAR(f.height, 1.75, 1e-6);
  const std::vector<PanelFit> fits = fit_garments(m, o, s);
  ASSERT_EQ(fits.size(), 1u);
  // Centred on the torso (a garment of one panel: the panel is its middle), then moved out of it
  // horizontally: the height stays.
  EXPECT_NEAR(std::abs(fits[0].moved), 0.125f, 1e-5f);
  float top = -1e9f;
  for (const Vec3& p : m.initial_positions) top = std::max(top, p.y);
  EXPECT_NEAR(top, f.neck, 1e-4);
}

TEST(GarmentFit, APanelPlacedThroughTheBodyIsMovedClearAlongItsNormal) {
  const fs::path d = temp_dir("through");
  write(d / "body.obj", boxes_obj(kBody));
  // The square stands in the torso's middle plane (z = 0), through the body.
  write(d / "g.json", one_panel(30, {0, 105.7f, 0}));
  const SceneDef s = parse_scene(body_scene(", \"body\": \"body\""), (d / "scene.json").string());
  ClothModel m = build_cloth_model(s);
  const ObstacleSet o = build_obstacles(s);
  const std::vector<PanelFit> fits = fit_garments(m, o, s);
  ASSERT_EQ(fits.size(), 1u);
  // Out through the torso's front or back face (0.12 m) by the clearance (2 x 2 mm), in 5 mm steps.
  EXPECT_GE(std::abs(fits[0].moved), 0.12f + 0.004f);
  EXPECT_LE(std::abs(fits[0].moved), 0.12f + 0.004f + 0.005f + 1e-5f);
  for (const Vec3& p : m.initial_positions) EXPECT_GE(std::abs(p.z), 0.124f);
  // And the simulator starts from there (nothing inside, nothing crossed).
  EXPECT_NO_THROW(Simulator sim(s));
}

TEST(GarmentFit, TwoPanelsThatCrossOnceClearOfTheBodyAreParted) {
  // Panels through each other but clear of the body (a hood over a sleeve, as GarmentCodeData's
  // rand_3DSCJVZ2EU starts): one of each crossing pair moves on along its normal, away from the
  // body, until they no longer cross; the run then starts.
  const fs::path d = temp_dir("parted");
  write(d / "body.obj", boxes_obj(kBody));
  // Front and back 60 x 30 cm at z = +-25 cm; a flap on each side, level at 1.2 m, 22 to 42 cm
  // out from the middle and 60 cm deep, through both.
  const std::string sq = R"("edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": [2, 3]}, {"endpoints": [3, 0]}])";
  write(d / "g.json", R"({"pattern": {"panels": {
    "front": {"translation": [0, 105.7, 25], "rotation": [0, 0, 0], "vertices": [[-30, 0], [30, 0], [30, 30], [-30, 30]], )" + sq + R"(},
    "back": {"translation": [0, 105.7, -25], "rotation": [0, 0, 0], "vertices": [[-30, 0], [30, 0], [30, 30], [-30, 30]], )" + sq + R"(},
    "right": {"translation": [22, 120, -30], "rotation": [90, 0, 0], "vertices": [[0, 0], [20, 0], [20, 60], [0, 60]], )" + sq + R"(},
    "left": {"translation": [-42, 120, -30], "rotation": [90, 0, 0], "vertices": [[0, 0], [20, 0], [20, 60], [0, 60]], )" + sq + R"(}},
    "stitches": []}, "properties": {"units_in_meter": 100, "curvature_coords": "relative"}})");
  const SceneDef s = parse_scene(body_scene(", \"body\": \"body\""), (d / "scene.json").string());
  ClothModel m = build_cloth_model(s);
  CheckReport before;
  check_cloth_crossings(cloth_check_mesh(m, m.initial_positions), before);
  ASSERT_GT(before.crossings, 0u) << "the two panels should start through each other";
  const ObstacleSet o = build_obstacles(s);
  const std::vector<PanelFit> fits = fit_garments(m, o, s);
  CheckReport after;
  check_cloth_crossings(cloth_check_mesh(m, m.initial_positions), after);
  EXPECT_EQ(after.crossings, 0u);
  ASSERT_EQ(fits.size(), 4u);
  float moved = 0;
  for (const PanelFit& f : fits) {
    moved += std::abs(f.moved);
    EXPECT_LE(std::abs(f.moved), float(kMaxClearMove) + 1e-5f) << f.panel;
  }
  EXPECT_GT(moved, 0.0f);
  EXPECT_NO_THROW(Simulator sim(s));
}

TEST(GarmentFit, ASkirtNarrowerThanTheLegsStanceIsWrappedAroundThem) {
  // Placed flat, its sides stand in front of and behind the legs: the stitches between them run
  // through the legs. Wrapped around the legs' hull, stretched to reach its sides, they do not.
  const fs::path d = temp_dir("stance");
  const Fitted f = fit_on_legs(d, straight_skirt());
  ASSERT_EQ(f.fits.size(), 2u);
  for (const PanelFit& p : f.fits) {
    EXPECT_TRUE(p.wrapped) << p.panel;
    EXPECT_GT(p.stretched, 1.05f) << p.panel;
    EXPECT_LE(p.stretched, float(kMaxStanceWiden) + 1e-6f) << p.panel;
  }
  EXPECT_GT(stitches_beside_the_legs(f.model), 3u);  // stitches beside the legs, not only above them
  EXPECT_NO_THROW(Simulator sim(f.scene));
  fs::remove_all(d);
}

TEST(GarmentFit, ARobeReachingAboveTheWaistIsWrappedBelowItOnly) {
  // The same straight panels, but from the knees to the neck, the front in two halves that meet at the
  // middle unsewn (an open robe): below the waist they are wrapped around the legs as the skirt is (each
  // front half from the middle to its side), so no stitch runs through a leg; above the waist line
  // they keep their flat placement (hulls there would take in the arms and the neck), eased between.
  const fs::path d = temp_dir("stance_robe");
  std::string g = straight_skirt();
  for (size_t at = g.find("[23, 50], [-23, 50]"); at != std::string::npos; at = g.find("[23, 50], [-23, 50]"))
    g.replace(at, 19, "[23, 87], [-23, 87]");
  const std::string front = g.substr(g.find("\"front\": {"), g.find("\"back\": {") - g.find("\"front\": {"));
  std::string halves = front;
  halves.replace(0, 7, "\"front_r\"");
  halves.replace(halves.find("[-23, 0]"), 8, "[0, 0]");
  halves.replace(halves.find("[-23, 87]"), 9, "[0, 87]");
  std::string left = front;
  left.replace(0, 7, "\"front_l\"");
  left.replace(left.find("[23, 0]"), 7, "[0, 0]");
  left.replace(left.find("[23, 87]"), 8, "[0, 87]");
  g.replace(g.find(front), front.size(), halves + left);
  const std::string stitches = R"([[{"panel": "front_r", "edge": 1}, {"panel": "back", "edge": 3}],
                 [{"panel": "front_l", "edge": 3}, {"panel": "back", "edge": 1}]])";
  const size_t st = g.find("\"stitches\": ") + 12;
  g.replace(st, g.find("]]}", st) + 2 - st, stitches);
  const Fitted f = fit_on_legs(d, g);
  ASSERT_EQ(f.fits.size(), 3u);
  for (const PanelFit& p : f.fits) EXPECT_TRUE(p.wrapped) << p.panel;
  ASSERT_GE(f.model.stitch_seam.size(), 20u);
  EXPECT_GT(stitches_beside_the_legs(f.model), 3u);
  // Each panel flat (one depth) above the waist line, curved round the legs below the crotch.
  const std::vector<Vec3>& x = f.model.initial_positions;
  for (const Piece& piece : f.model.pieces) {
    float hi_lo = INFINITY, hi_hi = -INFINITY, lo_lo = INFINITY, lo_hi = -INFINITY;
    for (uint32_t i = piece.first_vertex; i < piece.first_vertex + piece.vertex_count; ++i)
      if (x[i].y > 1.25f) hi_lo = std::min(hi_lo, x[i].z), hi_hi = std::max(hi_hi, x[i].z);
      else if (x[i].y < 0.7f) lo_lo = std::min(lo_lo, x[i].z), lo_hi = std::max(lo_hi, x[i].z);
    EXPECT_LT(hi_hi - hi_lo, 1e-5f) << piece.name;
    EXPECT_GT(lo_hi - lo_lo, 0.03f) << piece.name;
  }
  EXPECT_NO_THROW(Simulator sim(f.scene));
  fs::remove_all(d);
}

TEST(GarmentFit, AFlounceSewnToAWrappedSkirtIsWrappedWithIt) {
  // The straight skirt with a flounce 70 cm wide (wider than the stance: not wrapped on its own) sewn
  // under each panel's hem: wrapped with the skirt, else the skirt's sides, curved round the legs, go
  // through it where the two are sewn.
  const fs::path d = temp_dir("stance_flounce");
  std::string g = straight_skirt();
  const std::string wide = R"("vertices": [[-35, 0], [35, 0], [35, 12], [-35, 12]],
    "edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": [2, 3]}, {"endpoints": [3, 0]}])";
  const std::string flounces = R"("flounce_f": {"translation": [0, 46.8, 20], "rotation": [0, 0, 0], )" + wide +
                               R"(}, "flounce_b": {"translation": [0, 46.8, -20], "rotation": [0, 180, 0], )" + wide + "},\n    ";
  g.insert(g.find("\"front\": {"), flounces);
  const size_t st = g.find("\"stitches\": [") + 13;
  g.insert(st, R"([{"panel": "front", "edge": 0}, {"panel": "flounce_f", "edge": 2}],
                 [{"panel": "back", "edge": 0}, {"panel": "flounce_b", "edge": 2}], )");
  const Fitted f = fit_on_legs(d, g);
  ASSERT_EQ(f.fits.size(), 4u);
  for (const PanelFit& p : f.fits) EXPECT_TRUE(p.wrapped) << p.panel;
  EXPECT_NO_THROW(Simulator sim(f.scene));
  fs::remove_all(d);
}

TEST(GarmentFit, AWrappedSkirtIsSewnAroundBothLegs) {
  // The skirt above, sewn: every stitch closes outside the legs (none between them), and no checked
  // step has a crossing or a vertex inside the body.
  const fs::path d = temp_dir("stance_sewn");
  write(d / "body.obj", legs_apart_obj());
  write(d / "g.json", straight_skirt());
  std::string text = body_scene(", \"body\": \"body\"");
  const std::string edge = "\"edge_length\": 0.04";
  text.replace(text.find(edge), edge.size(), "\"edge_length\": 0.05");
  SceneDef s = parse_scene(text, (d / "scene.json").string());
  s.gravity = {0, 0, 0};
  Simulator sim(s);
  const ClothModel& m = sim.model();
  ASSERT_EQ(test::step_checked(sim, 3000, 20), "");  // 0.6 s: the close time and 0.3 s more
  // Drawn together: every stitch within two close tolerances (most welded; beside the legs the
  // skirt, 17 % short of their girth, pulls a few back to 4 to 6 mm, where their pull balances it).
  const float tol = seam_close_tolerance(s);
  EXPECT_LE(largest_stitch_gap(m, sim.positions()), 2.0f * tol);
  EXPECT_GE(sim.stitches_welded(), m.stitch_seam.size() * 2 / 3);
  for (size_t k = 0; k < m.stitch_seam.size(); ++k) {
    const Vec3 a = sim.positions()[m.stitches[2 * k]];
    if (a.y < 0.78f) EXPECT_GT(std::abs(a.x), kLegOuter - 0.01f) << "stitch " << k << " closed between the legs";
  }
  fs::remove_all(d);
}

TEST(GarmentFit, PanelsOverlappingInOnePlaneStartParted) {
  // Two 30 x 20 cm panels of one garment overlapping by half in one plane, clear of the body (as
  // GarmentCodeData's rand_033UAN6C0K places its cuff flounces): touching everywhere they overlap,
  // they would start with no room to move. One is moved along its normal, away from the body, until
  // no inner vertex of either is within the thickness of the other; nothing crosses.
  const fs::path d = temp_dir("overlap");
  const auto [s, m, fits] = fit_two_squares(d, {-8, 120, 20}, {8, 125.7f, 20}, "[]", 0.02f);
  ASSERT_EQ(fits.size(), 2u);
  EXPECT_GE(std::abs(fits[0].moved) + std::abs(fits[1].moved), 0.005f - 1e-6f);
  // The two planes: at least the thickness apart (they stay parallel, facing the body's front).
  float za = 0, zb = 0;
  for (uint32_t i = 0; i < m.pieces[0].vertex_count; ++i) za += m.initial_positions[m.pieces[0].first_vertex + i].z;
  for (uint32_t i = 0; i < m.pieces[1].vertex_count; ++i) zb += m.initial_positions[m.pieces[1].first_vertex + i].z;
  za /= float(m.pieces[0].vertex_count), zb /= float(m.pieces[1].vertex_count);
  EXPECT_GE(std::abs(za - zb), s.collision.thickness);
  CheckReport r;
  check_cloth_crossings(cloth_check_mesh(m, m.initial_positions), r);
  EXPECT_EQ(r.crossings, 0u);
  fs::remove_all(d);
}

TEST(GarmentFit, PanelsWhoseEdgesOverlapWhereTheyAreNotSewnToEachOtherStartParted) {
  // Two 30 x 20 cm panels in one plane, a's right side 2 mm over b's left (as GarmentCode's jumpsuit
  // lays the tips of its back trouser panels, sewn to the front panels there, not to each other):
  // only their outlines touch, and those vertices would start with no room to move. Unsewn, one panel
  // is moved off the other; sewn to each other along those sides, neither moves.
  for (const bool sewn : {false, true}) {
    const fs::path d = temp_dir(sewn ? "edges_sewn" : "edges");
    const std::string stitches = sewn ? R"([[{"panel": "a", "edge": 1}, {"panel": "b", "edge": 3}]])" : "[]";
    const auto [s, m, fits] = fit_two_squares(d, {-14.9f, 120, 20}, {14.9f, 120, 20}, stitches, 0.02f);
    ASSERT_EQ(fits.size(), 2u);
    // Both are first moved out of the body alike; parted, one of them 5 mm further.
    const float parted = std::abs(std::abs(fits[0].moved) - std::abs(fits[1].moved));
    if (sewn)
      EXPECT_EQ(parted, 0.0f);
    else
      EXPECT_GE(parted, 0.005f - 1e-6f);
    fs::remove_all(d);
  }
}

TEST(GarmentFit, APanelMovedClearGoesToTheSideOfThePanelItIsSewnTo) {
  // Two 30 x 20 cm panels through the torso (0.24 m deep), 4 cm in front of its middle and 4 cm
  // behind, the first's bottom sewn to the second's top. Each is nearer its own face of the torso:
  // moved clear the shortest way, the second would go out behind it, its stitches through the torso
  // to the first in front (as rand_1KMN65OI4O's cuff flounce went behind the hand). It goes out in
  // front instead, where none of them does.
  const fs::path d = temp_dir("sides");
  const auto [s, m, fits] =
      fit_two_squares(d, {0, 120, 4}, {0, 100, -4}, R"([[{"panel": "a", "edge": 0}, {"panel": "b", "edge": 2}]])", 0.04f);
  ASSERT_EQ(fits.size(), 2u);
  EXPECT_GT(fits[0].moved, 0.0f);
  EXPECT_GT(fits[1].moved, 0.0f) << "the lower panel (b) went out behind the torso";
  ASSERT_GE(m.stitch_seam.size(), 5u);
  for (size_t k = 0; k < m.stitch_seam.size(); ++k)
    for (int side = 0; side < 2; ++side)
      EXPECT_GT(m.initial_positions[m.stitches[2 * k + size_t(side)]].z, 0.12f) << "stitch " << k << " side " << side;
  fs::remove_all(d);
}

TEST(GarmentFit, BadGarmentsAreRefusedWordForWord) {
  const fs::path d = temp_dir("bad");
  write(d / "body.obj", boxes_obj(kBody));
  write(d / "g.json", one_panel(30, {0, 105.7f, 20}));
  const std::string file = (d / "scene.json").string();
  auto message = [&](const std::string& text) {
    try {
      Simulator sim(parse_scene(text, file));
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  // sewing.gravity_waits that is not true or false.
  std::string waits = body_scene(", \"body\": \"body\"");
  waits.replace(waits.find("\"close_time\": 0.3"), 17, "\"close_time\": 0.3, \"gravity_waits\": 1");
  EXPECT_EQ(message(waits), file + ": /sewing/gravity_waits: expected true or false, got number");
  waits = body_scene(", \"body\": \"body\"");
  waits.replace(waits.find("\"close_time\": 0.3"), 17, "\"close_time\": 0.3, \"gravity_waits\": true, \"ease_gravity\": false");
  EXPECT_EQ(message(waits), file + ": /sewing/gravity_waits: needs ease_gravity: with ease_gravity false gravity acts from the "
                                   "start and does not wait");
  // A body that is not an obstacle.
  std::string wrong = body_scene(", \"body\": \"man\"");
  EXPECT_EQ(message(wrong), file + ": /garments/0/body: no obstacle named 'man' (the scene has 'body')");
  // A seam between two garments.
  std::string two = body_scene(", \"body\": \"body\", \"prefix\": \"a_\"}, {\"garmentcode\": \"g.json\", \"material\": \"m\", "
                               "\"body\": \"body\", \"prefix\": \"b_\"");
  two.replace(two.find("\"sewing\""), 0,
              R"("seams": [{"a": {"panel": "a_front", "segment": "e1"}, "b": {"panel": "b_front", "segment": "e3"}}], )");
  EXPECT_EQ(message(two), file + ": /seams/0: joins panel 'a_front' of garment /garments/0 to panel 'b_front' of garment "
                                 "/garments/1: garments placed on a body are fitted separately, so a seam cannot join them");
  // A panel that cannot be cleared: a 1 m deep body, the panel in its middle.
  write(d / "body.obj", boxes_obj({{0.2f, 0.5f, 0.0f, 1.45f}, {0.05f, 0.05f, 1.45f, 1.6f}, {0.1f, 0.1f, 1.6f, 1.75f}}));
  write(d / "g.json", one_panel(30, {0, 105.7f, 0}));
  EXPECT_EQ(message(body_scene(", \"body\": \"body\"")),
            file + ": /garments/0: panel 'front' starts inside or through obstacle 'body', and moving it up to 0.25 m either "
                   "way along its normal did not clear it by 0.004 m; place the garment with position or the panel with "
                   "panels.<name>.offset");
  fs::remove_all(d);
}

TEST(GarmentFit, ABodyHeldStandsInItsRestPoseUntilTheHoldEnds) {
  SceneDef s = test::panel_scene(2, 0.1f, 2.5f, 1.0f);
  ObstacleDef man;
  man.name = "man";
  man.type = ObstacleType::Skinned;
  man.file = std::string(RAYCLOTH_SOURCE_DIR) + "/assets/walking_man.glb";
  man.animation = "walk";
  man.hold = 0.5;
  man.blend_in = 0.3;
  s.obstacles.push_back(man);
  const ObstacleSet o = build_obstacles(s);
  std::vector<Vec3> rest, x, v;
  o.pose_at(0.0, rest, v);
  o.pose_at(0.49, x, v);
  for (size_t i = 0; i < rest.size(); ++i) ASSERT_EQ(length(x[i] - rest[i]), 0.0f) << "vertex " << i;
  o.pose_at(0.9, x, v);
  float moved = 0;
  for (size_t i = 0; i < rest.size(); ++i) moved = std::max(moved, length(x[i] - rest[i]));
  EXPECT_GT(moved, 0.05f);  // walking by then
}

TEST(GarmentFit, ObstacleFrontAndHoldAreChecked) {
  auto message = [](const std::string& obstacle) {
    try {
      parse_scene(R"({"panels": [{"name": "p", "material": "m", "size": [1, 1], "resolution": [2, 2]}],
        "materials": [{"name": "m"}], "obstacles": [)" + obstacle + "]}",
                  "s.json");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message(R"({"name": "b", "type": "box", "front": [0, 1, 0]})"),
            "s.json: /obstacles/0/front: must point somewhere horizontal (x or z not 0)");
  EXPECT_EQ(message(R"({"name": "b", "type": "box", "hold": 1})"),
            "s.json: /obstacles/0/hold: field 'hold' does not apply to obstacle type 'box'");
}

TEST(Sewing, ACloseToleranceBelowTheThicknessIsRefused) {
  // The two sides of an open stitch are cloth to each other (nothing of a stitch is left out of the
  // contact, the bound or the rays, so a closing seam cannot pass through the cloth beside it): the
  // contact holds them a thickness apart, and a tolerance below it would never be reached.
  SceneDef s = two_squares_sewn();
  s.collision.thickness = 0.003f;
  s.sewing.close_tolerance = 0.0005f;
  try {
    Simulator sim(s);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "<scene>: /sewing/close_tolerance: must be at least the collision thickness 0.003 m (got 0.0005): the contact "
              "keeps the two sides of a stitch that far apart, so it would never close");
  }
}
