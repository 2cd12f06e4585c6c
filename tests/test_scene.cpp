// Scene files: the seed scene and the built-in default agree, the example scenes load and are
// stable, and every kind of bad input is reported with the exact file, JSON pointer and reason.
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <string>

#include "raycloth/error.h"
#include "raycloth/scene.h"
#include "sim/model.h"

namespace raycloth {
namespace {

const std::string kSource = RAYCLOTH_SOURCE_DIR;

// Runs `f`, expects an InputError, and checks its full message and its field.
void expect_input_error(const std::function<void()>& f, const std::string& message, const std::string& field) {
  try {
    f();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), message);
    EXPECT_EQ(e.field(), field);
    return;
  }
  ADD_FAILURE() << "no InputError thrown; expected: " << message;
}

void expect_parse_error(const std::string& json, const std::string& message, const std::string& field) {
  expect_input_error([&] { parse_scene(json, "test.json"); }, message, field);
}

// A valid scene to start from: one 3 x 3 panel of material "m".
const char* const kOnePanel = R"({
  "materials": [{"name": "m"}],
  "panels": [{"name": "a", "material": "m", "size": [1, 1], "resolution": [3, 3]}]
})";

// Same, with one obstacle appended.
std::string with_obstacle(const std::string& obstacle) {
  return R"({"materials": [{"name": "m"}],
             "panels": [{"name": "a", "material": "m", "size": [1, 1], "resolution": [3, 3]}],
             "obstacles": [)" +
         obstacle + "]}";
}

SceneDef code_scene() {
  SceneDef s;
  s.source = "code";
  s.materials.push_back({.name = "m"});
  PanelDef a{.name = "a", .material = "m", .width = 1.5f, .height = 0.75f, .resolution_u = 51, .resolution_v = 26};
  PanelDef b{.name = "b", .material = "m", .width = 0.75f, .height = 0.75f, .resolution_u = 26, .resolution_v = 26};
  s.panels = {a, b};
  return s;
}

TEST(SceneFile, SeedSceneParses) {
  const SceneDef s = load_scene_file(kSource + "/scenes/seed_drape.json");
  EXPECT_EQ(s.name, "seed_drape");
  EXPECT_EQ(s.source, kSource + "/scenes/seed_drape.json");
  ASSERT_EQ(s.panels.size(), 3u);
  EXPECT_EQ(s.panels[0].resolution_u, 51);
  EXPECT_EQ(s.panels[0].resolution_v, 26);
  EXPECT_EQ(s.panels[2].resolution_u, 40);
  EXPECT_FLOAT_EQ(s.panels[2].transform.rotation[1], 45.0f);
  ASSERT_EQ(s.seams.size(), 1u);
  EXPECT_EQ(s.seams[0].a.panel, "half_a");
  EXPECT_EQ(s.seams[0].a.edge, "top");
  EXPECT_EQ(s.seams[0].b.edge, "bottom");
  ASSERT_EQ(s.obstacles.size(), 1u);
  EXPECT_EQ(s.obstacles[0].type, ObstacleType::UvSphere);
  EXPECT_EQ(s.obstacles[0].slices, 24);
  EXPECT_EQ(s.obstacles[0].stacks, 25);
  EXPECT_FLOAT_EQ(s.obstacles[0].radius, 0.5f);
  EXPECT_DOUBLE_EQ(s.time.dt, 4e-4);
}

TEST(SceneFile, DefaultSceneMatchesSeedFile) {
  const SceneDef d = default_scene();
  const SceneDef f = load_scene_file(kSource + "/scenes/seed_drape.json");
  EXPECT_EQ(d.name, f.name);
  EXPECT_EQ(d.time.dt, f.time.dt);
  EXPECT_EQ(d.time.duration, f.time.duration);
  EXPECT_EQ(d.time.fps, f.time.fps);
  EXPECT_EQ(d.gravity, f.gravity);
  EXPECT_EQ(d.collision.tolerance, f.collision.tolerance);
  EXPECT_EQ(d.collision.cloth_cloth, f.collision.cloth_cloth);
  ASSERT_EQ(d.materials.size(), f.materials.size());
  for (size_t i = 0; i < d.materials.size(); ++i) {
    EXPECT_EQ(d.materials[i].name, f.materials[i].name);
    EXPECT_EQ(d.materials[i].density, f.materials[i].density);
    EXPECT_EQ(d.materials[i].bend, f.materials[i].bend);
  }
  ASSERT_EQ(d.panels.size(), f.panels.size());
  for (size_t i = 0; i < d.panels.size(); ++i) {
    EXPECT_EQ(d.panels[i].name, f.panels[i].name);
    EXPECT_EQ(d.panels[i].width, f.panels[i].width);
    EXPECT_EQ(d.panels[i].resolution_u, f.panels[i].resolution_u);
    EXPECT_EQ(d.panels[i].transform.position, f.panels[i].transform.position);
    EXPECT_EQ(d.panels[i].transform.rotation, f.panels[i].transform.rotation);
  }
  ASSERT_EQ(d.seams.size(), f.seams.size());
  EXPECT_EQ(d.seams[0].b.panel, f.seams[0].b.panel);
  ASSERT_EQ(d.obstacles.size(), f.obstacles.size());
  EXPECT_EQ(d.obstacles[0].radius, f.obstacles[0].radius);
  EXPECT_EQ(d.obstacles[0].slices, f.obstacles[0].slices);
}

TEST(SceneFile, DefaultsAndComments) {
  const SceneDef s = parse_scene(R"({
    // a line comment
    "materials": [{"name": "m"}], /* a block comment */
    "panels": [{"name": "a", "material": "m", "size": [2, 1], "resolution": [5, 3]}],
    "pins": [{"panel": "a", "edge": "top"}, {"panel": "a", "range": [0, 14]}],
    "obstacles": [{"type": "box", "size": [1, 2, 3]}]
  })",
                                 "comments.json");
  EXPECT_EQ(s.source, "comments.json");
  EXPECT_EQ(s.name, "scene");
  EXPECT_DOUBLE_EQ(s.time.dt, TimeDef{}.dt);
  EXPECT_FLOAT_EQ(s.materials[0].stretch, MaterialDef{}.stretch);
  EXPECT_FLOAT_EQ(s.panels[0].width, 2.0f);
  EXPECT_EQ(s.panels[0].resolution_v, 3);
  EXPECT_EQ(s.panels[0].transform.scale, (Float3{1, 1, 1}));
  ASSERT_EQ(s.pins.size(), 2u);
  EXPECT_EQ(s.pins[0].edge, "top");
  EXPECT_EQ(s.pins[1].range, (std::array<int, 2>{0, 14}));
  EXPECT_EQ(s.obstacles[0].name, "obstacle0");
  EXPECT_EQ(s.obstacles[0].size, (Float3{1, 2, 3}));
  EXPECT_FALSE(s.obstacles[0].motion.has_value());
}

TEST(SceneFile, MeshPathIsResolvedAgainstTheSceneFolder) {
  const std::string origin = kSource + "/scenes/x.json";
  const SceneDef s = parse_scene(with_obstacle(R"({"type": "mesh", "file": "../tests/data/triangle.obj"})"), origin);
  EXPECT_EQ(s.obstacles[0].file, kSource + "/tests/data/triangle.obj");
  const ObstacleSet set = build_obstacles(s);
  EXPECT_EQ(set.world.num_triangles(), 1u);
}

TEST(SceneFile, MotionIsRead) {
  const SceneDef s = parse_scene(
      with_obstacle(R"({"type": "uv_sphere", "motion": {"velocity": [0.5, 0, 0], "start": 1}})"), "m.json");
  ASSERT_TRUE(s.obstacles[0].motion.has_value());
  EXPECT_FLOAT_EQ(s.obstacles[0].motion->velocity[0], 0.5f);
  EXPECT_EQ(s.obstacles[0].motion->angular_velocity, (Float3{0, 0, 0}));
  EXPECT_DOUBLE_EQ(s.obstacles[0].motion->start, 1.0);
}

TEST(SceneErrors, MissingRequiredField) {
  expect_parse_error(R"({"materials": [{"name": "m"}],
                         "panels": [{"name": "a", "material": "m", "resolution": [3, 3]}]})",
                     "test.json: /panels/0/size: missing required field", "/panels/0/size");
  expect_parse_error(R"({"materials": [{"name": "m"}]})", "test.json: /panels: missing required field", "/panels");
}

TEST(SceneErrors, WrongType) {
  expect_parse_error(R"({"time": {"dt": "fast"}})", "test.json: /time/dt: expected a number, got string", "/time/dt");
  expect_parse_error(R"({"materials": [{"name": "m"}],
                         "panels": [{"name": "a", "material": "m", "size": [1, 1], "resolution": [3, 2.5]}]})",
                     "test.json: /panels/0/resolution/1: expected an integer, got 2.5", "/panels/0/resolution/1");
  expect_parse_error(R"({"gravity": [0, -9.81]})", "test.json: /gravity: expected 3 numbers, got 2", "/gravity");
  expect_parse_error(R"({"collision": {"cloth_cloth": 1}})",
                     "test.json: /collision/cloth_cloth: expected true or false, got number", "/collision/cloth_cloth");
  expect_parse_error("[1, 2]", "test.json: expected an object, got array", "");
}

TEST(SceneErrors, NonPositiveValues) {
  expect_parse_error(R"({"materials": [{"name": "m"}],
                         "panels": [{"name": "a", "material": "m", "size": [1, 1], "resolution": [3, 3]},
                                    {"name": "b", "material": "m", "size": [-1, 1], "resolution": [3, 3]}]})",
                     "test.json: /panels/1/size: both must be positive (got [-1, 1])", "/panels/1/size");
  expect_parse_error(R"({"time": {"dt": -1}, "materials": [{"name": "m"}],
                         "panels": [{"name": "a", "material": "m", "size": [1, 1], "resolution": [3, 3]}]})",
                     "test.json: /time/dt: must be positive (got -1)", "/time/dt");
  expect_parse_error(R"({"materials": [{"name": "m"}],
                         "panels": [{"name": "a", "material": "m", "size": [1, 1], "resolution": [1, 3]}]})",
                     "test.json: /panels/0/resolution: both must be at least 2 (got [1, 3])", "/panels/0/resolution");
}

TEST(SceneErrors, UnknownMaterial) {
  expect_parse_error(R"({"materials": [{"name": "cotton"}],
                         "panels": [{"name": "a", "material": "silk", "size": [1, 1], "resolution": [3, 3]}]})",
                     "test.json: /panels/0/material: unknown material 'silk'", "/panels/0/material");
}

TEST(SceneErrors, UnknownField) {
  expect_parse_error(R"({"materials": [{"name": "m"}],
                         "panels": [{"name": "a", "material": "m", "sizee": [1, 1], "size": [1, 1], "resolution": [3, 3]}]})",
                     "test.json: /panels/0/sizee: unknown field 'sizee'", "/panels/0/sizee");
  expect_parse_error(with_obstacle(R"({"type": "box", "radius": 1})"),
                     "test.json: /obstacles/0/radius: field 'radius' does not apply to obstacle type 'box'",
                     "/obstacles/0/radius");
  expect_parse_error(with_obstacle(R"({"type": "uv_sphere", "close_holes": false})"),
                     "test.json: /obstacles/0/close_holes: field 'close_holes' does not apply to obstacle type 'uv_sphere'",
                     "/obstacles/0/close_holes");
  expect_parse_error(with_obstacle(R"({"type": "mesh", "file": "x.obj", "close_holes": 1})"),
                     "test.json: /obstacles/0/close_holes: expected true or false, got number", "/obstacles/0/close_holes");
}

TEST(SceneErrors, UnknownPanelAndEdge) {
  expect_parse_error(R"({"materials": [{"name": "m"}],
                         "panels": [{"name": "a", "material": "m", "size": [1, 1], "resolution": [3, 3]}],
                         "seams": [{"a": {"panel": "a", "edge": "top"}, "b": {"panel": "x", "edge": "top"}}]})",
                     "test.json: /seams/0/b/panel: unknown panel 'x'", "/seams/0/b/panel");
  expect_parse_error(R"({"materials": [{"name": "m"}],
                         "panels": [{"name": "a", "material": "m", "size": [1, 1], "resolution": [3, 3]}],
                         "pins": [{"panel": "a", "edge": "middle"}]})",
                     "test.json: /pins/0/edge: unknown edge 'middle' (expected left, right, bottom or top)",
                     "/pins/0/edge");
  expect_parse_error(R"({"materials": [{"name": "m"}],
                         "panels": [{"name": "a", "material": "m", "size": [1, 1], "resolution": [3, 3]}],
                         "pins": [{"panel": "a", "edge": "top", "corner": "top_left"}]})",
                     "test.json: /pins/0: a pin needs exactly one of corner, edge, segment or range", "/pins/0");
}

TEST(SceneErrors, SeamEdgesOfDifferentLength) {
  expect_parse_error(R"({"materials": [{"name": "m"}],
                         "panels": [{"name": "a", "material": "m", "size": [1.5, 0.75], "resolution": [51, 26]},
                                    {"name": "b", "material": "m", "size": [0.75, 0.75], "resolution": [26, 26]}],
                         "seams": [{"a": {"panel": "a", "edge": "top"}, "b": {"panel": "b", "edge": "left"}}]})",
                     "test.json: /seams/0: edge 'top' of panel 'a' has 51 vertices but edge 'left' of panel 'b' has 26",
                     "/seams/0");
}

TEST(SceneErrors, ObjFileMissing) {
  const std::string origin = kSource + "/tests/data/scene.json";
  expect_input_error(
      [&] { parse_scene(with_obstacle(R"({"type": "mesh", "file": "missing.obj"})"), origin); },
      origin + ": /obstacles/0/file: OBJ file '" + kSource + "/tests/data/missing.obj' does not exist",
      "/obstacles/0/file");
  expect_parse_error(with_obstacle(R"({"type": "mesh"})"), "test.json: /obstacles/0/file: missing required field",
                     "/obstacles/0/file");
}

TEST(SceneErrors, ObjFileMalformed) {
  const std::string origin = kSource + "/tests/data/scene.json";
  const SceneDef s = parse_scene(with_obstacle(R"({"type": "mesh", "file": "bad.obj"})"), origin);
  expect_input_error([&] { build_obstacles(s); },
                     origin + ": /obstacles/0/file: OBJ file '" + kSource +
                         "/tests/data/bad.obj' is malformed: face refers to vertex 99 of 3",
                     "/obstacles/0/file");
}

TEST(SceneErrors, ObjVertexThatIsNotAFiniteNumberNamesTheLine) {
  const std::string origin = kSource + "/tests/data/scene.json";
  const SceneDef nan = parse_scene(with_obstacle(R"({"type": "mesh", "file": "nan_vertex.obj"})"), origin);
  expect_input_error([&] { build_obstacles(nan); },
                     origin + ": /obstacles/0/file: OBJ file '" + kSource +
                         "/tests/data/nan_vertex.obj' line 3: vertex coordinate 'nan' is not a finite number",
                     "/obstacles/0/file");
  const SceneDef huge = parse_scene(with_obstacle(R"({"type": "mesh", "file": "huge_vertex.obj"})"), origin);
  expect_input_error([&] { build_obstacles(huge); },
                     origin + ": /obstacles/0/file: OBJ file '" + kSource +
                         "/tests/data/huge_vertex.obj' line 2: vertex coordinate '1e40' is not a finite number",
                     "/obstacles/0/file");
}

TEST(SceneErrors, JsonSyntaxError) {
  expect_parse_error("{\n  \"name\": \"x\",\n  \"time\": {\"dt\": 0.001,}\n}",
                     "test.json: parse error at line 3, column 24: syntax error while parsing object key - "
                     "unexpected '}'; expected string literal",
                     "");
}

TEST(SceneErrors, NumberTooLargeForADoubleNamesTheField) {
  expect_parse_error(R"({"time": {"dt": 1e400}})",
                     "test.json: /time/dt: number overflow parsing '1e400': not a finite number", "/time/dt");
  expect_parse_error(R"({"panels": [{"name": "a"}, {"name": "b", "size": [1, -1e999]}]})",
                     "test.json: /panels/1/size/1: number overflow parsing '-1e999': not a finite number",
                     "/panels/1/size/1");
}

TEST(SceneErrors, UnknownObstacleType) {
  expect_parse_error(with_obstacle(R"({"type": "cone"})"),
                     "test.json: /obstacles/0/type: unknown obstacle type 'cone' (expected uv_sphere, box, plane, mesh or skinned)",
                     "/obstacles/0/type");
}

TEST(SceneErrors, MissingSceneFile) {
  const std::string path = kSource + "/scenes/no_such_scene.json";
  expect_input_error([&] { load_scene_file(path); }, path + ": cannot open scene file: No such file or directory", "");
}

std::string with_output(const std::string& output) {
  return R"({"materials": [{"name": "m"}],
             "panels": [{"name": "a", "material": "m", "size": [1, 1], "resolution": [3, 3]}],
             "output": )" +
         output + "}";
}

TEST(SceneFile, OutputSectionIsRead) {
  const SceneDef d = parse_scene(kOnePanel, "test.json");
  EXPECT_EQ(d.output.formats, std::vector<std::string>{"obj"});
  EXPECT_FALSE(d.output.render);
  EXPECT_FALSE(d.output.camera.position.has_value());
  const SceneDef s = parse_scene(with_output(R"({"formats": ["ply", "glb"], "render": true, "video": true,
      "camera": {"position": [0, 1, 3], "target": [0, 0.5, 0], "fov": 30, "resolution": [320, 200], "samples": 2}})"),
                                 "test.json");
  EXPECT_EQ(s.output.formats, (std::vector<std::string>{"ply", "glb"}));
  EXPECT_TRUE(s.output.render);
  EXPECT_TRUE(s.output.video);
  ASSERT_TRUE(s.output.camera.position.has_value());
  EXPECT_EQ(*s.output.camera.position, (Float3{0, 1, 3}));
  EXPECT_EQ(*s.output.camera.target, (Float3{0, 0.5f, 0}));
  EXPECT_EQ(s.output.camera.fov, 30.0f);
  EXPECT_EQ(s.output.camera.width, 320);
  EXPECT_EQ(s.output.camera.height, 200);
  EXPECT_EQ(s.output.camera.samples, 2);
}

TEST(SceneErrors, BadOutputSection) {
  expect_parse_error(with_output(R"({"formats": ["obj", "fbx"]})"),
                     "test.json: /output/formats/1: unknown format 'fbx' (expected obj, ply, pc2 or glb)",
                     "/output/formats/1");
  expect_parse_error(with_output(R"({"formats": ["ply", "ply"]})"),
                     "test.json: /output/formats/1: format 'ply' is listed twice", "/output/formats/1");
  expect_parse_error(with_output(R"({"formats": "ply"})"),
                     "test.json: /output/formats: expected an array of format names, got string", "/output/formats");
  expect_parse_error(with_output(R"({"camera": {"fov": 0}})"),
                     "test.json: /output/camera/fov: must be between 0 and 180 degrees (got 0)", "/output/camera/fov");
  expect_parse_error(with_output(R"({"camera": {"resolution": [0, 720]}})"),
                     "test.json: /output/camera/resolution: both must be between 1 and 16384 pixels (got [0, 720])",
                     "/output/camera/resolution");
  expect_parse_error(with_output(R"({"camera": {"position": [1, 1, 1], "target": [1, 1, 1]}})"),
                     "test.json: /output/camera/target: must differ from the camera position", "/output/camera/target");
  expect_parse_error(with_output(R"({"camera": {"samples": 0}})"),
                     "test.json: /output/camera/samples: must be between 1 and 1024 (got 0)", "/output/camera/samples");
  expect_parse_error(with_output(R"({"render": "yes"})"),
                     "test.json: /output/render: expected true or false, got string", "/output/render");
}

TEST(SceneValidate, CodeBuiltScenesGetTheSameChecks) {
  SceneDef s = code_scene();
  EXPECT_NO_THROW(validate_scene(s));
  s.seams.push_back({.a = {"a", "top"}, .b = {"b", "left"}});
  expect_input_error([&] { validate_scene(s); },
                     "code: /seams/0: edge 'top' of panel 'a' has 51 vertices but edge 'left' of panel 'b' has 26",
                     "/seams/0");
  s.seams[0].b.edge = "top";  // 26 vertices as well: still wrong
  EXPECT_THROW(validate_scene(s), InputError);
  s.seams[0].a.edge = "left";  // 26 and 26
  EXPECT_NO_THROW(validate_scene(s));

  s.pins.push_back({.panel = "b", .range = std::array<int, 2>{600, 700}});
  expect_input_error([&] { validate_scene(s); },
                     "code: /pins/0/range: range [600, 700] is outside panel 'b' (vertices 0 to 675)", "/pins/0/range");
  s.pins[0] = {.panel = "c", .corner = "top_left"};
  expect_input_error([&] { validate_scene(s); }, "code: /pins/0/panel: unknown panel 'c'", "/pins/0/panel");
  s.pins[0] = {.panel = "a", .corner = "top"};
  expect_input_error([&] { validate_scene(s); },
                     "code: /pins/0/corner: unknown corner 'top' (expected bottom_left, bottom_right, top_left or "
                     "top_right)",
                     "/pins/0/corner");
  s.pins.clear();

  s.panels[1].name = "a";
  expect_input_error([&] { validate_scene(s); }, "code: /panels/1/name: duplicate panel name 'a' (also /panels/0)",
                     "/panels/1/name");
  s.panels.clear();
  expect_input_error([&] { validate_scene(s); }, "code: /panels: the scene needs at least one panel", "/panels");
}

TEST(SceneValidate, DefaultSceneIsValid) { EXPECT_NO_THROW(validate_scene(default_scene())); }

// Every scene in scenes/ loads, builds, and has a time step well inside the stability limit: at
// most 3/4 of the mesh's limit 2 sqrt(m / K) (K summed over each vertex's springs; the seed scene
// uses about half) and a third of the shortest natural period pi sqrt(m / k).
TEST(SceneExamples, AllLoadAndAreStable) {
  int count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kSource + "/scenes")) {
    if (entry.path().extension() != ".json") continue;
    SCOPED_TRACE(entry.path().string());
    const SceneDef s = load_scene_file(entry.path().string());
    const ClothModel m = build_cloth_model(s);
    const ObstacleSet o = build_obstacles(s);
    EXPECT_GT(m.num_vertices(), 0u);
    EXPECT_LE(s.time.dt, 0.75 * m.stability_limit());
    EXPECT_LE(s.time.dt, m.natural_period() / 3.0);
    if (entry.path().filename() != "seed_drape.json") EXPECT_LT(m.num_vertices(), 3000u);
    ++count;
  }
  EXPECT_GE(count, 4);
}

}  // namespace
}  // namespace raycloth
