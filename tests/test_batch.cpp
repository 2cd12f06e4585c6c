// Sweeps (io/batch.h, `raycloth batch`): expansion, bad sweeps word for word, case selection, and the
// batch folder end to end: reruns skip finished cases, a killed case resumes to the same bytes, two
// processes never run the same case. Scenes: tests/data/batch/ (each case well under a second).
#include <gtest/gtest.h>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <thread>

#include "io/batch.h"
#include "raycloth/error.h"

namespace fs = std::filesystem;
using nlohmann::json;
using nlohmann::ordered_json;
using raycloth::InputError;

extern char** environ;

namespace {

const fs::path kData = fs::path(RAYCLOTH_SOURCE_DIR) / "tests" / "data" / "batch";

fs::path fresh_dir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("raycloth_batch_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void write(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

struct Result {
  int code;
  std::string err;
  std::string out;
};

Result run_cli(const std::string& args, const fs::path& dir, const std::string& tag = "cli") {
  const fs::path err = dir / (tag + ".stderr"), out = dir / (tag + ".stdout");
  const int status = std::system((std::string(RAYCLOTH_CLI) + " " + args + " > " + out.string() + " 2> " + err.string()).c_str());
  return {WEXITSTATUS(status), slurp(err), slurp(out)};
}

pid_t spawn_cli(const std::vector<std::string>& args, const fs::path& log) {
  std::vector<std::string> all = {RAYCLOTH_CLI};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& s : all) argv.push_back(s.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&fa, 1, 2);
  pid_t pid = 0;
  EXPECT_EQ(posix_spawn(&pid, RAYCLOTH_CLI, &fa, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&fa);
  return pid;
}

int wait_exit(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
}

std::vector<json> result_lines(const fs::path& out) {
  std::vector<json> lines;
  std::ifstream in(out / "results.jsonl");
  for (std::string line; std::getline(in, line);) lines.push_back(json::parse(line));
  return lines;
}

std::string message(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

// The sweep `text` next to a copy of the base scene, in its own folder.
std::string sweep_file(const fs::path& dir, const std::string& text) {
  fs::copy_file(kData / "sphere.json", dir / "sphere.json", fs::copy_options::overwrite_existing);
  write(dir / "sweep.json", text);
  return (dir / "sweep.json").string();
}

}  // namespace

TEST(Batch, ExpandsTheCartesianProductLastFieldFastest) {
  const raycloth::Sweep s = raycloth::load_sweep((kData / "sweep.json").string());
  ASSERT_EQ(s.cases(), 6u);
  const double stretch[] = {150, 150, 150, 300, 300, 300};
  const double speed[] = {0.1, 0.2, 0.3, 0.1, 0.2, 0.3};
  for (size_t i = 0; i < 6; ++i) {
    const ordered_json v = raycloth::case_values(s, i);
    ASSERT_EQ(v.size(), 2u);
    EXPECT_EQ(v.begin().key(), "/materials/0/stretch");  // the sweep's order, not sorted
    EXPECT_EQ(v["/materials/0/stretch"].get<double>(), stretch[i]) << i;
    EXPECT_EQ(v["/obstacles/0/motion/velocity"], ordered_json({speed[i], 0, 0})) << i;
    const raycloth::SceneDef scene = raycloth::case_scene(s, i);
    EXPECT_EQ(scene.materials.at(0).stretch, float(stretch[i]));
    EXPECT_EQ(scene.obstacles.at(0).motion->velocity[0], float(speed[i]));
    EXPECT_EQ(scene.time.duration, 0.3);      // from "set"
    EXPECT_EQ(scene.materials.at(0).shear, 40.0f);  // from the base scene
    EXPECT_EQ(scene.source, (kData / "sweep.json").string() + " (case " + std::to_string(i) + ")");
  }
  EXPECT_EQ(raycloth::case_id(4), "00004");
  EXPECT_EQ(raycloth::case_id(123456), "123456");
  const fs::path dir = fresh_dir("list");
  const Result r = run_cli("batch " + (kData / "sweep.json").string() + " --list", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out,
            "00000  /materials/0/stretch=150  /obstacles/0/motion/velocity=[0.1,0,0]\n"
            "00001  /materials/0/stretch=150  /obstacles/0/motion/velocity=[0.2,0,0]\n"
            "00002  /materials/0/stretch=150  /obstacles/0/motion/velocity=[0.3,0,0]\n"
            "00003  /materials/0/stretch=300  /obstacles/0/motion/velocity=[0.1,0,0]\n"
            "00004  /materials/0/stretch=300  /obstacles/0/motion/velocity=[0.2,0,0]\n"
            "00005  /materials/0/stretch=300  /obstacles/0/motion/velocity=[0.3,0,0]\n");
  EXPECT_EQ(run_cli("batch " + (kData / "sweep.json").string() + " --count", dir).out, "6\n");
}

TEST(Batch, BadSweepsAreRefusedWordForWord) {
  const fs::path dir = fresh_dir("bad");
  const std::string f = (dir / "sweep.json").string(), scene = (dir / "sphere.json").string();
  auto load = [&](const std::string& text) {
    return message([&] { raycloth::load_sweep(sweep_file(dir, text)); });
  };
  EXPECT_EQ(message([&] { raycloth::load_sweep((dir / "none.json").string()); }),
            (dir / "none.json").string() + ": cannot open sweep file: No such file or directory");
  EXPECT_EQ(load("[1, 2]"), f + ": must be a JSON object with \"scene\" and \"vary\"");
  EXPECT_EQ(load(R"({"scene": "sphere.json", "vary": {}, "vars": {}})"),
            f + ": /vars: unknown field 'vars' (expected scene, set, vary)");
  EXPECT_EQ(load(R"({"vary": {}})"), f + ": /scene: missing: name the base scene file (relative to the sweep file)");
  EXPECT_EQ(load(R"({"scene": "nowhere.json", "vary": {}})"),
            (dir / "nowhere.json").string() + ": cannot open scene file: No such file or directory");
  EXPECT_EQ(load(R"({"scene": "sphere.json"})"),
            f + ": /vary: missing: name the scene fields to vary and their values");
  EXPECT_EQ(load(R"({"scene": "sphere.json", "vary": {"materials": [1]}})"),
            f + ": /vary/materials: 'materials' is not a scene field: write it as a JSON pointer, such as "
                "\"/materials/0/stretch\"");
  EXPECT_EQ(load(R"({"scene": "sphere.json", "vary": {"/materials/3/stretch": [1]}})"),
            f + ": /vary/~1materials~13~1stretch: the scene " + scene + " has no /materials/3 (/materials is a list of 1)");
  EXPECT_EQ(load(R"({"scene": "sphere.json", "vary": {"/materials/0/weave/warp": [1]}})"),
            f + ": /vary/~1materials~10~1weave~1warp: the scene " + scene + " has no /materials/0/weave");
  EXPECT_EQ(load(R"({"scene": "sphere.json", "vary": {"/time/dt/x": [1]}})"),
            f + ": /vary/~1time~1dt~1x: the scene " + scene + " has no /time/dt/x (/time/dt is a number)");
  EXPECT_EQ(load(R"({"scene": "sphere.json", "vary": {"/gravity": []}})"),
            f + ": /vary/~1gravity: must be a non-empty list of values");
  EXPECT_EQ(load(R"({"scene": "sphere.json", "set": {"/gravity": [0, 0, 0]}, "vary": {"/gravity": [[0, 1, 0]]}})"),
            f + ": /vary/~1gravity: '/gravity' is also in /set: set it or vary it, not both");
  // A value the scene refuses: the case's own error, naming the sweep, the case and the scene field.
  const raycloth::Sweep s = raycloth::load_sweep(sweep_file(dir, R"({"scene": "sphere.json",
      "vary": {"/time/fps": [20, 30], "/materials/0/stretch": [100, -1]}})"));
  EXPECT_EQ(message([&] { raycloth::case_scene(s, 2); }), "(no error)");
  EXPECT_EQ(message([&] { raycloth::case_scene(s, 3); }), f + " (case 3): /materials/0/stretch: must be positive (got -1)");
}

TEST(Batch, SelectsAnIndexAShareOrTheSlurmArrayTask) {
  using raycloth::select_cases;
  std::map<std::string, std::string> env;
  auto getenv_fn = [&](const char* n) -> const char* {
    auto it = env.find(n);
    return it == env.end() ? nullptr : it->second.c_str();
  };
  EXPECT_EQ(select_cases(5, std::nullopt, "", getenv_fn), (std::vector<size_t>{0, 1, 2, 3, 4}));
  EXPECT_EQ(select_cases(5, 3, "", getenv_fn), (std::vector<size_t>{3}));
  EXPECT_EQ(select_cases(10, std::nullopt, "1/4", getenv_fn), (std::vector<size_t>{1, 5, 9}));
  EXPECT_EQ(message([&] { select_cases(5, 5, "", getenv_fn); }), "command line: --index: no case 5: the sweep has 5 cases (0 to 4)");
  EXPECT_EQ(message([&] { select_cases(5, std::nullopt, "4/4", getenv_fn); }),
            "command line: --shard: '4/4' is not a share I/N with 0 <= I < N (such as 0/4)");
  // sbatch --array=1-4 over 10 cases: task 2 is the second share of 4.
  env = {{"SLURM_ARRAY_TASK_ID", "2"}, {"SLURM_ARRAY_TASK_MIN", "1"}, {"SLURM_ARRAY_TASK_COUNT", "4"}};
  EXPECT_EQ(select_cases(10, std::nullopt, "", getenv_fn), (std::vector<size_t>{1, 5, 9}));
  EXPECT_EQ(select_cases(10, 7, "", getenv_fn), (std::vector<size_t>{7}));  // the option wins
  env = {{"SLURM_ARRAY_TASK_ID", "7"}};  // no count: the task is the case
  EXPECT_EQ(select_cases(10, std::nullopt, "", getenv_fn), (std::vector<size_t>{7}));
  env = {{"SLURM_ARRAY_TASK_ID", "x"}};
  EXPECT_EQ(message([&] { select_cases(10, std::nullopt, "", getenv_fn); }),
            "environment: SLURM_ARRAY_TASK_ID: 'x' is not a whole number");
}

TEST(Batch, RerunSkipsFinishedCasesAndTheTableHoldsEveryCase) {
  const fs::path dir = fresh_dir("rerun"), out = dir / "out";
  const std::string sweep = (kData / "sweep.json").string();
  Result r = run_cli("batch " + sweep + " --out " + out.string() + " --index 4", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_EQ(result_lines(out).size(), 1u);
  const auto run_json_time = fs::last_write_time(out / "cases" / "00004" / "run.json");
  r = run_cli("batch " + sweep + " --out " + out.string() + " --table", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("batch: 1 of 6 cases already finished, skipped\n"), std::string::npos) << r.err;
  std::vector<json> lines = result_lines(out);
  ASSERT_EQ(lines.size(), 6u);
  std::set<int> ids;
  for (const json& l : lines) {
    ids.insert(l["case"].get<int>());
    EXPECT_EQ(l["status"], 0) << l.dump();
    EXPECT_EQ(l["clean"], true) << l.dump();
    EXPECT_EQ(l["bad_frames"], 0);
    EXPECT_EQ(l["pinched_frames"], 0);
    EXPECT_EQ(l["frames"], 7);
    EXPECT_EQ(l["steps"], 300);
    EXPECT_EQ(l["error"], "");
    EXPECT_GT(l["steps_per_second"].get<double>(), 0);
  }
  EXPECT_EQ(ids.size(), 6u);
  EXPECT_EQ(fs::last_write_time(out / "cases" / "00004" / "run.json"), run_json_time);
  EXPECT_TRUE(fs::exists(out / "cases" / "00002" / "frames" / "cloth_0006.obj"));
  EXPECT_TRUE(fs::is_empty(out / "claims"));
  // The table: a header and one row per case in case order; the same rows as the process printed.
  const std::string csv = slurp(out / "results.csv");
  EXPECT_EQ(csv, r.out);
  EXPECT_EQ(csv.substr(0, csv.find('\n')),
            "case,/materials/0/stretch,/obstacles/0/motion/velocity,status,clean,frames,bad_frames,max_crossings,"
            "max_vertices_inside,pinched_frames,max_vertices_pinched,steps,steps_per_second,wall_s,error");
  EXPECT_EQ(csv.find("\n00003,300,\"[0.1,0,0]\",0,true,7,0,0,0,0,0,300,") != std::string::npos, true) << csv;
  // Everything finished: a rerun runs nothing and appends nothing.
  r = run_cli("batch " + sweep + " --out " + out.string() + " --jobs 2", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("batch: 6 of 6 cases already finished, skipped\n"), std::string::npos) << r.err;
  EXPECT_EQ(result_lines(out).size(), 6u);
  // Another sweep in the same folder is refused.
  write(dir / "other.json", R"({"scene": ")" + (kData / "sphere.json").string() + R"(", "vary": {"/time/fps": [10]}})");
  r = run_cli("batch " + (dir / "other.json").string() + " --out " + out.string(), dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "raycloth: error: " + out.string() + ": holds the cases of another sweep (" +
                       fs::absolute(sweep).string() + ", or it changed since); use another --out\n");
}

TEST(Batch, ACaseTheSceneRefusesIsRecordedAndTheOthersRun) {
  const fs::path dir = fresh_dir("refused"), out = dir / "out";
  const std::string f = sweep_file(dir, R"({"scene": "sphere.json", "set": {"/time/duration": 0.1},
      "vary": {"/materials/0/stretch": [100, -1]}})");
  const Result r = run_cli("batch " + f + " --out " + out.string() + " --table -q", dir);
  EXPECT_EQ(r.code, 1) << r.err;
  const auto bad = raycloth::read_case_result(out, 1), good = raycloth::read_case_result(out, 0);
  ASSERT_TRUE(bad && good);
  EXPECT_EQ((*good)["status"], 0);
  EXPECT_EQ((*bad)["status"], 2);
  EXPECT_EQ((*bad)["error"], f + " (case 1): /materials/0/stretch: must be positive (got -1)");
  EXPECT_EQ((*bad)["clean"], nullptr);
}

// A batch process killed (SIGKILL) in the middle of a case leaves its claim and checkpoint; the next
// run takes the dead process's claim over and resumes the case from the checkpoint, to the same
// frames and run.json as a run that was never stopped.
TEST(Batch, KilledCaseResumesFromItsCheckpoint) {
  const fs::path dir = fresh_dir("killed"), out = dir / "out", whole = dir / "whole";
  const std::string sweep = (kData / "long.json").string();
  const std::vector<std::string> args = {"batch", sweep, "--index", "0", "--checkpoint-every", "2", "--threads", "1", "-q"};
  auto with_out = [&](const fs::path& o) {
    std::vector<std::string> a = args;
    a.insert(a.end(), {"--out", o.string()});
    return a;
  };
  const pid_t pid = spawn_cli(with_out(out), dir / "killed.log");
  const fs::path checkpoint = out / "cases" / "00000" / "checkpoint.bin";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  // Wait for the second checkpoint (frame 4): the case is well under way, far from its 41 frames.
  while (!fs::exists(out / "cases" / "00000" / "frames" / "cloth_0005.obj") && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  kill(pid, SIGKILL);
  EXPECT_EQ(wait_exit(pid), -SIGKILL);
  ASSERT_FALSE(fs::exists(out / "cases" / "00000" / "result.json")) << "the case ended before it was killed";
  ASSERT_TRUE(fs::exists(checkpoint));
  ASSERT_TRUE(fs::exists(out / "claims" / "00000"));  // the dead process's claim
  EXPECT_FALSE(fs::exists(out / "results.jsonl"));
  const Result resume = run_cli("resume " + (out / "cases" / "00000").string(), dir);
  EXPECT_EQ(resume.code, 2);
  EXPECT_EQ(resume.err, "raycloth: error: " + checkpoint.string() + ": is a case of the sweep " + sweep +
                            "; resume it with `raycloth batch SWEEP --out DIR` (it continues from this checkpoint)\n");

  EXPECT_EQ(wait_exit(spawn_cli(with_out(out), dir / "resumed.log")), 0) << slurp(dir / "resumed.log");
  EXPECT_EQ(wait_exit(spawn_cli(with_out(whole), dir / "whole.log")), 0) << slurp(dir / "whole.log");
  const auto resumed = raycloth::read_case_result(out, 0), straight = raycloth::read_case_result(whole, 0);
  ASSERT_TRUE(resumed && straight);
  EXPECT_EQ((*resumed)["resumed"], true);
  EXPECT_EQ((*straight)["resumed"], false);
  EXPECT_EQ((*resumed)["frames"], 41);
  EXPECT_FALSE(fs::exists(checkpoint));
  EXPECT_TRUE(fs::is_empty(out / "claims"));
  ASSERT_EQ(result_lines(out).size(), 1u);
  for (const char* key : {"status", "clean", "frames", "bad_frames", "pinched_frames", "steps", "values"})
    EXPECT_EQ((*resumed)[key], (*straight)[key]) << key;
  EXPECT_EQ(slurp(out / "cases" / "00000" / "run.json"), slurp(whole / "cases" / "00000" / "run.json"));
  for (int f = 0; f <= 40; ++f) {
    const std::string name = "cloth_" + std::string(f < 10 ? "000" : "00") + std::to_string(f) + ".obj";
    ASSERT_EQ(slurp(out / "cases" / "00000" / "frames" / name), slurp(whole / "cases" / "00000" / "frames" / name)) << name;
  }
}

// A case whose process ends without writing its result (here its folder is a file, so result.json
// cannot be written) is a failure, said as such: until 0.5.5 the batch counted it as "held by other
// processes" and exited 4, with no word of the error where the case ran in a process of its own.
// The other cases run, its claim goes, and a rerun once the folder is fixed runs it.
TEST(Batch, ACaseEndingWithoutAResultIsSaidAndRetriedNotCountedAsHeld) {
  const fs::path dir = fresh_dir("lost"), out = dir / "out";
  const std::string sweep = (kData / "sweep.json").string();
  for (const std::string jobs : {"1", "2"}) {
    fs::remove_all(out);
    fs::create_directories(out / "cases");
    write(out / "cases" / "00000", "not a folder\n");
    const std::string run = "batch " + sweep + " --out " + out.string() + " --shard 0/3 --threads 1 --jobs " + jobs;
    const Result r = run_cli(run, dir, "jobs" + jobs);
    EXPECT_EQ(r.code, 1) << r.err;
    const std::string error = "batch: case 00000 ended without a result: " +
                              (out / "cases" / "00000" / "result.json").string() +
                              ": cannot write: Not a directory; run the batch again to retry it\n";
    EXPECT_NE(r.err.find(error), std::string::npos) << r.err;
    if (jobs == "2")
      EXPECT_NE(r.err.find("batch: case 00000 ended with exit status 1 without a result (its error is above); run "
                           "the batch again to retry it\n"),
                std::string::npos)
          << r.err;
    EXPECT_NE(r.err.find("batch: 1/2 done, 0 failed, 0 running, 1 ended without a result, ETA"), std::string::npos)
        << r.err;
    EXPECT_EQ(r.err.find("held"), std::string::npos) << r.err;
    EXPECT_TRUE(raycloth::read_case_result(out, 3));  // the share's other case
    EXPECT_FALSE(raycloth::read_case_result(out, 0));
    EXPECT_TRUE(fs::is_empty(out / "claims"));
    fs::remove(out / "cases" / "00000");
    const Result again = run_cli(run, dir, "again" + jobs);
    EXPECT_EQ(again.code, 0) << again.err;
    EXPECT_TRUE(raycloth::read_case_result(out, 0));
  }
}

// Three processes on the same sweep and folder at once: every case runs exactly once.
TEST(Batch, ConcurrentProcessesNeverRunTheSameCase) {
  const fs::path dir = fresh_dir("concurrent"), out = dir / "out";
  const std::string sweep = (kData / "sweep.json").string();
  std::vector<pid_t> pids;
  for (int k = 0; k < 3; ++k)
    pids.push_back(spawn_cli({"batch", sweep, "--out", out.string(), "--threads", "1", "-q"},
                             dir / ("p" + std::to_string(k) + ".log")));
  for (pid_t p : pids) {
    const int code = wait_exit(p);
    EXPECT_TRUE(code == 0 || code == 4) << code;  // 4: some cases were held by the others
  }
  const std::vector<json> lines = result_lines(out);
  std::multiset<int> ids;
  for (const json& l : lines) ids.insert(l["case"].get<int>());
  EXPECT_EQ(lines.size(), 6u);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(ids.count(i), 1u) << i;
  EXPECT_TRUE(fs::is_empty(out / "claims"));
}

// A claim is respected while its process lives (here: this test's own pid) or, from another host,
// until --stale-after finds it untouched for longer than it allows.
TEST(Batch, LiveClaimsAreRespectedStaleOnesTakenOver) {
  const fs::path dir = fresh_dir("claims"), out = dir / "out";
  const std::string sweep = (kData / "sweep.json").string();
  const std::string run = "batch " + sweep + " --out " + out.string() + " --index 1";
  fs::create_directories(out / "claims");
  write(out / "claims" / "00001", std::to_string(getpid()) + " " + [] {
    char h[256] = {};
    gethostname(h, sizeof h - 1);
    return std::string(h);
  }() + " 0\n");
  Result r = run_cli(run, dir);
  EXPECT_EQ(r.code, 4) << r.err;  // held by a live process
  EXPECT_FALSE(raycloth::read_case_result(out, 1));
  write(out / "claims" / "00001", "1 some-other-host 0\n");
  r = run_cli(run + " --stale-after 60", dir);
  EXPECT_EQ(r.code, 4) << r.err;  // another host's claim, touched just now
  fs::last_write_time(out / "claims" / "00001", fs::file_time_type::clock::now() - std::chrono::minutes(5));
  r = run_cli(run, dir);
  EXPECT_EQ(r.code, 4) << r.err;  // without --stale-after, another host's claim stays
  r = run_cli(run + " --stale-after 60", dir);
  EXPECT_EQ(r.code, 0) << r.err;  // untouched for 5 minutes: taken over
  ASSERT_TRUE(raycloth::read_case_result(out, 1));
  EXPECT_FALSE(fs::exists(out / "claims" / "00001"));
}
