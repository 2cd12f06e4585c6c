// Pinches in the exact check (a cloth vertex inside the body where the body's own surfaces are
// closer than twice the cloth thickness: not clean, not a failure), and the refusal of a start with
// cloth vertices already inside an obstacle.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "sim/model_check.h"
#include "fixtures.h"
#include "io/obj_writer.h"
#include "raycloth/error.h"
#include "raycloth/simulator.h"
#include "sim/model.h"

using namespace raycloth;
namespace fs = std::filesystem;

namespace {

constexpr double kThickness = 0.002;  // twice it: 4 mm

// Two boxes side by side along x, 0.2 m wide: "left" from x = -0.2 to 0, "right" from x = gap.
ObstacleSet two_boxes(float gap) {
  SceneDef s;
  ObstacleDef left = test::box_obstacle({0.2f, 0.2f, 0.2f}, {-0.1f, 0, 0});
  left.name = "left";
  ObstacleDef right = test::box_obstacle({0.2f, 0.2f, 0.2f}, {gap + 0.1f, 0, 0});
  right.name = "right";
  s.obstacles = {left, right};
  return build_obstacles(s);
}

// One cloth triangle whose first vertex is at p, the other two well above every box.
CheckMesh cloth_with_vertex_at(Vec3 p) {
  CheckMesh m;
  m.vertices = {p, make_vec3(p.x, 0.5f, 0), make_vec3(p.x, 0.5f, 0.1f)};
  m.triangles = {0, 1, 2};
  m.group_names = {"sheet"};
  m.group_first_triangle = {0};
  return m;
}

CheckReport check(const CheckMesh& cloth, const ObstacleSet& set) {
  return check_state(cloth, obstacle_check_mesh(set, set.world.vertices), kThickness);
}

}  // namespace

// A hand against a hip: the boxes are 2 mm apart, a cloth vertex 1 mm inside the left one next to
// the gap cannot be outside both at the thickness. Pinched, with the body's gap of 2 mm.
TEST(Pinch, VertexInsideWhereTheBodyLeavesLessThanTwiceTheThicknessIsPinched) {
  const CheckReport r = check(cloth_with_vertex_at(make_vec3(-0.001f, 0, 0)), two_boxes(0.002f));
  EXPECT_EQ(r.vertices_inside, 0u);
  ASSERT_EQ(r.vertices_pinched, 1u);
  EXPECT_NEAR(r.min_pinch_gap, 0.002, 1e-6);
  ASSERT_EQ(r.first_pinched.size(), 1u);
  EXPECT_EQ(r.first_pinched[0].vertex, 0u);
  EXPECT_EQ(r.first_pinched[0].obstacle, "left");
  EXPECT_NEAR(r.first_pinched[0].gap, 0.002, 1e-6);
  EXPECT_FALSE(r.clean());
  EXPECT_FALSE(r.failed());
  EXPECT_TRUE(r.pinched_only());
  EXPECT_EQ(describe(r),
            "0 crossings, 0 vertices inside, 1 vertices pinched (body gap 2 mm); first pinched: vertex 0 inside 'left' "
            "(body gap 2 mm)");
  // Without the thickness (check_state's default) nothing is a pinch.
  const ObstacleSet set = two_boxes(0.002f);
  const CheckReport plain = check_state(cloth_with_vertex_at(make_vec3(-0.001f, 0, 0)),
                                        obstacle_check_mesh(set, set.world.vertices));
  EXPECT_EQ(plain.vertices_inside, 1u);
  EXPECT_EQ(plain.vertices_pinched, 0u);
}

// Touching bodies (gap 0) pinch too: the ray starts a hair behind the surface.
TEST(Pinch, TouchingBodiesPinchWithGapZero) {
  const CheckReport r = check(cloth_with_vertex_at(make_vec3(-0.001f, 0, 0)), two_boxes(0.0f));
  EXPECT_EQ(r.vertices_inside, 0u);
  ASSERT_EQ(r.vertices_pinched, 1u);
  EXPECT_NEAR(r.min_pinch_gap, 0.0, 1e-6);
}

// The same vertex with the boxes 10 cm apart: the body leaves room, so it is a failure.
TEST(Pinch, VertexInsideWhereTheBodyLeavesRoomIsAFailure) {
  const CheckReport r = check(cloth_with_vertex_at(make_vec3(-0.001f, 0, 0)), two_boxes(0.1f));
  EXPECT_EQ(r.vertices_pinched, 0u);
  ASSERT_EQ(r.vertices_inside, 1u);
  EXPECT_NEAR(r.first_inside[0].gap, 0.1, 1e-6);
  EXPECT_TRUE(r.failed());
  EXPECT_FALSE(r.pinched_only());
  EXPECT_EQ(describe(r), "0 crossings, 1 vertices inside; first: vertex 0 inside 'left'");
}

// Clothes over skin: a box inside a box 2 mm larger on every side, both closed with outward normals.
// A vertex 1 mm under the inner surface: the ray from the inner surface leaves the outer layer from
// behind (2 mm away, less than twice the thickness), which is no pinch; both are failures.
TEST(Pinch, VertexUnderAnOuterLayerIsAFailureNotAPinch) {
  SceneDef s;
  ObstacleDef skin = test::box_obstacle({0.2f, 0.2f, 0.2f}, {0, 0, 0});
  skin.name = "skin";
  ObstacleDef coat = test::box_obstacle({0.204f, 0.204f, 0.204f}, {0, 0, 0});
  coat.name = "coat";
  s.obstacles = {skin, coat};
  const ObstacleSet set = build_obstacles(s);
  const CheckReport r = check(cloth_with_vertex_at(make_vec3(0.099f, 0, 0)), set);
  EXPECT_EQ(r.closed_obstacles, 2u);
  EXPECT_EQ(r.vertices_pinched, 0u) << describe(r);
  ASSERT_EQ(r.vertices_inside, 2u);
  EXPECT_EQ(r.first_inside[0].obstacle, "skin");
  EXPECT_EQ(r.first_inside[1].obstacle, "coat");
  EXPECT_TRUE(std::isinf(r.first_inside[0].gap)) << r.first_inside[0].gap;
  EXPECT_TRUE(std::isinf(r.first_inside[1].gap)) << r.first_inside[1].gap;
}

// ---- The start check -----------------------------------------------------------------------------

// A sheet placed through the middle of a box: 9 of its 25 vertices strictly inside, the deepest (its
// centre) 0.075 m under the box's top; the way out is up, plus the 2 mm thickness.
TEST(StartInside, SheetThroughABoxIsRefusedNamingPanelObstacleCountDepthAndMove) {
  SceneDef s = test::panel_scene(5, 0.4f, 0.5f);
  s.source = "through.json";
  PanelDef clear = s.panels[0];
  clear.name = "clear";
  clear.transform.position = {2, 0.5f, 0};
  s.panels.insert(s.panels.begin(), clear);  // panel 0 is clear of the box, panel 1 goes through it
  s.obstacles.push_back(test::box_obstacle({0.25f, 0.25f, 0.25f}, {0, 0.45f, 0}));
  try {
    Simulator sim(s);
    FAIL() << "a start with cloth inside a box was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "through.json");
    EXPECT_EQ(e.field(), "/panels/1");
    EXPECT_EQ(std::string(e.what()),
              "through.json: /panels/1: panel 'cloth' starts with 9 vertices inside obstacle 'box' (the deepest 0.075 m "
              "below its surface); move the panel out of it, e.g. by (0, 0.077, 0)");
  }
}

// Within the thickness is not inside: a sheet 1 mm above the box's top starts.
TEST(StartInside, SheetWithinTheThicknessOfABoxStarts) {
  SceneDef s = test::panel_scene(5, 0.4f, 0.576f);
  s.obstacles.push_back(test::box_obstacle({0.25f, 0.25f, 0.25f}, {0, 0.45f, 0}));  // top at 0.575
  EXPECT_NO_THROW(Simulator sim(s));
}

// ---- The command line ----------------------------------------------------------------------------

namespace {

struct Result {
  int code;
  std::string err;
  std::string out;
};

Result run_cli(const std::string& args, const fs::path& dir) {
  fs::create_directories(dir);
  const fs::path err = dir / "stderr.txt";
  const std::string cmd =
      std::string(RAYCLOTH_CLI) + " " + args + " > " + (dir / "stdout.txt").string() + " 2> " + err.string();
  const int status = std::system(cmd.c_str());
  auto slurp = [](const fs::path& p) {
    std::ifstream in(p);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  };
  return {WEXITSTATUS(status), slurp(err), slurp(dir / "stdout.txt")};
}

fs::path fresh_dir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("raycloth_pinch_" + name);
  fs::remove_all(d);
  return d;
}

// An output folder with one frame: the cloth triangle and the two boxes `gap` apart.
fs::path pinch_folder(const std::string& name, float gap) {
  const fs::path out = fresh_dir(name) / "out";
  fs::create_directories(out / "frames");
  const ObstacleSet set = two_boxes(gap);
  write_obstacles_obj(out / "obstacles.obj", set, set.world.vertices);
  std::ofstream(out / "frames" / "cloth_0000.obj") << "o sheet\nv -0.001 0 0\nv -0.001 0.5 0\nv -0.001 0.5 0.1\nf 1 2 3\n";
  return out;
}

}  // namespace

TEST(PinchCli, CheckOfAFolderWithOnlyPinchesExitsThree) {
  const fs::path out = pinch_folder("check3", 0.002f);
  std::ofstream(out / "run.json") << R"({"thickness": 0.002})";
  const Result r = run_cli("check " + out.string(), out.parent_path());
  EXPECT_EQ(r.code, 3) << r.out << r.err;
  EXPECT_NE(r.out.find("frame 0000: 0 crossings, 0 vertices inside, 1 vertices pinched (body gap 2 mm)"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find(": 1 frames, 0 bad: 0 edge-triangle crossings and 0 vertices inside in all"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find(out.string() + ": 1 frames pinched only: 1 cloth vertices pinched in all"), std::string::npos)
      << r.out;
  EXPECT_EQ(r.err, "raycloth: pinched: " + out.string() + ": the only problems are pinches, in 1 of 1 frames (exit status 3)\n");

  // With the boxes 10 cm apart the same vertex is a failure: 1.
  const fs::path apart = pinch_folder("check1", 0.1f);
  std::ofstream(apart / "run.json") << R"({"thickness": 0.002})";
  const Result f = run_cli("check " + apart.string(), apart.parent_path());
  EXPECT_EQ(f.code, 1) << f.out << f.err;
  EXPECT_NE(f.out.find(": 1 frames, 1 bad: 0 edge-triangle crossings and 1 vertices inside in all"), std::string::npos)
      << f.out;
}

TEST(PinchCli, CheckOfAFolderWithObstaclesNeedsTheThicknessFromRunJson) {
  const fs::path out = pinch_folder("nothickness", 0.002f);
  Result r = run_cli("check " + out.string(), out.parent_path());
  EXPECT_EQ(r.code, 2);
  const std::string why = "`raycloth check` needs the run's cloth thickness (which `raycloth run` writes there) to tell "
                          "cloth pinched by the body from penetration";
  EXPECT_EQ(r.err, "raycloth: error: " + (out / "run.json").string() +
                       ": /thickness: cannot be read (No such file or directory); " + why + "\n");
  std::ofstream(out / "run.json") << R"({"scene": "old"})";
  r = run_cli("check " + out.string(), out.parent_path());
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: " + (out / "run.json").string() + ": /thickness: missing; " + why +
                       ": run the scene again\n");
  std::ofstream(out / "run.json") << R"({"thickness": "2 mm"})";
  r = run_cli("check " + out.string(), out.parent_path());
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: " + (out / "run.json").string() +
                       ": /thickness: must be a non-negative number of metres (got \"2 mm\")\n");
}

// The squeeze scene: a press box driven down towards a table box, with a 0.6 m cloth lying on the
// table, stops `gap` above it (1 mm: less than the 2 mm thickness). `pin` is added to the cloth.
std::string squeeze_scene(const std::string& pin, double gap = 0.001) {
  return R"({
    "name": "squeeze", "time": {"dt": 0.0004, "duration": 0.1, "fps": 30},
    "materials": [{"name": "cotton", "density": 0.2, "stretch": 200, "shear": 40, "bend": 4, "damping": 1.0}],
    "panels": [{"name": "cloth", "material": "cotton", "size": [0.6, 0.6], "resolution": [11, 11],
                "position": [0, 0.21, 0]}],
    "pins": [)" + pin + R"(],
    "obstacles": [{"name": "table", "type": "box", "size": [0.4, 0.2, 0.4], "position": [0, 0.1, 0]},
                  {"name": "press", "type": "box", "size": [0.2, 0.2, 0.2], "position": [0, )" +
         std::to_string(0.35 + gap) + R"(, 0],
                   "motion": {"velocity": [0, -0.5, 0]}}]})";
}

// The squeeze run's last frame (3): the 9 cloth vertices under the press lie above the table's top
// (y = 0.2) and below `below`.
void expect_between_the_boxes(const fs::path& out, double below) {
  std::ifstream in(out / "frames" / "cloth_0003.obj");
  std::string line;
  int under = 0;
  while (std::getline(in, line)) {
    if (line.rfind("v ", 0) != 0) continue;
    std::istringstream v(line.substr(2));
    double x, y, z;
    v >> x >> y >> z;
    if (std::fabs(x) >= 0.1 || std::fabs(z) >= 0.1) continue;
    ++under;
    EXPECT_GT(y, 0.2) << line;
    EXPECT_LT(y, below) << line;
  }
  EXPECT_EQ(under, 9);
}

// Free cloth squeezed there goes halfway across the body's gap, outside both boxes: the run is clean.
// Before, every vertex under the press was pushed the whole thickness off the nearest box, into the
// other one: 9 vertices pinched (exit 3).
TEST(PinchCli, ClothSqueezedBetweenTwoBodiesGoesHalfwayAcrossTheirGap) {
  const fs::path dir = fresh_dir("squeeze_free");
  fs::create_directories(dir);
  std::ofstream(dir / "squeeze.json") << squeeze_scene("");
  const fs::path out = dir / "out";
  const Result r = run_cli("run " + (dir / "squeeze.json").string() + " --quiet --out " + out.string(), dir);
  EXPECT_EQ(r.code, 0) << r.err;
  expect_between_the_boxes(out, 0.201);  // below the press
}

// A press stopping 0.1 mm above the table (a forearm swung against the hip): halfway across the
// gap is 50 um off both boxes, outside both, and the run is clean. Before, a gap under a tenth of the
// push (0.2 mm here) was taken for surfaces that touch: every vertex under the press went the whole
// thickness off one box, into the other, step after step (9 pinched, exit 3).
TEST(PinchCli, ClothSqueezedIntoATenthOfTheThicknessStillGoesHalfwayAcross) {
  const fs::path dir = fresh_dir("squeeze_thin");
  fs::create_directories(dir);
  std::ofstream(dir / "squeeze.json") << squeeze_scene("", 0.0001);
  const fs::path out = dir / "out";
  const Result r = run_cli("run " + (dir / "squeeze.json").string() + " --quiet --out " + out.string(), dir);
  EXPECT_EQ(r.code, 0) << r.err;
  expect_between_the_boxes(out, 0.2003);  // halfway to the press (its last steps 0.3 to 0.1 mm above it)
}

// A pinned vertex cannot be moved out: the cloth pinned at its centre, under the press, ends inside
// it where the body leaves 1 mm. The run says the only problems are pinches (exit 3), in run.json and
// on stderr, and `raycloth check` agrees from the written frames and run.json's thickness.
TEST(PinchCli, RunSqueezedBetweenTwoBodiesCloserThanTheThicknessExitsThree) {
  const fs::path dir = fresh_dir("squeeze");
  fs::create_directories(dir);
  std::ofstream(dir / "squeeze.json") << squeeze_scene(R"({"panel": "cloth", "range": [60, 60]})");
  const fs::path out = dir / "out";
  const Result r = run_cli("run " + (dir / "squeeze.json").string() + " --quiet --out " + out.string(), dir);
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_EQ(r.err.rfind("raycloth: pinched: " + out.string() + ": the only problems are pinches, in ", 0), 0u) << r.err;
  std::ifstream in(out / "run.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["thickness"], 0.002);
  const nlohmann::json& c = j["check"];
  EXPECT_EQ(c["bad_frames"], 0) << c.dump();
  EXPECT_EQ(c["max_vertices_inside"], 0) << c.dump();
  ASSERT_GE(c["pinched_frames"].get<int>(), 1) << c.dump();
  EXPECT_GT(c["max_vertices_pinched"].get<int>(), 0);
  // The last frame: the press 1 mm above the table.
  EXPECT_NEAR(c["min_pinch_gap"].get<double>(), 0.001, 1e-5);
  const nlohmann::json& last = j["frames"].back();
  EXPECT_GT(last["pinched"].get<int>(), 0);
  EXPECT_NEAR(last["pinch_gap"].get<double>(), 0.001, 1e-5);
  EXPECT_TRUE(j["frames"][0]["pinch_gap"].is_null());
  EXPECT_EQ(j["frames"][0]["pinched"], 0);
  const Result k = run_cli("check --quiet " + out.string(), dir);
  EXPECT_EQ(k.code, 3) << k.out << k.err;
}
