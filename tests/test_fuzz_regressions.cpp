// Inputs that crashed, hung or ran a reader out of memory (found by the fuzzers in fuzz/ or while
// hardening the readers against them), each kept in tests/data/fuzz/ or built here, and the
// message each must end in now: "FILE: FIELD: REASON", nothing else.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "raycloth/error.h"
#include "raycloth/scene.h"
#include "scene/mesh.h"
#include "scene/skinned_mesh.h"

namespace raycloth {
namespace {

namespace fs = std::filesystem;
const std::string kData = std::string(RAYCLOTH_SOURCE_DIR) + "/tests/data/fuzz/";

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

// Loads a glTF body as a scene's obstacle does and poses it once mid-animation.
std::string gltf_message(const std::string& path) {
  return message_of([&] {
    const SkinnedMesh m = load_skinned_mesh(path, "", [](const std::string& field, const std::string& reason) {
      throw InputError("scene.json", "/obstacles/0/" + field, reason);
    });
    std::vector<Vec3> posed;
    m.skin(m.joint_matrices(m.sample(0.5f * (m.start + m.end), 1.0f)), posed);
  });
}

struct GltfCase {
  const char* file;
  const char* reason;
};

class FuzzGltf : public ::testing::TestWithParam<GltfCase> {};

TEST_P(FuzzGltf, EndsInItsMessage) {
  const std::string path = kData + GetParam().file;
  EXPECT_EQ(gltf_message(path), "scene.json: /obstacles/0/file: glTF file '" + path + "'" + GetParam().reason);
}

INSTANTIATE_TEST_SUITE_P(
    Inputs, FuzzGltf,
    ::testing::Values(
        // Found by fuzz_gltf: a buffer view naming buffer 1 of 1 was read past the buffer list.
        GltfCase{"gltf_bad_buffer_view.gltf", " animation 'wave' key values: no such buffer"},
        // An accessor count of 2^62: the bounds check overflowed, then std::vector's own message.
        GltfCase{"gltf_huge_accessor_count.gltf", " mesh 'tri' POSITION: accessor runs past the end of its buffer"},
        GltfCase{"gltf_huge_byte_offset.gltf", " mesh 'tri' POSITION: accessor starts past the end of its buffer"},
        // Read past the mesh list / the sampler list.
        GltfCase{"gltf_no_such_mesh.gltf", ": node 'body' has no mesh 5"},
        GltfCase{"gltf_no_such_sampler.gltf", " animation 'wave': a channel has no sampler"},
        // A cycle of parents recursed until the stack overflowed when the body was posed.
        GltfCase{"gltf_node_cycle.gltf", ": node 0 is its own ancestor"},
        GltfCase{"gltf_bad_child.gltf", ": node 1 has a child 9 that is not a node"},
        GltfCase{"gltf_two_parents.gltf", ": node 1 is the child of more than one node"},
        // Float joints and indices of 1e30 were converted to size_t: undefined behaviour.
        GltfCase{"gltf_huge_joint.gltf", " mesh 'tri': vertex 0 uses joint 1e+30 but the skin has 2 joints (0 to 1)"},
        GltfCase{"gltf_huge_index.gltf", " mesh 'tri': an index is out of range"},
        // A NaN went on into the simulation without a word.
        GltfCase{"gltf_nan_position.gltf", " mesh 'tri' POSITION: a value is not a finite number"},
        // Decreasing key times made the sampler's binary search undefined.
        GltfCase{"gltf_unsorted_key_times.gltf", " animation 'wave': key times are not in increasing order"}),
    [](const ::testing::TestParamInfo<GltfCase>& info) {
      std::string name = fs::path(info.param.file).stem().string();
      for (char& c : name)
        if (c == '.' || c == '-') c = '_';
      return name;
    });

// A chain of 200000 nodes, each the parent of the next, the last the skin's joint: posing it
// recursed once per node and overflowed the stack.
TEST(FuzzGltfDeep, AChainOfManyNodesPosesWithoutRecursion) {
  std::ifstream in(std::string(RAYCLOTH_SOURCE_DIR) + "/fuzz/corpus/gltf/animated.gltf");  // valid: 2 joints, 3 nodes
  nlohmann::json g = nlohmann::json::parse(in);
  const int n = 200000;
  nlohmann::json nodes = nlohmann::json::array();
  for (int i = 0; i < n; ++i) nodes.push_back({{"children", {i + 1}}});
  for (auto node : g["nodes"]) {  // root, tip, body: now n, n + 1, n + 2
    if (node.contains("children"))
      for (auto& c : node["children"]) c = c.get<int>() + n;
    nodes.push_back(node);
  }
  g["nodes"] = nodes;
  g["scenes"][0]["nodes"] = {0, n + 2};
  for (auto& j : g["skins"][0]["joints"]) j = j.get<int>() + n;
  for (auto& c : g["animations"][0]["channels"]) c["target"]["node"] = c["target"]["node"].get<int>() + n;
  const fs::path path = fs::temp_directory_path() / "raycloth_deep_chain.gltf";
  {
    std::ofstream out(path);
    out << g.dump();
  }
  EXPECT_EQ(gltf_message(path.string()), "(no InputError)");
  fs::remove(path);
}

TEST(FuzzGltfFiles, ADeviceIsNotReadAsABody) {
  EXPECT_EQ(gltf_message("/dev/zero"), "scene.json: /obstacles/0/file: glTF file '/dev/zero' is not a regular file");
}

std::string obj_message(const std::string& path) {
  return message_of([&] { load_obj_mesh(path, "scene.json", "/obstacles/0/file"); });
}

// /dev/zero as an OBJ obstacle (or a scene file) was read line by line forever, until memory ran out.
TEST(FuzzObj, ADeviceIsNotReadAsAMesh) {
  EXPECT_EQ(obj_message("/dev/zero"), "scene.json: /obstacles/0/file: OBJ file '/dev/zero' is not a regular file");
}

// `mtllib` made tinyobjloader open any file the OBJ names (materials are never used), a device
// included, and read it forever.
TEST(FuzzObj, MaterialLibrariesAreNotOpened) {
  const fs::path dir = fs::temp_directory_path() / "raycloth_fuzz_mtllib";
  fs::create_directories(dir);
  const fs::path obj = dir / "mesh.obj";
  {
    std::ofstream out(obj);
    out << "mtllib " << fs::relative("/dev/zero", dir).string() << "\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl x\nf 1 2 3\n";
  }
  EXPECT_EQ(obj_message(obj.string()), "(no InputError)");
  const TriMesh m = load_obj_mesh(obj.string(), "scene.json", "/obstacles/0/file");
  EXPECT_EQ(m.num_triangles(), 1u);
  fs::remove_all(dir);
}

// Found by fuzz_obj: a `vw` (skin weight) line with a joint number past INT_MAX, converted to int
// inside tinyobjloader (undefined behaviour, reported by the instrumented fuzz build; the input is in
// fuzz/corpus/obj/ too, so that every fuzz run replays it). Those lines are now left unread.
TEST(FuzzObj, SkinWeightLinesAreNotRead) {
  const std::string path = kData + "obj_vw_huge_joint.obj";
  EXPECT_EQ(obj_message(path), "scene.json: /obstacles/0/file: OBJ file '" + path + "' is malformed: it has no faces");
}

// Found by fuzz_obj (100k executions into the second run): a lone carriage return ends a line for
// tinyobjloader, so "\rvw ..." was a `vw` line that the blanking missed; "\rv nan ..." likewise
// escaped the coordinate check. Lines are now split as tinyobjloader splits them.
TEST(FuzzObj, ACarriageReturnEndsALineAsInTinyobjloader) {
  const std::string vw = kData + "obj_vw_after_cr.obj";
  EXPECT_EQ(obj_message(vw), "scene.json: /obstacles/0/file: OBJ file '" + vw + "' is malformed: it has no faces");
  const std::string nan = kData + "obj_cr_nan.obj";
  EXPECT_EQ(obj_message(nan),
            "scene.json: /obstacles/0/file: OBJ file '" + nan + "' line 3: vertex coordinate 'nan' is not a finite number");
}

// tinyobjloader skips indentation before `v`; the coordinate check did not, and let "nan" through as 0.
TEST(FuzzObj, IndentedVertexLinesAreChecked) {
  const std::string path = kData + "obj_indented_nan.obj";
  EXPECT_EQ(obj_message(path),
            "scene.json: /obstacles/0/file: OBJ file '" + path + "' line 3: vertex coordinate 'nan' is not a finite number");
}

// Found by fuzz_scene (3.9 million executions into its first 30-minute run): a mesh path with a
// component longer than the system allows made std::filesystem::exists throw its own
// filesystem_error out of the reader.
TEST(FuzzScene, AFileNameTooLongIsAnInputError) {
  std::ifstream in(kData + "scene_name_too_long.json");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string found = message_of([&] { parse_scene(text, "fuzz.json"); });
  const std::string suffix = "/walking_man.glb' cannot be read: File name too long";
  EXPECT_EQ(found.rfind("fuzz.json: /obstacles/0/file: glTF file '../assets", 0), 0u) << found;
  EXPECT_TRUE(found.size() > suffix.size() && found.compare(found.size() - suffix.size(), suffix.size(), suffix) == 0) << found;
  const std::string name(300, 'a');
  EXPECT_EQ(message_of([&] {
              parse_scene(R"({"materials": [{"name": "m"}], "panels": [{"name": "a", "material": "m", "size": [1, 1],
                  "resolution": [2, 2]}], "obstacles": [{"type": "mesh", "file": ")" + name + R"(/x.obj"}]})",
                          "fuzz.json");
            }),
            "fuzz.json: /obstacles/0/file: OBJ file '" + name + "/x.obj' cannot be read: File name too long");
  EXPECT_EQ(message_of([&] {
              parse_scene(R"({"materials": [{"name": "m"}], "panels": [{"name": "a", "material": "m", "mesh": ")" + name +
                              R"(/x.obj"}]})",
                          "fuzz.json");
            }),
            "fuzz.json: /panels/0/mesh: OBJ file '" + name + "/x.obj' cannot be read: File name too long");
  EXPECT_EQ(obj_message(name + "/x.obj"),
            "scene.json: /obstacles/0/file: OBJ file '" + name + "/x.obj' cannot be read: File name too long");
  EXPECT_EQ(gltf_message(name + "/x.glb"),
            "scene.json: /obstacles/0/file: glTF file '" + name + "/x.glb' cannot be read: File name too long");
}

TEST(FuzzScene, ADeviceIsNotReadAsAScene) {
  EXPECT_EQ(message_of([] { load_scene_file("/dev/zero"); }), "/dev/zero: cannot open scene file: it is not a regular file");
}

// Scenes that asked for more than memory holds or than any run would finish: refused with a limit.
std::string scene_message(const std::string& panels_and_more) {
  return message_of([&] {
    parse_scene(R"({"materials": [{"name": "m"}], )" + panels_and_more + "}", "big.json");
  });
}

TEST(FuzzScene, HugeRequestsAreRefusedWithALimit) {
  const std::string panel = R"({"name": "a", "material": "m", "size": [1, 1], "resolution": [2048, 2048]})";
  EXPECT_EQ(scene_message(R"("panels": [{"name": "a", "material": "m", "size": [1, 1], "resolution": [100000, 100000]}])"),
            "big.json: /panels/0/resolution: too many vertices (got [100000, 100000], at most 4194304 in all)");
  EXPECT_EQ(scene_message(R"("panels": [)" + panel + R"(, {"name": "b", "material": "m", "size": [1, 1], "resolution": [2, 2]}])"),
            "big.json: /panels/1/resolution: the panels have too many vertices in all (at most 4194304)");
  const std::string one = R"("panels": [{"name": "a", "material": "m", "size": [1, 1], "resolution": [2, 2]}])";
  EXPECT_EQ(scene_message(one + R"(, "obstacles": [{"type": "uv_sphere", "slices": 1000000000, "stacks": 1000}])"),
            "big.json: /obstacles/0/slices: too many vertices: slices x stacks is 1000000000000, at most 4194304");
  EXPECT_EQ(scene_message(one + R"(, "time": {"dt": 1e-300, "duration": 1})"),
            "big.json: /time/dt: the run would take more than 1e12 steps (duration 1 s, dt 1e-300 s)");
  EXPECT_EQ(scene_message(one + R"(, "time": {"duration": 1e300})"),
            "big.json: /time/dt: the run would take more than 1e12 steps (duration 1e+300 s, dt 0.0004 s)");
  EXPECT_EQ(scene_message(one + R"(, "time": {"dt": 1, "duration": 1e9, "fps": 30})"),
            "big.json: /time/fps: the run would write more than 1000000 frames (duration 1e+09 s, fps 30)");
}

}  // namespace
}  // namespace raycloth
