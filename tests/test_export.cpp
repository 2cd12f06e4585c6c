// Exchange formats (PLY frames, PC2 point cache, glTF binary) read back by independent readers,
// and the run's summary picture.
#include <gtest/gtest.h>
#include <stb/stb_image.h>
#include <tiny_gltf.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "fixtures.h"
#include "skinned_gltf.h"
#include "io/run.h"
#include "io/run_summary.h"
#include "raycloth/error.h"
#include "scene/transform.h"
#include "sim/model.h"

namespace fs = std::filesystem;

namespace raycloth {
namespace {

// Copies what the simulator holds at every frame, to compare the files against.
class Recorder final : public FrameSink {
 public:
  void frame(Simulator& sim, const FrameRecord& r) override {
    times.push_back(r.time);
    cloth.push_back(sim.positions());
    obstacles.push_back(sim.obstacle_vertices());
  }
  std::vector<double> times;
  std::vector<std::vector<Vec3>> cloth, obstacles;
};

// A 6 x 5 panel falling onto a sphere for 0.2 s: frame 0 and 7 more frames.
SceneDef falling_panel() {
  SceneDef s = test::panel_scene(6, 0.5f, 0.3f);
  s.name = "export_test";
  s.panels[0].resolution_v = 5;
  s.panels[0].height = 0.4f;
  s.time.duration = 0.2;
  s.obstacles.push_back(test::sphere_obstacle(0.2f, {0, 0, 0}));
  return s;
}

fs::path fresh_dir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("raycloth_export_" + name);
  fs::remove_all(d);
  return d;
}

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

template <typename T>
T read_at(const std::string& bytes, size_t offset) {
  T v;
  std::memcpy(&v, bytes.data() + offset, sizeof(T));
  return v;
}

std::shared_ptr<Recorder> run_with(const SceneDef& s, const fs::path& out, std::vector<std::string> formats) {
  auto rec = std::make_shared<Recorder>();
  RunOptions opt;
  opt.out_dir = out;
  opt.quiet = true;
  opt.formats = std::move(formats);
  opt.sinks.push_back(rec);
  run_scene(s, opt);
  return rec;
}

// The components of a float accessor's elements, in order.
std::vector<float> accessor_floats(const tinygltf::Model& m, int index) {
  const tinygltf::Accessor& a = m.accessors[size_t(index)];
  const tinygltf::BufferView& bv = m.bufferViews[size_t(a.bufferView)];
  const int components = tinygltf::GetNumComponentsInType(uint32_t(a.type));
  const int stride = a.ByteStride(bv);
  std::vector<float> out;
  const unsigned char* base = m.buffers[size_t(bv.buffer)].data.data() + bv.byteOffset + a.byteOffset;
  for (size_t i = 0; i < a.count; ++i)
    for (int c = 0; c < components; ++c) {
      float f;
      std::memcpy(&f, base + i * size_t(stride) + size_t(c) * sizeof(float), sizeof(float));
      out.push_back(f);
    }
  return out;
}

Vec3 rotate(const std::vector<float>& q, Vec3 v) {  // q = (x, y, z, w)
  const Vec3 u = make_vec3(q[0], q[1], q[2]);
  const float w = q[3];
  return 2.0f * dot(u, v) * u + (w * w - dot(u, u)) * v + 2.0f * w * cross(u, v);
}

TEST(Export, PlyFramesHaveTheModelsCountsAndTheFinalPositions) {
  const fs::path out = fresh_dir("ply");
  const auto rec = run_with(falling_panel(), out, {"ply"});
  ASSERT_EQ(rec->cloth.size(), 8u);
  for (const auto& e : fs::directory_iterator(out / "frames")) EXPECT_EQ(e.path().extension(), ".ply") << e.path();
  const std::string bytes = read_all(out / "frames" / "cloth_0007.ply");
  const size_t end = bytes.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  const std::string header = bytes.substr(0, end + 11);
  EXPECT_EQ(header.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u) << header;
  EXPECT_NE(header.find("comment panel 0 cloth\n"), std::string::npos) << header;
  EXPECT_NE(header.find("element vertex 30\n"), std::string::npos) << header;  // 6 x 5
  EXPECT_NE(header.find("element face 40\n"), std::string::npos) << header;    // 5 x 4 cells, 2 each
  // x y z nx ny nz (float) + panel (uint) per vertex; a uchar count and 3 ints per face.
  ASSERT_EQ(bytes.size(), header.size() + 30 * 28 + 40 * 13);
  for (size_t i = 0; i < 30; ++i) {
    const Vec3 p = make_vec3(read_at<float>(bytes, header.size() + 28 * i), read_at<float>(bytes, header.size() + 28 * i + 4),
                             read_at<float>(bytes, header.size() + 28 * i + 8));
    EXPECT_EQ(p.x, rec->cloth.back()[i].x);
    EXPECT_EQ(p.y, rec->cloth.back()[i].y);
    EXPECT_EQ(p.z, rec->cloth.back()[i].z);
    const Vec3 n = make_vec3(read_at<float>(bytes, header.size() + 28 * i + 12),
                             read_at<float>(bytes, header.size() + 28 * i + 16),
                             read_at<float>(bytes, header.size() + 28 * i + 20));
    EXPECT_NEAR(length(n), 1.0f, 1e-5f);
  }
  const size_t faces = header.size() + 30 * 28;
  EXPECT_EQ(read_at<uint8_t>(bytes, faces), 3);
  EXPECT_FALSE(fs::exists(out / "frames" / "cloth_0000.obj"));
  EXPECT_TRUE(fs::exists(out / "obstacles.obj"));
}

TEST(Export, Pc2HeaderAndSamplesMatchTheRun) {
  const fs::path out = fresh_dir("pc2");
  const auto rec = run_with(falling_panel(), out, {"pc2"});
  const std::string b = read_all(out / "cloth.pc2");
  ASSERT_GE(b.size(), 32u);
  EXPECT_EQ(std::memcmp(b.data(), "POINTCACHE2\0", 12), 0);
  EXPECT_EQ(read_at<int32_t>(b, 12), 1);           // version
  EXPECT_EQ(read_at<int32_t>(b, 16), 30);          // points
  EXPECT_EQ(read_at<float>(b, 20), 0.0f);          // start frame
  EXPECT_EQ(read_at<float>(b, 24), 1.0f);          // one sample per frame
  const int32_t samples = read_at<int32_t>(b, 28);
  EXPECT_EQ(samples, 8);
  ASSERT_EQ(b.size(), 32u + size_t(samples) * 30 * 12);
  for (int s : {0, samples - 1})
    for (size_t i = 0; i < 30; ++i) {
      const size_t at = 32 + (size_t(s) * 30 + i) * 12;
      EXPECT_EQ(read_at<float>(b, at), rec->cloth[size_t(s)][i].x);
      EXPECT_EQ(read_at<float>(b, at + 4), rec->cloth[size_t(s)][i].y);
      EXPECT_EQ(read_at<float>(b, at + 8), rec->cloth[size_t(s)][i].z);
    }
  EXPECT_FALSE(fs::exists(out / "cloth.pc2.tmp"));
  // The rest pose: one object, its vertices in the cache's point order (frame 0).
  std::ifstream obj(out / "cloth_rest.obj");
  std::string line;
  size_t v = 0, f = 0, o = 0;
  while (std::getline(obj, line)) {
    if (line.rfind("v ", 0) == 0) {
      float x, y, z;
      ASSERT_EQ(std::sscanf(line.c_str(), "v %f %f %f", &x, &y, &z), 3);
      EXPECT_NEAR(x, rec->cloth[0][v].x, 1e-6f);
      EXPECT_NEAR(y, rec->cloth[0][v].y, 1e-6f);
      EXPECT_NEAR(z, rec->cloth[0][v].z, 1e-6f);
      ++v;
    }
    f += line.rfind("f ", 0) == 0;
    o += line.rfind("o ", 0) == 0;
  }
  EXPECT_EQ(v, 30u);
  EXPECT_EQ(f, 40u);
  EXPECT_EQ(o, 1u);
}

TEST(Export, GlbLoadsAndItsLastMorphTargetIsTheFinalFrame) {
  const fs::path out = fresh_dir("glb");
  const auto rec = run_with(falling_panel(), out, {"glb"});
  tinygltf::TinyGLTF loader;
  tinygltf::Model m;
  std::string err, warn;
  ASSERT_TRUE(loader.LoadBinaryFromFile(&m, &err, &warn, (out / "cloth.glb").string())) << err;
  EXPECT_TRUE(warn.empty()) << warn;
  const size_t frames = rec->cloth.size();
  ASSERT_EQ(m.meshes.size(), 2u);  // the panel and the sphere
  ASSERT_EQ(m.nodes.size(), 2u);
  EXPECT_EQ(m.nodes[0].name, "cloth");
  EXPECT_EQ(m.nodes[1].name, "sphere");
  const tinygltf::Primitive& prim = m.meshes[0].primitives.at(0);
  EXPECT_EQ(m.accessors[size_t(prim.attributes.at("POSITION"))].count, 30u);
  EXPECT_EQ(m.accessors[size_t(prim.attributes.at("NORMAL"))].count, 30u);
  EXPECT_EQ(m.accessors[size_t(prim.indices)].count, 40u * 3);
  ASSERT_EQ(prim.targets.size(), frames);
  EXPECT_EQ(m.meshes[1].primitives.at(0).targets.size(), 0u);
  EXPECT_EQ(m.accessors[size_t(m.meshes[1].primitives[0].attributes.at("POSITION"))].count, 578u);

  // One animation: a weights channel for the panel, keyed at the frame times.
  ASSERT_EQ(m.animations.size(), 1u);
  const tinygltf::Animation& anim = m.animations[0];
  ASSERT_EQ(anim.channels.size(), 1u);
  EXPECT_EQ(anim.channels[0].target_path, "weights");
  EXPECT_EQ(anim.channels[0].target_node, 0);
  const tinygltf::AnimationSampler& sampler = anim.samplers[size_t(anim.channels[0].sampler)];
  const std::vector<float> times = accessor_floats(m, sampler.input);
  ASSERT_EQ(times.size(), frames);
  for (size_t k = 0; k < frames; ++k) EXPECT_NEAR(times[k], rec->times[k], 1e-6);
  const std::vector<float> weights = accessor_floats(m, sampler.output);
  ASSERT_EQ(weights.size(), frames * frames);
  for (size_t k = 0; k < frames; ++k) EXPECT_EQ(weights[(frames - 1) * frames + k], k + 1 == frames ? 1.0f : 0.0f);

  const std::vector<float> base = accessor_floats(m, prim.attributes.at("POSITION"));
  const std::vector<float> last = accessor_floats(m, prim.targets.back().at("POSITION"));
  ASSERT_EQ(base.size(), 90u);
  ASSERT_EQ(last.size(), 90u);
  for (size_t i = 0; i < 30; ++i) {
    EXPECT_NEAR(base[3 * i] + last[3 * i], rec->cloth.back()[i].x, 1e-5);
    EXPECT_NEAR(base[3 * i + 1] + last[3 * i + 1], rec->cloth.back()[i].y, 1e-5);
    EXPECT_NEAR(base[3 * i + 2] + last[3 * i + 2], rec->cloth.back()[i].z, 1e-5);
  }
  EXPECT_GT(std::abs(last[1]), 0.01f);  // the panel did fall
}

TEST(Export, GlbMovingObstacleKeysPutItWhereTheSimulatorHadIt) {
  SceneDef s = falling_panel();
  ObstacleDef box = test::box_obstacle({0.3f, 0.1f, 0.2f}, {0.1f, -0.4f, 0.05f});
  box.transform.rotation = {10, 20, 30};
  box.transform.scale = {1.0f, 2.0f, 1.5f};
  box.motion = MotionDef{{0.2f, 0.1f, -0.1f}, {40, -25, 60}, 0.05};
  s.obstacles.push_back(box);
  const fs::path out = fresh_dir("glb_moving");
  const auto rec = run_with(s, out, {"glb"});
  tinygltf::TinyGLTF loader;
  tinygltf::Model m;
  std::string err, warn;
  ASSERT_TRUE(loader.LoadBinaryFromFile(&m, &err, &warn, (out / "cloth.glb").string())) << err;
  ASSERT_EQ(m.nodes.size(), 3u);
  const int node = 2;
  EXPECT_EQ(m.nodes[node].name, "box");
  const std::vector<float> local = accessor_floats(m, m.meshes[size_t(m.nodes[node].mesh)].primitives[0].attributes.at("POSITION"));
  std::vector<float> translation, rotation;
  for (const auto& c : m.animations.at(0).channels) {
    if (c.target_node != node) continue;
    const auto& smp = m.animations[0].samplers[size_t(c.sampler)];
    (c.target_path == "translation" ? translation : rotation) = accessor_floats(m, smp.output);
  }
  const size_t frames = rec->cloth.size();
  ASSERT_EQ(translation.size(), 3 * frames);
  ASSERT_EQ(rotation.size(), 4 * frames);
  const std::vector<double>& scale = m.nodes[node].scale;
  ASSERT_EQ(scale.size(), 3u);
  const uint32_t first = 578;  // after the sphere's vertices
  for (size_t k : {size_t(0), frames - 1}) {
    const std::vector<float> q(rotation.begin() + 4 * k, rotation.begin() + 4 * k + 4);
    for (size_t i = 0; i < local.size() / 3; ++i) {
      const Vec3 p = rotate(q, make_vec3(local[3 * i] * float(scale[0]), local[3 * i + 1] * float(scale[1]),
                                         local[3 * i + 2] * float(scale[2]))) +
                     make_vec3(translation[3 * k], translation[3 * k + 1], translation[3 * k + 2]);
      const Vec3 want = rec->obstacles[k][first + i];
      EXPECT_NEAR(p.x, want.x, 1e-5) << "frame " << k << " vertex " << i;
      EXPECT_NEAR(p.y, want.y, 1e-5) << "frame " << k << " vertex " << i;
      EXPECT_NEAR(p.z, want.z, 1e-5) << "frame " << k << " vertex " << i;
    }
  }
}

TEST(Export, GlbSkinnedBodyIsPosedInEveryFrame) {
  const SceneDef s = test::panel_beside_an_arm(fresh_dir("glb_skinned_gltf"), "glb_skinned");
  const fs::path out = fresh_dir("glb_skinned");
  const auto rec = run_with(s, out, {"glb"});
  tinygltf::TinyGLTF loader;
  tinygltf::Model m;
  std::string err, warn;
  ASSERT_TRUE(loader.LoadBinaryFromFile(&m, &err, &warn, (out / "cloth.glb").string())) << err;
  ASSERT_EQ(m.nodes.size(), 2u);
  const int node = 1;
  EXPECT_EQ(m.nodes[node].name, "arm");
  EXPECT_TRUE(m.nodes[node].translation.empty() && m.nodes[node].rotation.empty());  // world space
  const tinygltf::Primitive& prim = m.meshes[size_t(m.nodes[node].mesh)].primitives.at(0);
  const size_t frames = rec->times.size();
  ASSERT_EQ(frames, 8u);
  ASSERT_EQ(prim.targets.size(), frames);
  // The arm's node is keyed by the cloth's weights animation: key k selects target k.
  const tinygltf::AnimationChannel* weights = nullptr;
  for (const auto& c : m.animations.at(0).channels)
    if (c.target_node == node) weights = &c;
  ASSERT_NE(weights, nullptr);
  EXPECT_EQ(weights->target_path, "weights");
  EXPECT_EQ(m.animations[0].samplers[size_t(weights->sampler)].output,
            m.animations[0].samplers[size_t(m.animations[0].channels[0].sampler)].output);
  // Frame k's vertices (base + target k) are the body posed at frame k's time.
  const ObstacleSet set = build_obstacles(s);
  const std::vector<float> base = accessor_floats(m, prim.attributes.at("POSITION"));
  ASSERT_EQ(base.size(), 3 * set.world.vertices.size());
  float moved = 0;
  for (size_t k = 0; k < frames; ++k) {
    std::vector<Vec3> x, v;
    set.pose_at(rec->times[k], x, v);
    const std::vector<float> d = accessor_floats(m, prim.targets[k].at("POSITION"));
    for (size_t i = 0; i < x.size(); ++i) {
      const Vec3 p = make_vec3(base[3 * i] + d[3 * i], base[3 * i + 1] + d[3 * i + 1], base[3 * i + 2] + d[3 * i + 2]);
      ASSERT_LT(length(p - x[i]), 1e-5f) << "frame " << k << " vertex " << i;
      moved = std::max(moved, length(p - make_vec3(base[3 * i], base[3 * i + 1], base[3 * i + 2])));
    }
  }
  EXPECT_GT(moved, 0.3f);  // the arm swung
}

TEST(Export, QuaternionRotatesLikeTheTransformMatrix) {
  for (const Float3& deg : {Float3{0, 0, 0}, Float3{90, 0, 0}, Float3{10, 20, 30}, Float3{-120, 75, 200}}) {
    const auto qd = rotation_quaternion_xyz_degrees(deg);
    const std::vector<float> q{float(qd[0]), float(qd[1]), float(qd[2]), float(qd[3])};
    const Mat3 r = rotation_xyz_degrees(deg);
    for (const Vec3& v : {make_vec3(1, 0, 0), make_vec3(0, 1, 0), make_vec3(0.3f, -0.7f, 0.5f)}) {
      const Vec3 a = rotate(q, v), b = mul(r, v);
      EXPECT_NEAR(a.x, b.x, 1e-6f);
      EXPECT_NEAR(a.y, b.y, 1e-6f);
      EXPECT_NEAR(a.z, b.z, 1e-6f);
    }
  }
}

TEST(Export, FormatsComeFromTheSceneUnlessOverridden) {
  SceneDef s = falling_panel();
  s.time.duration = 0.05;
  s.output.formats = {"ply", "pc2"};
  const fs::path out = fresh_dir("scene_formats");
  RunOptions opt;
  opt.out_dir = out;
  opt.quiet = true;
  run_scene(s, opt);
  EXPECT_TRUE(fs::exists(out / "frames" / "cloth_0000.ply"));
  EXPECT_TRUE(fs::exists(out / "cloth.pc2"));
  EXPECT_FALSE(fs::exists(out / "frames" / "cloth_0000.obj"));
  EXPECT_FALSE(fs::exists(out / "cloth.glb"));
  std::ifstream in(out / "run.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["outputs"], (nlohmann::json{"frames/cloth_*.ply", "cloth.pc2", "cloth_rest.obj", "obstacles.obj",
                                          "run.json", "timing.json", "summary.png"}));

  const fs::path out2 = fresh_dir("option_formats");
  opt.out_dir = out2;
  opt.formats = std::vector<std::string>{"obj"};
  run_scene(s, opt);
  EXPECT_TRUE(fs::exists(out2 / "frames" / "cloth_0000.obj"));
  EXPECT_FALSE(fs::exists(out2 / "cloth.pc2"));

  opt.formats = std::vector<std::string>{"obj", "fbx"};
  opt.out_dir = fresh_dir("bad_formats");
  try {
    run_scene(s, opt);
    FAIL() << "fbx accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "/output/formats/1");
  }
  EXPECT_FALSE(fs::exists(opt.out_dir));
}

// A blow-up: the point cache and the glTF file still hold the frames written so far.
TEST(Export, BlowUpLeavesWholeFilesWithTheFramesSoFar) {
  SceneDef s = test::panel_scene(10, 0.27f, 0.0f);
  s.panels[0].transform.scale = {1.5f, 1, 1};  // start stretched
  s.time.dt = 0.03;                           // far past T0
  // A pinned corner deforms the panel, so the unstable step has something to amplify (a panel in
  // free fall stays undeformed: the displacement bound scales every vertex's move alike).
  s.pins.push_back({.panel = "cloth", .corner = "top_left"});
  s.time.duration = 60;
  s.time.fps = 10;  // a frame every 3 or 4 steps
  const fs::path out = fresh_dir("blowup");
  auto rec = std::make_shared<Recorder>();
  RunOptions opt;
  opt.out_dir = out;
  opt.quiet = true;
  opt.sim.allow_unstable_dt = true;
  opt.formats = std::vector<std::string>{"pc2", "glb"};
  opt.sinks.push_back(rec);
  EXPECT_THROW(run_scene(s, opt), SimulationError);
  const size_t frames = rec->cloth.size();
  ASSERT_GE(frames, 2u);
  const std::string b = read_all(out / "cloth.pc2");
  ASSERT_GE(b.size(), 32u);
  EXPECT_EQ(read_at<int32_t>(b, 28), int32_t(frames));
  EXPECT_EQ(b.size(), 32u + frames * 100 * 12);
  tinygltf::TinyGLTF loader;
  tinygltf::Model m;
  std::string err, warn;
  ASSERT_TRUE(loader.LoadBinaryFromFile(&m, &err, &warn, (out / "cloth.glb").string())) << err;
  EXPECT_EQ(m.meshes.at(0).primitives.at(0).targets.size(), frames);
  EXPECT_TRUE(fs::exists(out / "summary.png"));
  std::ifstream in(out / "run.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_NE(j["error"].get<std::string>().find("blew up"), std::string::npos);
  EXPECT_EQ(j["frames"].size(), frames);
}

TEST(Summary, PngIsWrittenWithThePlotsOfTheRun) {
  const fs::path out = fresh_dir("summary");
  run_with(falling_panel(), out, {});
  int w = 0, h = 0, c = 0;
  unsigned char* px = stbi_load((out / "summary.png").string().c_str(), &w, &h, &c, 3);
  ASSERT_NE(px, nullptr) << stbi_failure_reason();
  EXPECT_EQ(w, 960);
  EXPECT_EQ(h, 834);
  std::set<uint32_t> colours;
  for (int i = 0; i < w * h; ++i) colours.insert(uint32_t(px[3 * i]) << 16 | uint32_t(px[3 * i + 1]) << 8 | px[3 * i + 2]);
  stbi_image_free(px);
  EXPECT_GE(colours.size(), 5u);  // background, ink, grid and the three series
  EXPECT_TRUE(fs::exists(out / "run.json"));
  EXPECT_FALSE(fs::exists(out / "frames" / "cloth_0000.obj"));  // no mesh format asked for
}

// Rows in which `colour` appears in column x of the data area.
std::vector<int> rows_with(const RgbImage& img, const PlotArea& a, int x, Rgb colour) {
  std::vector<int> rows;
  for (int y = a.top + 1; y < a.bottom; ++y)
    if (img.at(x, y) == colour) rows.push_back(y);
  return rows;
}

TEST(Summary, PlotDrawsItsSeriesInTheExpectedRows) {
  RgbImage img(400, 300, Rgb{255, 255, 255});
  PlotSeries line;
  line.color = Rgb{0, 0, 255};
  for (int i = 0; i <= 10; ++i) line.x.push_back(i), line.y.push_back(i);
  const PlotArea a = draw_plot(img, 0, 0, 400, 300, "y = x", line, PlotAxis{0, 10, false}, PlotAxis{0, 10, false});
  ASSERT_LT(a.left, a.right);
  ASSERT_LT(a.top, a.bottom);
  // y = x runs from the bottom-left corner of the data area to its top-right corner.
  for (double xv : {2.5, 5.0, 7.5}) {
    const int col = a.left + int(std::lround(xv / 10 * (a.right - a.left)));
    const double want = a.bottom - xv / 10 * (a.bottom - a.top);
    const std::vector<int> rows = rows_with(img, a, col, line.color);
    ASSERT_FALSE(rows.empty()) << xv;
    // A 2-pixel brush on a slope of about one row per column.
    double mean = 0;
    for (int r : rows) {
      mean += r;
      EXPECT_NEAR(r, want, 3.0) << "x = " << xv;
    }
    EXPECT_NEAR(mean / double(rows.size()), want, 1.0) << "x = " << xv;
  }

  // A constant 100 on a log axis from 1 to 10^4 sits half-way up.
  RgbImage log_img(400, 300, Rgb{255, 255, 255});
  PlotSeries flat;
  flat.color = Rgb{200, 0, 0};
  flat.x = {0, 1};
  flat.y = {100, 100};
  const PlotArea b = draw_plot(log_img, 0, 0, 400, 300, "log", flat, PlotAxis{0, 1, false}, PlotAxis{1, 1e4, true});
  const double middle = (b.top + b.bottom) / 2.0;
  for (int col = b.left + 5; col < b.right - 5; col += 37) {
    const std::vector<int> rows = rows_with(log_img, b, col, flat.color);
    ASSERT_FALSE(rows.empty()) << col;
    for (int r : rows) EXPECT_NEAR(r, middle, 1.5) << "column " << col;
  }
}

TEST(Summary, NiceAxesEndOnRoundNumbers) {
  const PlotAxis lin = nice_axis(0, 1730, false);
  EXPECT_EQ(lin.lo, 0);
  EXPECT_EQ(lin.hi, 2000);
  const PlotAxis log = nice_axis(3e-4, 2.5, true);
  EXPECT_DOUBLE_EQ(log.lo, 1e-4);
  EXPECT_DOUBLE_EQ(log.hi, 10);
}

// A run checks each frame beside the steps of the next (a thread of its own), unless a caller is
// shown every frame (on_frame), which then checks it before the call. Both report the same on the
// squeeze (a press box squeezing cloth into a table box), which fails some frames.
TEST(Export, FramesCheckedBesideTheStepsReportWhatFramesCheckedInTurnDo) {
  const SceneDef s = parse_scene(test::kSqueezeSceneJson, "<squeeze>");
  RunOptions opt;
  opt.quiet = true;
  opt.out_dir = fresh_dir("check_beside");
  const RunReport beside = run_scene(s, opt);
  std::vector<long> shown;
  opt.out_dir = fresh_dir("check_in_turn");
  opt.on_frame = [&](Simulator&, const FrameRecord& f) { shown.push_back(f.vertices_inside); };
  const RunReport in_turn = run_scene(s, opt);
  ASSERT_EQ(beside.frames.size(), in_turn.frames.size());
  ASSERT_EQ(shown.size(), in_turn.frames.size());
  for (size_t k = 0; k < beside.frames.size(); ++k) {
    EXPECT_EQ(beside.frames[k].crossings, in_turn.frames[k].crossings) << "frame " << k;
    EXPECT_EQ(beside.frames[k].vertices_inside, in_turn.frames[k].vertices_inside) << "frame " << k;
    EXPECT_EQ(beside.frames[k].pinched, in_turn.frames[k].pinched) << "frame " << k;
    EXPECT_EQ(shown[k], in_turn.frames[k].vertices_inside) << "frame " << k;  // the caller saw it checked
    EXPECT_GE(beside.frames[k].crossings, 0) << "frame " << k;
  }
  EXPECT_EQ(beside.check.frames_checked, beside.frames.size());
  EXPECT_GT(beside.check.bad_frames, 0u);
  EXPECT_EQ(beside.check.bad_frames, in_turn.check.bad_frames);
  EXPECT_EQ(beside.check.first_bad_frame, in_turn.check.first_bad_frame);
  EXPECT_EQ(beside.check.first_problem, in_turn.check.first_problem);
  EXPECT_EQ(beside.check.max_vertices_inside, in_turn.check.max_vertices_inside);
}

}  // namespace
}  // namespace raycloth
