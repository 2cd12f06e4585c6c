// `raycloth batch SWEEP --out DIR`: the cases of a sweep (io/batch.h), one process or many.
#include <fmt/format.h>
#include <spawn.h>
#include <sys/wait.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <thread>

#include "commands.h"
#include "common.h"
#include "io/atomic_file.h"
#include "io/batch.h"
#include "raycloth/error.h"

extern char** environ;

namespace raycloth::cli {

namespace {
namespace fs = std::filesystem;

struct BatchArgs {
  std::string sweep;
  std::string out;
  long index = -1;
  std::string shard;
  int jobs = 1;
  int threads = 0;
  double stale_after = 0;
  int checkpoint_every = 5;
  std::string device = "cpu";
  bool no_check = false;
  bool list = false;
  bool count = false;
  bool table = false;
  bool quiet = false;
};

std::string clock_text(double seconds) {
  const long s = long(seconds + 0.5);
  return fmt::format("{}:{:02d}:{:02d}", s / 3600, (s / 60) % 60, s % 60);
}

// The progress line: cases of this share finished (by now, by this process or before), failed, ETA.
class Progress {
 public:
  Progress(size_t total, size_t already, bool quiet) : total_(total), done_(already), quiet_(quiet) {}
  void finished(bool failed, double wall) {
    ++done_, ++ran_;
    if (failed) ++failed_;
    wall_ += wall;
  }
  void held() { ++held_; }
  // A case whose process ended without writing its result (an error writing it, a signal).
  void lost() { ++lost_; }
  void print(int running, int jobs) const {
    if (quiet_) return;
    std::string eta = "?";
    const size_t left = total_ - done_ - held_ - lost_;
    if (ran_ > 0) {
      const double per_case = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count() /
                              double(ran_);
      eta = clock_text(per_case * double(left));
    }
    (void)jobs;
    std::cerr << fmt::format("batch: {}/{} done, {} failed, {} running{}{}, ETA {}\n", done_, total_, failed_, running,
                             lost_ ? fmt::format(", {} ended without a result", lost_) : "",
                             held_ ? fmt::format(", {} held by other processes", held_) : "", eta);
  }
  size_t failed() const { return failed_ + lost_; }
  size_t held_count() const { return held_; }

 private:
  size_t total_, done_, ran_ = 0, failed_ = 0, held_ = 0, lost_ = 0;
  bool quiet_;
  double wall_ = 0;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

// The exit status of a batch process whose share holds a case another live process has claimed
// (and no failure): what a case process (`--index I`) tells its parent when the case was not its own.
constexpr int kExitHeld = 4;

bool failed_status(const nlohmann::ordered_json& r) {
  const int s = r.value("status", 1);
  return s != 0 && s != 3;
}

// Runs case i in a child `raycloth batch ... --index i`; returns its pid.
pid_t spawn_case(const BatchArgs& a, size_t i, int threads) {
  std::vector<std::string> args = {"raycloth", "batch", a.sweep, "--out", a.out, "--index", std::to_string(i),
                                   "--quiet", "--checkpoint-every", std::to_string(a.checkpoint_every),
                                   "--device", a.device, "--stale-after", fmt::format("{}", a.stale_after)};
  if (threads > 0) args.insert(args.end(), {"--threads", std::to_string(threads)});
  if (a.no_check) args.push_back("--no-check");
  std::vector<char*> argv;
  for (auto& s : args) argv.push_back(s.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int err = posix_spawn(&pid, "/proc/self/exe", nullptr, nullptr, argv.data(), environ);
  if (err != 0) throw std::runtime_error(std::string("cannot start a case process: ") + std::strerror(err));
  return pid;
}

int batch_command(const BatchArgs& a) {
  const Sweep sweep = load_sweep(a.sweep);
  if (a.count) {
    std::cout << sweep.cases() << "\n";
    return 0;
  }
  if (a.list) {
    for (size_t i = 0; i < sweep.cases(); ++i) {
      std::string line = case_id(i);
      const nlohmann::ordered_json values = case_values(sweep, i);
      for (const auto& [k, v] : values.items()) line += fmt::format("  {}={}", k, v.dump());
      std::cout << line << "\n";
    }
    return 0;
  }
  if (a.out.empty()) throw InputError("command line", "--out", "missing: name the output folder");
  const std::vector<size_t> cases =
      select_cases(sweep.cases(), a.index >= 0 ? std::optional<long>(a.index) : std::nullopt, a.shard,
                   [](const char* n) { return std::getenv(n); });
  prepare_batch_folder(sweep, a.out);

  BatchOptions opt;
  opt.out = a.out;
  opt.device = a.device;
  opt.check = !a.no_check;
  opt.checkpoint_every = a.checkpoint_every;
  opt.stale_after = a.stale_after;

  std::vector<size_t> todo;
  size_t already = 0, failed_before = 0;
  for (size_t i : cases) {
    if (const auto r = read_case_result(a.out, i)) {
      ++already;
      if (failed_status(*r)) ++failed_before;
    } else {
      todo.push_back(i);
    }
  }
  const bool progress_quiet = a.quiet || cases.size() <= 1;
  Progress progress(cases.size(), already, progress_quiet);
  if (!a.quiet && already > 0)
    std::cerr << fmt::format("batch: {} of {} cases already finished, skipped\n", already, cases.size());

  if (a.jobs <= 1) {
    std::optional<tbb::global_control> threads;
    if (a.threads > 0) threads.emplace(tbb::global_control::max_allowed_parallelism, size_t(a.threads));
    for (size_t i : todo) {
      nlohmann::ordered_json r;
      CaseOutcome o;
      try {
        o = run_case(sweep, i, opt, &r);
      } catch (const std::exception& e) {
        // The case could not record its result (its folder, results.jsonl, its claim): the others
        // go on; a rerun runs it again. Said even with --quiet, as errors are.
        progress.lost();
        std::cerr << fmt::format("batch: case {} ended without a result: {}; run the batch again to retry it\n",
                                 case_id(i), e.what());
        progress.print(0, 1);
        continue;
      }
      if (o == CaseOutcome::ran) progress.finished(failed_status(r), r.value("wall_s", 0.0));
      else if (o == CaseOutcome::claimed) progress.held();
      else progress.finished(false, 0);
      progress.print(0, 1);
    }
  } else {
    const int hw = int(std::max(1u, std::thread::hardware_concurrency()));
    const int threads = a.threads > 0 ? a.threads : std::max(1, hw / a.jobs);
    std::map<pid_t, size_t> running;
    size_t next = 0;
    while (next < todo.size() || !running.empty()) {
      while (next < todo.size() && int(running.size()) < a.jobs) {
        const size_t i = todo[next++];
        running[spawn_case(a, i, threads)] = i;
      }
      progress.print(int(running.size()), a.jobs);
      int wstatus = 0;
      const pid_t pid = ::waitpid(-1, &wstatus, 0);
      if (pid < 0) {
        if (errno == EINTR) continue;
        throw std::runtime_error(std::string("waiting for a case process: ") + std::strerror(errno));
      }
      const auto it = running.find(pid);
      if (it == running.end()) continue;
      const size_t i = it->second;
      running.erase(it);
      if (const auto r = read_case_result(a.out, i)) {
        progress.finished(failed_status(*r), r->value("wall_s", 0.0));
      } else if (WIFEXITED(wstatus) && WEXITSTATUS(wstatus) == kExitHeld) {
        progress.held();  // the case process found it claimed by another live process
      } else {
        // The case process died (its claim is dead: a rerun resumes it from its checkpoint) or
        // ended on an error before its result was written (the error is above, on its stderr).
        progress.lost();
        if (!a.quiet) {
          if (WIFSIGNALED(wstatus))
            std::cerr << fmt::format("batch: case {} stopped by signal {} without a result; run the batch again to "
                                     "resume it\n",
                                     case_id(i), WTERMSIG(wstatus));
          else
            std::cerr << fmt::format("batch: case {} ended with exit status {} without a result (its error is "
                                     "above); run the batch again to retry it\n",
                                     case_id(i), WEXITSTATUS(wstatus));
        }
      }
    }
    progress.print(0, a.jobs);
  }

  if (a.table) {
    const std::string csv = results_csv(sweep, a.out);
    write_file_atomically(fs::path(a.out) / "results.csv", [&](std::ostream& o) { o << csv; });
    std::cout << csv;
  }
  if (progress.failed() + failed_before > 0) return 1;
  if (progress.held_count() > 0) return kExitHeld;
  return 0;
}

}  // namespace

Action add_batch_command(CLI::App& app) {
  auto a = std::make_shared<BatchArgs>();
  CLI::App* cmd = app.add_subcommand("batch", "Run the cases of a sweep (a base scene and values to vary) into --out");
  cmd->add_option("sweep", a->sweep, "Sweep file (JSON; docs/batch.md)")->required();
  cmd->add_option("-o,--out", a->out, "Output folder: cases/NNNNN/, results.jsonl, results.csv");
  cmd->add_option("--index", a->index, "Run case I only");
  cmd->add_option("--shard", a->shard, "Run share I/N: the cases i with i % N == I");
  cmd->add_option("-j,--jobs", a->jobs, "Cases at a time, each in its own process")->check(CLI::PositiveNumber)->capture_default_str();
  cmd->add_option("--threads", a->threads, "Worker threads per case (default: all cores, divided by --jobs)");
  cmd->add_option("--stale-after", a->stale_after,
                  "Take over claims not touched for this many seconds (a running case touches its claim every frame; "
                  "claims of dead processes on this host are taken over anyway)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--checkpoint-every", a->checkpoint_every, "Checkpoint a case every N frames (0: never)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--device", a->device, "cpu, cuda or auto")->check(CLI::IsMember({"cpu", "cuda", "auto"}))->capture_default_str();
  cmd->add_flag("--no-check", a->no_check, "Skip the exact penetration check of every frame");
  cmd->add_flag("--list", a->list, "Print the cases and their values; run nothing");
  cmd->add_flag("--count", a->count, "Print the number of cases; run nothing");
  cmd->add_flag("--table", a->table, "Also write OUT/results.csv (every finished case) and print it");
  cmd->add_flag("-q,--quiet", a->quiet, "No progress line");
  return [cmd, a] {
    if (!cmd->parsed()) return 0;
    return guarded([&] { return batch_command(*a); });
  };
}

}  // namespace raycloth::cli
