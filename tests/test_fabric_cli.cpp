// `raycloth fabric-test` end to end: a cantilever and a pull from the command line, their files, and
// bad input with its exit code and message.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

namespace fs = std::filesystem;

namespace {

struct Result {
  int code;
  std::string err, out;
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

Result fabric_cli(const std::string& args, const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("raycloth_fabric_cli_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string cmd = std::string(RAYCLOTH_CLI) + " fabric-test " + args + " > " + (dir / "stdout.txt").string() +
                          " 2> " + (dir / "stderr.txt").string();
  const int status = std::system(cmd.c_str());
  return {WEXITSTATUS(status), slurp(dir / "stderr.txt"), slurp(dir / "stdout.txt")};
}

}  // namespace

TEST(FabricCli, CantileverAndTensileWriteTheirResults) {
  const fs::path out = fs::temp_directory_path() / "raycloth_fabric_cli_out";
  fs::remove_all(out);
  Result r = fabric_cli("cantilever --fabric denim -q --out " + (out / "c").string(), "cantilever");
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(slurp(out / "c" / "result.json"));
  EXPECT_EQ(j["test"], "cantilever");
  EXPECT_EQ(j["fabric"], "denim");
  EXPECT_NEAR(j["bending_length_cm"].get<double>() / j["predicted_bending_length_cm"].get<double>(), 1.0, 0.03);
  EXPECT_NE(r.out.find("denim: bending length c = "), std::string::npos) << r.out;
  r = fabric_cli("tensile --fabric denim -q --settle 0.2 --out " + (out / "t").string(), "tensile");
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string csv = slurp(out / "t" / "tensile.csv");
  EXPECT_EQ(csv.rfind("strain,stress_N_per_m,stress_gf_per_cm\n", 0), 0u) << csv;
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 6);
}

TEST(FabricCli, BadFabricsAndMeasurementsExitWithStatus2) {
  Result r = fabric_cli("cantilever --fabric velvet", "velvet");
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err,
            "raycloth: error: command line: --fabric: unknown fabric 'velvet' (expected a KES-F preset, cotton_shirting, "
            "wool_suiting, polyester_plain, silk_crepe, denim, cotton_jersey or linen_plain, or a measured fabric, "
            "ivory_rib_knit, pink_ribbon_brown, white_dots_on_blk, navy_sparkle_sweat, camel_ponte_roma, gray_interlock, "
            "denim_11oz, white_swim_solid, tango_red_jet_set or royal_target)\n");
  r = fabric_cli("drape --fabric denim --kes 40,-1,3,4", "kes");
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: command line: --kes: B: must be a positive measurement (got -1)\n");
}
