// Rendered images: size, determinism, what lands where (sphere, cloth, sky), the camera framing,
// and the CLI's --render, render DIR and --video paths end to end.
#include <gtest/gtest.h>
#include <stb/stb_image.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "fixtures.h"
#include "io/run.h"
#include "render/image_frames.h"
#include "sim/model.h"
#include "skinned_gltf.h"
#include "raycloth/simulator.h"
#include "render/renderer.h"

namespace fs = std::filesystem;
using namespace raycloth;

namespace {

// A 1 m panel (11 x 11 vertices) 0.6 m above a sphere of radius 0.3 at the origin.
SceneDef panel_over_sphere() {
  SceneDef s = test::panel_scene(11, 1.0f, 0.6f);
  s.obstacles.push_back(test::sphere_obstacle(0.3f, {0, 0, 0}));
  return s;
}

struct Rendered {
  RgbImage image;
  View view;
};

Rendered render_scene(const SceneDef& scene, const CameraDef& camera) {
  Simulator sim(scene);
  const RenderScene rs = make_render_scene(sim);
  Rendered r;
  r.view = make_view(rs.bounds(), camera);
  Renderer renderer;
  r.image = renderer.render(rs, r.view);
  return r;
}

CameraDef small_camera(int samples = 2) {
  CameraDef c;
  c.width = 160;
  c.height = 90;
  c.samples = samples;
  return c;
}

struct Colour {
  float r, g, b;  // 0..255, mean of a region
  float hue() const {  // degrees
    const float mx = std::max({r, g, b}), mn = std::min({r, g, b});
    if (mx == mn) return 0;
    float h = mx == r ? (g - b) / (mx - mn) : mx == g ? 2 + (b - r) / (mx - mn) : 4 + (r - g) / (mx - mn);
    return std::fmod(h * 60 + 360, 360.0f);
  }
  float saturation() const {
    const float mx = std::max({r, g, b});
    return mx > 0 ? (mx - std::min({r, g, b})) / mx : 0;
  }
};

// Mean colour of the (2 half + 1)^2 pixels around (x, y).
Colour region(const RgbImage& img, float fx, float fy, int half = 1) {
  const int x0 = int(fx), y0 = int(fy);
  Colour c{0, 0, 0};
  int n = 0;
  for (int y = y0 - half; y <= y0 + half; ++y)
    for (int x = x0 - half; x <= x0 + half; ++x) {
      if (x < 0 || y < 0 || x >= img.width || y >= img.height) continue;
      const uint8_t* p = &img.pixels[(size_t(y) * img.width + x) * 3];
      c.r += p[0], c.g += p[1], c.b += p[2];
      ++n;
    }
  EXPECT_GT(n, 0) << "region outside the image at " << fx << ", " << fy;
  return n ? Colour{c.r / n, c.g / n, c.b / n} : c;
}

float hue_of(const LinearRgb& albedo) { return Colour{albedo[0], albedo[1], albedo[2]}.hue(); }
float hue_distance(float a, float b) {
  const float d = std::fabs(a - b);
  return std::min(d, 360 - d);
}

}  // namespace

TEST(Render, ImageHasTheRequestedSize) {
  const Rendered r = render_scene(panel_over_sphere(), small_camera(1));
  EXPECT_EQ(r.image.width, 160);
  EXPECT_EQ(r.image.height, 90);
  EXPECT_EQ(r.image.pixels.size(), 160u * 90u * 3u);
}

TEST(Render, SameSceneGivesIdenticalBytesOnAnyNumberOfThreads) {
  const Rendered a = render_scene(panel_over_sphere(), small_camera());
  const Rendered b = render_scene(panel_over_sphere(), small_camera());
  EXPECT_EQ(a.image.pixels, b.image.pixels);
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  const Rendered c = render_scene(panel_over_sphere(), small_camera());
  EXPECT_EQ(a.image.pixels, c.image.pixels);
  // And the PNG bytes.
  const fs::path dir = fs::temp_directory_path() / "raycloth_render_png";
  fs::create_directories(dir);
  write_png(dir / "a.png", a.image);
  write_png(dir / "c.png", c.image);
  auto bytes = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  EXPECT_EQ(bytes(dir / "a.png"), bytes(dir / "c.png"));
  EXPECT_FALSE(fs::exists(dir / "a.png.tmp"));
}

TEST(Render, SphereClothAndSkyLandWhereTheCameraSaysTheyDo) {
  const Rendered r = render_scene(panel_over_sphere(), small_camera());
  const Camera& cam = r.view.camera;
  float x, y;

  // The sphere's centre: the obstacle's neutral grey, neither sky nor cloth.
  ASSERT_TRUE(cam.project(make_vec3(0, 0, 0), x, y));
  const Colour sphere = region(r.image, x, y);
  EXPECT_LT(sphere.saturation(), 0.12f) << sphere.r << " " << sphere.g << " " << sphere.b;
  EXPECT_GT(sphere.g, 40.0f);

  // The middle of the panel seen from above: the first palette colour's hue, saturated.
  ASSERT_TRUE(cam.project(make_vec3(0.2f, 0.6f, 0.2f), x, y));
  const Colour cloth = region(r.image, x, y);
  EXPECT_LT(hue_distance(cloth.hue(), hue_of(panel_colour(0))), 15.0f) << cloth.hue();
  EXPECT_GT(cloth.saturation(), 0.4f);

  // The top corners: sky, bright and blue.
  for (float cx : {1.0f, 158.0f}) {
    const Colour sky = region(r.image, cx, 1.0f);
    EXPECT_GT(sky.b, sky.r + 15) << cx;
    EXPECT_GT(sky.b, 170.0f) << cx;
  }

  // The bottom corners: the ground in front of the sphere, warm grey (red at least blue).
  for (float cx : {1.0f, 158.0f}) {
    const Colour ground = region(r.image, cx, 88.0f);
    EXPECT_GE(ground.r, ground.b) << cx;
    EXPECT_LT(ground.saturation(), 0.15f) << cx;
  }
}

TEST(Render, PlacedCameraLooksAtItsTarget) {
  CameraDef c = small_camera();
  c.position = Float3{0, 0, 3};
  c.target = Float3{0, 0, 0};
  const Rendered r = render_scene(panel_over_sphere(), c);
  // Looking straight at the sphere: the image centre is the sphere's grey.
  const Colour centre = region(r.image, 80, 45, 2);
  EXPECT_LT(centre.saturation(), 0.12f);
  float x, y;
  ASSERT_TRUE(r.view.camera.project(make_vec3(0, 0, 0), x, y));
  EXPECT_NEAR(x, 80.0f, 1e-3f);
  EXPECT_NEAR(y, 45.0f, 1e-3f);
}

TEST(Render, AutomaticCameraKeepsTheWholeSceneInView) {
  for (const SceneDef& scene : {panel_over_sphere(), default_scene()}) {
    Simulator sim(scene);
    const RenderScene rs = make_render_scene(sim);
    for (auto [w, h] : {std::pair{1280, 720}, std::pair{400, 800}}) {
      CameraDef c;
      c.width = w;
      c.height = h;
      const View v = make_view(rs.bounds(), c);
      const Bounds b = rs.bounds();
      float x, y;
      for (int i = 0; i < 8; ++i) {
        const Vec3 corner = make_vec3(i & 1 ? b.hi.x : b.lo.x, i & 2 ? b.hi.y : b.lo.y, i & 4 ? b.hi.z : b.lo.z);
        ASSERT_TRUE(v.camera.project(corner, x, y));
        EXPECT_GE(x, 0.0f);
        EXPECT_LE(x, float(w));
        EXPECT_GE(y, 0.0f);
        EXPECT_LE(y, float(h));
      }
      // Slightly from above.
      EXPECT_GT(v.camera.eye.y, v.camera.target.y);
      EXPECT_LT(v.camera.forward.y, -0.2f);
    }
  }
}

// --- The command line ---

namespace {

struct CliResult {
  int code;
  std::string out, err;
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

CliResult cli(const std::string& args, const fs::path& dir, const std::string& env = "") {
  fs::create_directories(dir);
  const std::string cmd = env + (env.empty() ? "" : " ") + RAYCLOTH_CLI + " " + args + " > " +
                          (dir / "stdout.txt").string() + " 2> " + (dir / "stderr.txt").string();
  const int status = std::system(cmd.c_str());
  return {WEXITSTATUS(status), slurp(dir / "stdout.txt"), slurp(dir / "stderr.txt")};
}

fs::path fresh(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("raycloth_render_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// Two frames (0 and 1) of a small panel falling onto a sphere.
fs::path tiny_scene(const fs::path& dir) {
  const fs::path p = dir / "tiny.json";
  std::ofstream(p) << R"({
    "name": "tiny",
    "time": { "dt": 0.0004, "duration": 0.05, "fps": 20 },
    "materials": [ { "name": "cotton" } ],
    "panels": [ { "name": "sheet", "material": "cotton", "size": [0.5, 0.5], "resolution": [6, 6],
                  "position": [0, 0.3, 0] } ],
    "obstacles": [ { "type": "uv_sphere", "radius": 0.2 } ]
  })";
  return p;
}

std::array<int, 2> png_size(const fs::path& p) {
  int w = 0, h = 0, n = 0;
  unsigned char* data = stbi_load(p.string().c_str(), &w, &h, &n, 3);
  EXPECT_NE(data, nullptr) << p;
  stbi_image_free(data);
  return {w, h};
}

bool ffmpeg_on_path() { return std::system("command -v ffmpeg > /dev/null 2>&1") == 0; }

TEST(RenderFolder, DrawsTheSkinnedBodyPosedPerFrame) {
  // `raycloth render DIR` draws what read_output_frame returns: the per-frame obstacle OBJ.
  const SceneDef s = test::panel_beside_an_arm(fresh("render_skinned_gltf"), "render_skinned");
  const fs::path out = fresh("render_skinned");
  RunOptions opt;
  opt.out_dir = out;
  opt.quiet = true;
  opt.formats = std::vector<std::string>{"obj"};
  run_scene(s, opt);
  const OutputFolder folder = read_output_folder(out);
  ASSERT_EQ(folder.frames.size(), 8u);
  const ObstacleSet set = build_obstacles(s);
  for (int k : {1, 7}) {
    const RenderScene r = read_output_frame(folder, k);
    std::vector<Vec3> x, v;
    // As the run writes frames: every steps_per_frame steps, the last at the end of the run.
    const long steps_per_frame = std::lround(1.0 / (s.time.fps * s.time.dt));
    const long steps = std::min(k * steps_per_frame, std::lround(s.time.duration / s.time.dt));
    set.pose_at(double(steps) * s.time.dt, x, v);
    ASSERT_EQ(r.obstacle_vertices.size(), x.size());
    for (size_t i = 0; i < x.size(); ++i) ASSERT_LT(length(r.obstacle_vertices[i] - x[i]), 1e-5f) << "frame " << k;
  }
}

}  // namespace

TEST(RenderCli, RunRenderWritesAnImagePerFrameAtTheRequestedResolution) {
  const fs::path dir = fresh("run");
  const CliResult r = cli("run " + tiny_scene(dir).string() + " --quiet --render --resolution 64x36 --samples 1 --out " +
                              (dir / "out").string(), dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(png_size(dir / "out" / "images" / "frame_0000.png"), (std::array<int, 2>{64, 36}));
  EXPECT_EQ(png_size(dir / "out" / "images" / "frame_0001.png"), (std::array<int, 2>{64, 36}));
  EXPECT_FALSE(fs::exists(dir / "out" / "images" / "frame_0002.png"));
  EXPECT_FALSE(fs::exists(dir / "out" / "video.mp4"));
  std::ifstream in(dir / "out" / "run.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["fps"], 20.0);
  EXPECT_EQ(j["camera"]["resolution"], nlohmann::json({64, 36}));
  EXPECT_EQ(j["camera"]["samples"], 1);
}

TEST(RenderCli, SceneOutputRenderIsHonoured) {
  const fs::path dir = fresh("scene_render");
  std::string text = slurp(tiny_scene(dir));
  text.insert(text.rfind('}'), R"(, "output": { "render": true, "camera": { "resolution": [40, 30], "samples": 1 } })");
  std::ofstream(dir / "tiny.json") << text;
  const CliResult r = cli("run " + (dir / "tiny.json").string() + " --quiet --out " + (dir / "out").string(), dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(png_size(dir / "out" / "images" / "frame_0001.png"), (std::array<int, 2>{40, 30}));
}

TEST(RenderCli, RenderDirRendersAnExistingOutputFolderWithItsCamera) {
  const fs::path dir = fresh("dir");
  const fs::path out = dir / "out";
  ASSERT_EQ(cli("run " + tiny_scene(dir).string() + " --quiet --resolution 48x32 --out " + out.string(), dir).code, 0);
  EXPECT_FALSE(fs::exists(out / "images"));
  CliResult r = cli("render " + out.string() + " --quiet --samples 1", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(png_size(out / "images" / "frame_0000.png"), (std::array<int, 2>{48, 32}));  // the run's resolution
  EXPECT_EQ(png_size(out / "images" / "frame_0001.png"), (std::array<int, 2>{48, 32}));
  r = cli("render " + out.string() + " --quiet --samples 1 --resolution 30x20 --camera-pos 0,1,2 --camera-target 0,0,0",
          dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(png_size(out / "images" / "frame_0001.png"), (std::array<int, 2>{30, 20}));
}

TEST(RenderCli, RenderDirWithoutRunJsonFailsWithTheReason) {
  const fs::path dir = fresh("no_run_json");
  const CliResult r = cli("render " + dir.string(), dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: " + (dir / "run.json").string() +
                       ": cannot open: No such file or directory (is it an output folder of raycloth run?)\n");
  EXPECT_FALSE(fs::exists(dir / "images"));
}

TEST(RenderCli, RenderDirWithAMissingFrameNamesTheFile) {
  const fs::path dir = fresh("missing_frame");
  const fs::path out = dir / "out";
  ASSERT_EQ(cli("run " + tiny_scene(dir).string() + " --quiet --out " + out.string(), dir).code, 0);
  fs::remove(out / "frames" / "cloth_0001.obj");
  const CliResult r = cli("render " + out.string() + " --quiet --resolution 16x16 --samples 1", dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: " + (out / "frames" / "cloth_0001.obj").string() +
                       ": does not exist (rendering a folder needs the run's OBJ frames, output format obj)\n");
}

TEST(RenderCli, CameraOptionsAreCheckedLikeTheSceneFile) {
  const fs::path dir = fresh("camera_options");
  const std::string scene = tiny_scene(dir).string(), out = " --out " + (dir / "out").string();
  struct Case {
    std::string args, message;
  };
  for (const Case& c : {
           Case{"--fov 200", "command line: /output/camera/fov: must be between 0 and 180 degrees (got 200)"},
           Case{"--fov wide", "command line: /output/camera/fov: expected a number (got 'wide')"},
           Case{"--resolution 12x", "command line: /output/camera/resolution: expected WxH (got '12x')"},
           Case{"--resolution 0x10",
                "command line: /output/camera/resolution: both must be between 1 and 16384 pixels (got [0, 10])"},
           Case{"--samples 0", "command line: /output/camera/samples: must be between 1 and 1024 (got 0)"},
           Case{"--camera-pos 1,2", "command line: /output/camera/position: expected x,y,z (got '1,2')"},
           Case{"--camera-pos 1,2,3 --camera-target 1,2,3",
                "command line: /output/camera/target: must differ from the camera position"},
       }) {
    const CliResult r = cli("run " + scene + " --render " + c.args + out, dir);
    EXPECT_EQ(r.code, 2) << c.args;
    EXPECT_EQ(r.err, "raycloth: error: " + c.message + "\n") << c.args;
    EXPECT_FALSE(fs::exists(dir / "out")) << c.args;
  }
}

TEST(RenderCli, VideoWithoutFfmpegWarnsAndKeepsTheImages) {
  const fs::path dir = fresh("no_ffmpeg");
  const fs::path out = dir / "out";
  const CliResult r = cli("run " + tiny_scene(dir).string() + " --quiet --video --resolution 32x18 --samples 1 --out " +
                              out.string(), dir, "RAYCLOTH_FFMPEG=/nonexistent/ffmpeg");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err, "raycloth: warning: cannot run ffmpeg '/nonexistent/ffmpeg' (No such file or directory): no video; "
                   "the images are in " + (out / "images").string() +
                   ". Install ffmpeg (apt-get install ffmpeg) or set RAYCLOTH_FFMPEG to its path, then run: "
                   "raycloth render " + out.string() + " --video\n");
  EXPECT_TRUE(fs::exists(out / "images" / "frame_0000.png"));
  EXPECT_TRUE(fs::exists(out / "images" / "frame_0001.png"));
  EXPECT_FALSE(fs::exists(out / "video.mp4"));
}

TEST(RenderCli, FailingFfmpegIsAnErrorWithItsOutputAndKeepsTheImages) {
  const fs::path dir = fresh("bad_ffmpeg");
  const fs::path out = dir / "out";
  const fs::path fake = dir / "fake_ffmpeg.sh";
  std::ofstream(fake) << "#!/bin/sh\necho 'first line' >&2\necho 'Unknown encoder libx264' >&2\nexit 3\n";
  fs::permissions(fake, fs::perms::owner_all);
  const CliResult r = cli("run " + tiny_scene(dir).string() + " --quiet --video --resolution 32x18 --samples 1 --out " +
                              out.string(), dir, "RAYCLOTH_FFMPEG=" + fake.string());
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "raycloth: error: " + (out / "video.mp4").string() +
                       ": ffmpeg failed (exit code 3), the images are kept: first line\nUnknown encoder libx264\n");
  EXPECT_TRUE(fs::exists(out / "images" / "frame_0001.png"));
  EXPECT_FALSE(fs::exists(out / "video.mp4"));
  EXPECT_FALSE(fs::exists(out / "video.mp4.tmp"));
}

TEST(RenderCli, VideoFromTheImagesWhenFfmpegIsInstalled) {
  if (!ffmpeg_on_path()) GTEST_SKIP() << "ffmpeg is not installed (apt-get install ffmpeg)";
  const fs::path dir = fresh("video");
  const fs::path out = dir / "out";
  // Odd sizes: the video is padded to even ones.
  CliResult r = cli("run " + tiny_scene(dir).string() + " --quiet --video --resolution 33x19 --samples 1 --out " +
                        out.string(), dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  ASSERT_TRUE(fs::exists(out / "video.mp4"));
  EXPECT_GT(fs::file_size(out / "video.mp4"), 0u);
  EXPECT_FALSE(fs::exists(out / "video.mp4.tmp"));
  fs::remove(out / "video.mp4");
  r = cli("render " + out.string() + " --quiet --video --samples 1", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_GT(fs::file_size(out / "video.mp4"), 0u);
}
