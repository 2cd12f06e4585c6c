// Checkpoints and resume, end to end through the command-line tool: a run killed part-way (SIGKILL)
// and resumed writes the same bytes as an uninterrupted run (every file but the wall-clock ones:
// timing.json and summary.png); checkpoints from another scene, version or run are refused with a
// message; an output folder that cannot be written, or a disk that fills mid-run, ends in a clear
// error with the frames already written whole.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <thread>

#include "io/checkpoint.h"

namespace fs = std::filesystem;

namespace {

const std::string kScene = std::string(RAYCLOTH_SOURCE_DIR) + "/scenes/moving_sphere.json";
// A moving obstacle, cloth against cloth, every mesh format; a checkpoint after every 2nd frame.
const std::string kOutputArgs = " --format obj,ply,pc2,glb --checkpoint-every 2 --quiet";
const std::string kArgs = " --duration 0.4" + kOutputArgs;  // 12 frames: short enough for the sanitizer build

struct Result {
  int code;
  std::string err;
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

Result run_cli(const std::string& args) {
  const fs::path err = fs::temp_directory_path() / ("raycloth_resume_stderr_" + std::to_string(getpid()));
  const std::string cmd = std::string(RAYCLOTH_CLI) + " " + args + " > /dev/null 2> " + err.string();
  const int status = std::system(cmd.c_str());
  Result r{WEXITSTATUS(status), slurp(err)};
  fs::remove(err);
  return r;
}

// Per process: ctest runs the tests of this file in parallel processes.
fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("raycloth_resume_" + name + "_" + std::to_string(getpid()));
  umount(d.c_str());  // a tmpfs left by an earlier failure
  fs::remove_all(d);
  return d;
}

// The uninterrupted run everything is compared with (made once).
const fs::path& reference_run() {
  static const fs::path dir = [] {
    const fs::path d = fresh_dir("reference");
    const Result r = run_cli("run " + kScene + " --out " + d.string() + kArgs);
    EXPECT_EQ(r.code, 0) << r.err;
    return d;
  }();
  return dir;
}

// Starts `raycloth run` in a child, waits for its first checkpoint and then for one more frame,
// and kills it with SIGKILL. Returns true when the child was killed (not finished).
bool run_and_kill(const fs::path& out) {
  const pid_t pid = fork();
  if (pid == 0) {
    std::freopen("/dev/null", "w", stdout);
    std::freopen("/dev/null", "w", stderr);
    execl(RAYCLOTH_CLI, RAYCLOTH_CLI, "run", kScene.c_str(), "--out", out.c_str(), "--duration", "0.4", "--format",
          "obj,ply,pc2,glb", "--checkpoint-every", "2", "--quiet", static_cast<char*>(nullptr));
    _exit(127);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(5);
  while (!fs::exists(out / "frames" / "cloth_0003.obj") && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL;
}

std::set<std::string> files_under(const fs::path& dir) {
  std::set<std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) files.insert(fs::relative(e.path(), dir).string());
  return files;
}

// Every file of `a` and `b` byte for byte, but the wall-clock ones.
void expect_same_outputs(const fs::path& a, const fs::path& b) {
  std::set<std::string> fa = files_under(a), fb = files_under(b);
  EXPECT_EQ(fa, fb);
  for (const std::string& f : fa) {
    if (f == "timing.json" || f == "summary.png" || !fb.count(f)) continue;
    EXPECT_TRUE(slurp(a / f) == slurp(b / f)) << f << " differs";
  }
}

TEST(Resume, AKilledRunResumedWritesTheSameBytes) {
  const fs::path& ref = reference_run();
  const fs::path out = fresh_dir("killed");
  ASSERT_TRUE(run_and_kill(out)) << "the run ended before it could be killed";
  ASSERT_TRUE(fs::exists(out / "checkpoint.bin"));
  EXPECT_FALSE(fs::exists(out / "run.json"));
  const Result r = run_cli("run " + kScene + " --out " + out.string() + kArgs + " --resume");
  ASSERT_EQ(r.code, 0) << r.err;
  expect_same_outputs(ref, out);
  EXPECT_FALSE(fs::exists(out / "checkpoint.bin"));  // the run is complete
}

TEST(Resume, ResumeDirContinuesTheCommandKeptInTheCheckpoint) {
  const fs::path& ref = reference_run();
  const fs::path out = fresh_dir("resume_dir");
  ASSERT_TRUE(run_and_kill(out)) << "the run ended before it could be killed";
  const Result r = run_cli("resume " + out.string() + " --quiet");
  ASSERT_EQ(r.code, 0) << r.err;
  expect_same_outputs(ref, out);
}

// A run whose next frame file cannot be written (frames/cloth_0004.obj.tmp leads to /dev/full):
// it stops with the file and the reason, after its checkpoint at frame 2.
fs::path run_into_full_disk(const std::string& name, Result& r) {
  const fs::path out = fresh_dir(name);
  fs::create_directories(out / "frames");
  fs::create_symlink("/dev/full", out / "frames" / "cloth_0004.obj.tmp");
  r = run_cli("run " + kScene + " --out " + out.string() + kArgs);
  return out;
}

TEST(DiskTrouble, AFullDiskStopsTheRunNamingTheFileAndKeepsTheFramesWhole) {
  const fs::path& ref = reference_run();
  Result r;
  const fs::path out = run_into_full_disk("full", r);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "raycloth: error: " + (out / "frames" / "cloth_0004.obj").string() +
                       ": write failed: No space left on device\n");
  for (int f = 0; f < 4; ++f) {
    const std::string name = "frames/cloth_000" + std::to_string(f) + ".obj";
    EXPECT_TRUE(slurp(out / name) == slurp(ref / name)) << name;
  }
  EXPECT_FALSE(fs::exists(out / "frames" / "cloth_0004.obj"));
  EXPECT_TRUE(fs::exists(out / "checkpoint.bin"));
  // Room again: the run goes on from its checkpoint to the same end.
  fs::remove(out / "frames" / "cloth_0004.obj.tmp");
  const Result resumed = run_cli("run " + kScene + " --out " + out.string() + kArgs + " --resume");
  ASSERT_EQ(resumed.code, 0) << resumed.err;
  expect_same_outputs(ref, out);
}

// A real full file system, where one can be mounted (root, and a system that allows it).
TEST(DiskTrouble, ASmallFileSystemThatFillsUp) {
  const fs::path& ref = reference_run();
  const fs::path mnt = fresh_dir("tmpfs");
  fs::create_directories(mnt);
  if (mount("tmpfs", mnt.c_str(), "tmpfs", 0, "size=2m") != 0) GTEST_SKIP() << "cannot mount a tmpfs here";
  const fs::path out = mnt / "out";
  const Result r = run_cli("run " + kScene + " --out " + out.string() + kArgs);
  EXPECT_EQ(r.code, 1);
  const std::string prefix = "raycloth: error: " + out.string() + "/", suffix = ": write failed: No space left on device\n";
  EXPECT_EQ(r.err.compare(0, prefix.size(), prefix), 0) << r.err;
  EXPECT_TRUE(r.err.size() > suffix.size() && r.err.compare(r.err.size() - suffix.size(), suffix.size(), suffix) == 0) << r.err;
  size_t whole = 0;
  for (const std::string& f : files_under(out)) {
    if (f.rfind("frames/cloth_", 0) != 0 || fs::path(f).extension() == ".tmp") continue;
    EXPECT_TRUE(slurp(out / f) == slurp(ref / f)) << f;
    ++whole;
  }
  EXPECT_GT(whole, 0u);
  umount(mnt.c_str());
}

TEST(DiskTrouble, AnOutputFolderUnderAFileIsRefusedBeforeSimulating) {
  const fs::path dir = fresh_dir("under_file");
  fs::create_directories(dir);
  std::ofstream(dir / "file") << "x";
  const Result r = run_cli("run " + kScene + " --out " + (dir / "file" / "out").string() + kArgs);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: " + (dir / "file" / "out").string() + ": cannot write the output folder: Not a directory\n");
}

TEST(DiskTrouble, AnOutputFolderOnAReadOnlySystemIsRefused) {
  const Result r = run_cli("run " + kScene + " --out /proc/raycloth_out" + kArgs);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: /proc/raycloth_out: cannot write the output folder: No such file or directory\n");
}

// A checkpoint left by a run stopped at frame 4 (full disk), for the refusals below.
fs::path stopped_run(const std::string& name) {
  Result r;
  const fs::path out = run_into_full_disk(name, r);
  EXPECT_EQ(r.code, 1);
  fs::remove(out / "frames" / "cloth_0004.obj.tmp");
  return out;
}

TEST(ResumeRefused, WithoutACheckpoint) {
  const fs::path out = fresh_dir("none");
  fs::create_directories(out);
  const Result r = run_cli("run " + kScene + " --out " + out.string() + kArgs + " --resume");
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: " + (out / "checkpoint.bin").string() +
                       ": no checkpoint to resume from (the run finished, or never wrote one)\n");
  const Result d = run_cli("resume " + out.string());
  EXPECT_EQ(d.code, 2);
  EXPECT_EQ(d.err, r.err);
}

TEST(ResumeRefused, FromAnotherScene) {
  const fs::path out = stopped_run("other_scene");
  const fs::path scene = out.parent_path() / "raycloth_resume_changed.json";
  std::string text = slurp(kScene);
  text.replace(text.find("\"name\": \"moving_sphere\""), 23, "\"name\": \"moving_sphere\" ");
  std::ofstream(scene) << text;  // the same scene but for one space: another file
  const Result r = run_cli("run " + scene.string() + " --out " + out.string() + kArgs + " --resume");
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: " + (out / "checkpoint.bin").string() +
                       ": was written for another scene (the scene file or a mesh it uses has changed); start the run "
                       "again without --resume\n");
}

TEST(ResumeRefused, FromARunWithOtherSettings) {
  const fs::path out = stopped_run("other_settings");
  const Result r = run_cli("run " + kScene + " --out " + out.string() + kOutputArgs + " --duration 0.3 --resume");
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: " + (out / "checkpoint.bin").string() +
                       ": was written by a run with other settings (duration: 0.4 then, 0.3 now); resume with the same "
                       "options, or start again without --resume\n");
}

// Bytes of the checkpoint changed in place: another version, damage, not a checkpoint at all.
TEST(ResumeRefused, FromAnotherVersionOrDamaged) {
  const fs::path out = stopped_run("damaged");
  const fs::path cp = out / "checkpoint.bin";
  const std::string good = slurp(cp);
  auto resume_with = [&](const std::string& bytes) {
    std::ofstream(cp, std::ios::binary | std::ios::trunc) << bytes;
    return run_cli("run " + kScene + " --out " + out.string() + kArgs + " --resume");
  };
  const std::string at = "raycloth: error: " + cp.string() + ": ";
  std::string other = good;
  const std::string version = raycloth::raycloth_version();  // in the header
  const size_t v = other.find(version);
  ASSERT_NE(v, std::string::npos);
  other.replace(v, version.size(), "0.0.9");
  Result r = resume_with(other);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, at + "was written by raycloth 0.0.9, this is raycloth " + version + "; start the run again without --resume\n");
  std::string damaged = good;
  damaged[damaged.size() / 2] ^= 0x40;
  r = resume_with(damaged);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, at + "is truncated or damaged; start the run again without --resume\n");
  r = resume_with(good.substr(0, good.size() / 2));
  EXPECT_EQ(r.err, at + "is truncated or damaged; start the run again without --resume\n");
  r = resume_with("{\"not\": \"a checkpoint\"}");
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, at + "is not a raycloth checkpoint\n");
}

}  // namespace
