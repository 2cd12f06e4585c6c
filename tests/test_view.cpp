// `raycloth view DIR` (io/viewer.h): the page it writes is self-contained and carries the run; bad
// folders get their messages; and in a real browser (headless Chromium, skipped where there is none)
// the page draws the cloth, two frames differ, and nothing on it failed.
#include <gtest/gtest.h>
#include <stb/stb_image.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

struct Result {
  int code;
  std::string out, err;
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

Result sh(const std::string& cmd, const fs::path& dir) {
  fs::create_directories(dir);
  const int status = std::system((cmd + " > " + (dir / "stdout.txt").string() + " 2> " + (dir / "stderr.txt").string()).c_str());
  return {WEXITSTATUS(status), slurp(dir / "stdout.txt"), slurp(dir / "stderr.txt")};
}

fs::path fresh(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("raycloth_view_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

const std::string cli = RAYCLOTH_CLI;
const std::string source = RAYCLOTH_SOURCE_DIR;

// A short run of a scene into dir/out, then its page.
fs::path run_and_view(const std::string& scene, double duration, const fs::path& dir) {
  const fs::path out = dir / "out";
  const Result r = sh(cli + " run " + scene + " --quiet --duration " + std::to_string(duration) + " --out " + out.string(), dir);
  EXPECT_EQ(r.code, 0) << r.err;
  const Result v = sh(cli + " view " + out.string(), dir);
  EXPECT_EQ(v.code, 0) << v.err;
  EXPECT_NE(v.out.find("view.html"), std::string::npos) << v.out;
  return out / "view.html";
}

TEST(View, PageCarriesTheRunAndFetchesNothing) {
  const fs::path dir = fresh("page");
  const fs::path page = run_and_view(source + "/scenes/moving_sphere.json", 0.1, dir);
  const std::string html = slurp(page);
  ASSERT_FALSE(html.empty());
  EXPECT_FALSE(fs::exists(page.string() + ".tmp"));
  // No resource from a network: no script, link, image or module import by URL.
  EXPECT_FALSE(std::regex_search(html, std::regex(R"((src|href)\s*=\s*["']?(https?:)?//)"))) << "a resource by URL";
  EXPECT_FALSE(std::regex_search(html, std::regex(R"((from|import)\s*\(?\s*["'](https?:)?//)"))) << "a module by URL";
  // The embedded run: as many frames as the folder has, and the exact check of each.
  const size_t a = html.find("<script type=\"application/json\" id=\"run-data\">");
  ASSERT_NE(a, std::string::npos);
  const size_t b = html.find("</script>", a);
  const std::string text = html.substr(a + 46, b - a - 46);
  const nlohmann::json data = nlohmann::json::parse(text);
  size_t frames = 0;
  for (const auto& e : fs::directory_iterator(page.parent_path() / "frames"))
    frames += e.path().filename().string().rfind("cloth_", 0) == 0;
  EXPECT_EQ(data["cloth"]["frames"].size(), frames);
  EXPECT_EQ(data["check"]["frames"].size(), frames);
  EXPECT_EQ(data["check"]["summary"], "clean on all " + std::to_string(frames) + " frames");
  EXPECT_TRUE(data.contains("obstacles"));
  EXPECT_GT(data["figures"]["steps_per_second"].get<double>(), 0.0);
}

TEST(View, BadFoldersAreRefusedWithTheReason) {
  const fs::path dir = fresh("bad");
  Result r = sh(cli + " view " + (dir / "none").string(), dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: " + (dir / "none").string() + ": is not a folder (an output folder of `raycloth run`)\n");
  fs::create_directories(dir / "empty");
  r = sh(cli + " view " + (dir / "empty").string(), dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: " + (dir / "empty").string() +
                       ": frames: no frames/cloth_NNNN.obj: `raycloth view` plays the OBJ frames of `raycloth run` (its "
                       "default output, --format obj)\n");
  EXPECT_FALSE(fs::exists(dir / "empty" / "view.html"));
  // A frame missing in the middle.
  fs::create_directories(dir / "gap" / "frames");
  std::ofstream(dir / "gap" / "frames" / "cloth_0000.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  std::ofstream(dir / "gap" / "frames" / "cloth_0002.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  r = sh(cli + " view --no-check " + (dir / "gap").string(), dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: " + (dir / "gap" / "frames").string() + ": frame 0001 is missing (frames must run from 0000 on)\n");
}

// ---- In a browser -------------------------------------------------------------------------------

const char* kChromium = "/usr/bin/chromium";

struct Shot {
  int w = 0, h = 0;
  std::vector<unsigned char> rgb;
};

// Headless Chromium, WebGL 2 on SwiftShader, the page paused at `frame`.
Shot screenshot(const fs::path& page, int frame, const fs::path& png) {
  const std::string flags =
      "--headless --no-sandbox --use-angle=swiftshader --enable-unsafe-swiftshader --window-size=640,480 "
      "--virtual-time-budget=10000 ";
  const Result r = sh(std::string(kChromium) + " " + flags + "--screenshot=" + png.string() + " 'file://" +
                          page.string() + "#frame=" + std::to_string(frame) + "'",
                      png.parent_path());
  EXPECT_EQ(r.code, 0) << r.err;
  Shot s;
  int n = 0;
  unsigned char* px = stbi_load(png.string().c_str(), &s.w, &s.h, &n, 3);
  EXPECT_NE(px, nullptr) << png;
  if (px) s.rgb.assign(px, px + size_t(s.w) * size_t(s.h) * 3), stbi_image_free(px);
  return s;
}

// The page's own report: its status box after loading ("ok", or "error: ..." for any error).
std::string page_status(const fs::path& page, const fs::path& dir) {
  const Result r = sh(std::string(kChromium) +
                          " --headless --no-sandbox --use-angle=swiftshader --enable-unsafe-swiftshader "
                          "--virtual-time-budget=10000 --dump-dom 'file://" + page.string() + "#frame=1'",
                      dir);
  std::smatch m;
  if (std::regex_search(r.out, m, std::regex(R"(<div id="status">([^<]*)</div>)"))) return m[1].str();
  return "no status in the page: " + r.out.substr(0, 200);
}

// Pixels of the cloth's colour (blue, #3b7dd8 lit) in the middle half of the picture.
size_t cloth_pixels(const Shot& s) {
  size_t count = 0;
  for (int y = s.h / 4; y < 3 * s.h / 4; ++y)
    for (int x = s.w / 4; x < 3 * s.w / 4; ++x) {
      const unsigned char* p = &s.rgb[3 * (size_t(y) * size_t(s.w) + size_t(x))];
      if (p[2] > p[0] + 60 && p[2] > p[1] + 20) ++count;
    }
  return count;
}

size_t differing(const Shot& a, const Shot& b) {
  size_t count = 0;
  for (size_t i = 0; i + 2 < std::min(a.rgb.size(), b.rgb.size()); i += 3)
    if (std::abs(int(a.rgb[i]) - int(b.rgb[i])) + std::abs(int(a.rgb[i + 1]) - int(b.rgb[i + 1])) +
            std::abs(int(a.rgb[i + 2]) - int(b.rgb[i + 2])) > 30)
      ++count;
  return count;
}

void browser_test(const std::string& scene, double duration, const std::string& name) {
  if (!fs::exists(kChromium)) GTEST_SKIP() << "no " << kChromium << " (Debian package chromium): the page is not opened";
  const fs::path dir = fresh(name);
  const fs::path page = run_and_view(scene, duration, dir);
  EXPECT_EQ(page_status(page, dir), "ok");
  int last = -1;
  for (const auto& e : fs::directory_iterator(page.parent_path() / "frames"))
    last += e.path().filename().string().rfind("cloth_", 0) == 0;
  const Shot first = screenshot(page, 0, dir / "first.png");
  const Shot end = screenshot(page, last, dir / "last.png");
  ASSERT_EQ(first.w, 640);
  ASSERT_EQ(first.h, 480);
  const size_t area = size_t(first.w / 2) * size_t(first.h / 2);
  EXPECT_GT(cloth_pixels(first), area / 50) << "the cloth is not drawn in frame 0";
  EXPECT_GT(cloth_pixels(end), area / 50) << "the cloth is not drawn in frame " << last;
  EXPECT_GT(differing(first, end), area / 100) << "frames 0 and " << last << " look the same";
}

TEST(ViewBrowser, DefaultSceneIsDrawnAndPlays) { browser_test("", 0.2, "browser_default"); }

TEST(ViewBrowser, WalkingSkirtIsDrawnAndPlays) {
  browser_test(source + "/scenes/walking_skirt.json", 0.2, "browser_skirt");
}

}  // namespace
