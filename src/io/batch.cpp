#include "io/batch.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <fstream>
#include <sstream>

#include "io/atomic_file.h"
#include "io/checkpoint.h"
#include "io/run.h"
#include "raycloth/error.h"
#include "scene/json_text.h"

namespace raycloth {

namespace fs = std::filesystem;
using json = nlohmann::json;
using ojson = nlohmann::ordered_json;

namespace {

constexpr size_t kMaxCases = 10'000'000;

std::string read_text(const std::string& path, const char* what) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw InputError(path, "", fmt::format("cannot open {}: {}", what, std::strerror(EISDIR)));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", fmt::format("cannot open {}: {}", what, std::strerror(errno)));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// nlohmann's messages start with "[json.exception.parse_error.101] ".
std::string json_message(const std::exception& e) {
  std::string m = e.what();
  if (m.rfind("[json.exception.", 0) == 0) {
    const size_t end = m.find("] ");
    if (end != std::string::npos) m = m.substr(end + 2);
  }
  return m;
}

// Checks that `key` names a field of the base scene that can be set: a JSON pointer whose parent
// exists, an existing element of a list or any key of an object (scene fields left out take their
// defaults, so a sweep may set them).
json::json_pointer scene_pointer(const Sweep& s, const std::string& section, const std::string& key) {
  const std::string field = "/" + section + "/" + json_pointer_token(key);
  if (key.empty() || key[0] != '/')
    throw InputError(s.file, field, fmt::format("'{}' is not a scene field: write it as a JSON pointer, such as "
                                                "\"/materials/0/stretch\"", key));
  json::json_pointer p;
  try {
    p = json::json_pointer(key);
  } catch (const json::exception& e) {
    throw InputError(s.file, field, fmt::format("'{}' is not a JSON pointer: {}", key, json_message(e)));
  }
  // Walk down to the field's parent: every step must exist (a list's element by its index).
  const std::string scene = s.scene_file.string();
  std::vector<std::string> tokens;
  for (json::json_pointer q = p; !q.empty(); q.pop_back()) tokens.insert(tokens.begin(), q.back());
  const json* at = &s.base;
  std::string walked;
  for (size_t t = 0; t < tokens.size(); ++t) {
    const std::string& tok = tokens[t];
    const bool last = t + 1 == tokens.size();
    const std::string here = walked.empty() ? "/" : walked;
    walked.append("/").append(json_pointer_token(tok));
    if (at->is_object()) {
      if (last) return p;  // a field the scene leaves to its default may be set
      if (!at->contains(tok)) throw InputError(s.file, field, fmt::format("the scene {} has no {}", scene, walked));
      at = &(*at)[tok];
    } else if (at->is_array()) {
      const bool digits = !tok.empty() && tok.size() < 10 && tok.find_first_not_of("0123456789") == std::string::npos &&
                          (tok == "0" || tok[0] != '0');
      if (!digits || std::stoul(tok) >= at->size())
        throw InputError(s.file, field,
                         fmt::format("the scene {} has no {} ({} is a list of {})", scene, walked, here, at->size()));
      if (last) return p;
      at = &(*at)[std::stoul(tok)];
    } else {
      throw InputError(s.file, field, fmt::format("the scene {} has no {} ({} is a {})", scene, walked, here, at->type_name()));
    }
  }
  throw InputError(s.file, field, "names the whole scene; name a field in it");
}

// An exclusive lock on OUT/.lock for as long as it lives.
class FolderLock {
 public:
  explicit FolderLock(const fs::path& out) {
    const std::string path = (out / ".lock").string();
    fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) throw std::runtime_error(path + ": cannot open the lock file: " + std::strerror(errno));
    while (::flock(fd_, LOCK_EX) != 0) {
      if (errno != EINTR) {
        const int err = errno;
        ::close(fd_);
        throw std::runtime_error(path + ": cannot lock: " + std::strerror(err));
      }
    }
  }
  ~FolderLock() { ::close(fd_); }
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;

 private:
  int fd_ = -1;
};

std::string host_name() {
  char buf[256] = {};
  if (::gethostname(buf, sizeof buf - 1) != 0) return "unknown";
  return buf;
}

// Writes all of `text` with one write() (O_APPEND makes it land whole at the end).
void write_whole(int fd, const std::string& text, const std::string& path) {
  const ssize_t n = ::write(fd, text.data(), text.size());
  if (n != ssize_t(text.size()))
    throw std::runtime_error(path + ": cannot write: " + (n < 0 ? std::strerror(errno) : "short write"));
}

enum class Claim { taken, finished, held };

// Under the folder lock: a finished case (result.json) is left alone; otherwise the claim file is
// created with O_EXCL, or taken over when its process is dead (same host) or it is stale.
Claim claim_case(const fs::path& out, size_t i, double stale_after) {
  FolderLock lock(out);
  std::error_code ec;
  if (fs::exists(out / "cases" / case_id(i) / "result.json", ec)) return Claim::finished;
  const fs::path claim = out / "claims" / case_id(i);
  const std::string me = fmt::format("{} {} {}\n", ::getpid(), host_name(), long(std::time(nullptr)));
  for (int attempt = 0; attempt < 2; ++attempt) {
    const int fd = ::open(claim.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd >= 0) {
      write_whole(fd, me, claim.string());
      ::close(fd);
      return Claim::taken;
    }
    if (errno != EEXIST) throw std::runtime_error(claim.string() + ": cannot create the claim: " + std::strerror(errno));
    // Someone's claim: take it over only if its process is gone or it went stale.
    std::ifstream in(claim);
    long pid = 0;
    std::string host;
    in >> pid >> host;
    bool dead = false;
    if (host == host_name() && pid > 0 && ::kill(pid_t(pid), 0) != 0 && errno == ESRCH) dead = true;
    struct stat st {};
    if (!dead && stale_after > 0 && ::stat(claim.c_str(), &st) == 0 &&
        double(std::time(nullptr) - st.st_mtime) > stale_after)
      dead = true;
    if (!dead) return Claim::held;
    fs::remove(claim, ec);
  }
  return Claim::held;
}

void touch(const fs::path& file) { ::utimensat(AT_FDCWD, file.c_str(), nullptr, 0); }

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

std::string csv_value(const ojson& v) {
  if (v.is_null()) return "";
  if (v.is_string()) return v.get<std::string>();
  return v.dump();
}

}  // namespace

size_t Sweep::cases() const {
  size_t n = 1;
  for (const auto& v : vary) n *= v.second.size();
  return n;
}

std::string case_id(size_t i) { return fmt::format("{:05d}", i); }

Sweep load_sweep(const std::string& path) {
  Sweep s;
  s.file = path;
  const std::string text = read_text(path, "sweep file");
  ojson j;
  try {
    j = ojson::parse(text, nullptr, /*allow_exceptions=*/true, /*ignore_comments=*/true);
  } catch (const json::exception& e) {
    throw InputError(path, "", json_message(e));
  }
  if (!j.is_object()) throw InputError(path, "", "must be a JSON object with \"scene\" and \"vary\"");
  for (const auto& [key, value] : j.items()) {
    (void)value;
    if (key != "scene" && key != "set" && key != "vary")
      throw InputError(path, "/" + json_pointer_token(key), "unknown field '" + key + "' (expected scene, set, vary)");
  }
  if (!j.contains("scene")) throw InputError(path, "/scene", "missing: name the base scene file (relative to the sweep file)");
  if (!j["scene"].is_string() || j["scene"].get<std::string>().empty())
    throw InputError(path, "/scene", "must be a file name (relative to the sweep file)");
  s.scene_file = fs::path(path).parent_path() / j["scene"].get<std::string>();
  const std::string scene_text = read_text(s.scene_file.string(), "scene file");
  load_scene_file(s.scene_file.string());  // the base scene must run as it is: its own errors name it
  s.base = json::parse(scene_text, nullptr, true, true);
  s.fingerprint = hash_bytes(scene_text, hash_bytes(text));

  if (j.contains("set")) {
    if (!j["set"].is_object()) throw InputError(path, "/set", "must be an object of scene fields (JSON pointers) to values");
    for (const auto& [key, value] : j["set"].items()) {
      scene_pointer(s, "set", key);
      s.set.emplace_back(key, json::parse(value.dump()));
    }
  }
  if (!j.contains("vary")) throw InputError(path, "/vary", "missing: name the scene fields to vary and their values");
  if (!j["vary"].is_object())
    throw InputError(path, "/vary", "must be an object of scene fields (JSON pointers) to lists of values");
  size_t count = 1;
  for (const auto& [key, values] : j["vary"].items()) {
    const std::string field = "/vary/" + json_pointer_token(key);
    scene_pointer(s, "vary", key);
    for (const auto& [k, v] : s.set) {
      (void)v;
      if (k == key) throw InputError(path, field, fmt::format("'{}' is also in /set: set it or vary it, not both", key));
    }
    if (!values.is_array() || values.empty()) throw InputError(path, field, "must be a non-empty list of values");
    std::vector<json> list;
    for (const auto& v : values) list.push_back(json::parse(v.dump()));
    if (count > kMaxCases / list.size())
      throw InputError(path, "/vary", fmt::format("more than {} cases; split the sweep", kMaxCases));
    count *= list.size();
    s.vary.emplace_back(key, std::move(list));
  }
  return s;
}

ojson case_values(const Sweep& s, size_t i) {
  if (i >= s.cases()) throw std::out_of_range(fmt::format("case {} of a sweep of {}", i, s.cases()));
  std::vector<size_t> pick(s.vary.size());
  for (size_t k = s.vary.size(); k-- > 0;) {
    pick[k] = i % s.vary[k].second.size();
    i /= s.vary[k].second.size();
  }
  ojson v = ojson::object();
  for (size_t k = 0; k < s.vary.size(); ++k) v[s.vary[k].first] = ojson::parse(s.vary[k].second[pick[k]].dump());
  return v;
}

json case_scene_json(const Sweep& s, size_t i) {
  json scene = s.base;
  for (const auto& [key, value] : s.set) scene[json::json_pointer(key)] = value;
  const ojson values = case_values(s, i);
  for (const auto& [key, value] : values.items()) scene[json::json_pointer(key)] = json::parse(value.dump());
  return scene;
}

SceneDef case_scene(const Sweep& s, size_t i) {
  return parse_scene(case_scene_json(s, i), fmt::format("{} (case {})", s.file, i), s.scene_file.parent_path());
}

void prepare_batch_folder(const Sweep& s, const fs::path& out) {
  std::error_code ec;
  fs::create_directories(out / "cases", ec);
  fs::create_directories(out / "claims", ec);
  if (ec) throw InputError(out.string(), "", "cannot write the output folder: " + ec.message());
  FolderLock lock(out);
  const fs::path info = out / "batch.json";
  const std::string hash = fmt::format("{:016x}", s.fingerprint);
  if (fs::exists(info, ec)) {
    json j;
    try {
      j = json::parse(read_text(info.string(), "batch file"));
    } catch (const json::exception& e) {
      throw InputError(info.string(), "", json_message(e));
    }
    if (j.value("fingerprint", std::string()) != hash)
      throw InputError(out.string(), "",
                       fmt::format("holds the cases of another sweep ({}, or it changed since); use another --out",
                                   j.value("sweep", std::string("?"))));
    return;
  }
  const ojson j = {{"sweep", fs::absolute(s.file).string()},
                   {"scene", fs::absolute(s.scene_file).string()},
                   {"cases", s.cases()},
                   {"fingerprint", hash}};
  write_file_atomically(info, [&](std::ostream& o) { o << j.dump(2) << "\n"; });
}

std::optional<ojson> read_case_result(const fs::path& out, size_t i) {
  const fs::path file = out / "cases" / case_id(i) / "result.json";
  std::ifstream in(file);
  if (!in) return std::nullopt;
  try {
    return ojson::parse(in);
  } catch (const json::exception&) {
    return std::nullopt;
  }
}

CaseOutcome run_case(const Sweep& s, size_t i, const BatchOptions& o, ojson* result) {
  const Claim c = claim_case(o.out, i, o.stale_after);
  if (c == Claim::finished) return CaseOutcome::finished;
  if (c == Claim::held) return CaseOutcome::claimed;
  const fs::path claim = o.out / "claims" / case_id(i);
  // The claim goes when the case ends, with its result or on an error that leaves none (a rerun
  // runs it again).
  struct ClaimRelease {
    const fs::path& file;
    ~ClaimRelease() {
      std::error_code ec;
      fs::remove(file, ec);
    }
  } release{claim};
  const fs::path dir = o.out / "cases" / case_id(i);
  const auto t0 = std::chrono::steady_clock::now();

  ojson r;
  r["case"] = i;
  r["id"] = case_id(i);
  r["values"] = case_values(s, i);
  int status = 0;
  std::string error;
  RunReport report;
  bool resumed = false;
  try {
    const SceneDef scene = case_scene(s, i);
    RunOptions opt;
    opt.out_dir = dir;
    opt.sim.device = o.device;
    opt.quiet = true;
    opt.check = o.check;
    opt.checkpoint_every = o.checkpoint_every;
    opt.scene_text = case_scene_json(s, i).dump();
    opt.invocation = ojson{{"batch", fs::absolute(s.file).string()}, {"case", i}}.dump();
    opt.on_frame = [&](Simulator&, const FrameRecord&) { touch(claim); };
    opt.between_steps = o.between_steps;
    std::error_code ec;
    opt.resume = fs::exists(dir / kCheckpointName, ec);
    resumed = opt.resume;
    try {
      report = run_scene(scene, opt);
    } catch (const InputError& e) {
      // A checkpoint this build cannot continue (another version, damaged): start the case over.
      if (!opt.resume || e.file().find(kCheckpointName) == std::string::npos) throw;
      fs::remove(dir / kCheckpointName, ec);
      opt.resume = resumed = false;
      report = run_scene(scene, opt);
    }
    if (report.check.bad_frames > 0) {
      status = 1;
      error = fmt::format("the exact check found penetration in {} of {} frames (first, frame {}: {})",
                          report.check.bad_frames, report.check.frames_checked, report.check.first_bad_frame,
                          report.check.first_problem);
    } else if (report.check.pinched_frames > 0) {
      status = 3;
    }
  } catch (const InputError& e) {
    status = 2;
    error = e.what();
  } catch (const std::exception& e) {
    status = 1;
    error = e.what();
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const RunCheck& ck = report.check;
  const bool checked = status != 2 && ck.enabled && ck.frames_checked > 0;
  r["status"] = status;
  r["clean"] = checked ? ojson(ck.bad_frames == 0 && ck.pinched_frames == 0) : ojson();
  r["frames"] = report.frames.size();
  r["bad_frames"] = checked ? ojson(ck.bad_frames) : ojson();
  r["max_crossings"] = checked ? ojson(ck.max_crossings) : ojson();
  r["max_vertices_inside"] = checked ? ojson(ck.max_vertices_inside) : ojson();
  r["pinched_frames"] = checked ? ojson(ck.pinched_frames) : ojson();
  r["max_vertices_pinched"] = checked ? ojson(ck.max_vertices_pinched) : ojson();
  r["steps"] = report.steps;
  r["simulated_time"] = report.simulated_time;
  r["steps_per_second"] = std::round(report.steps_per_second * 10) / 10;
  r["wall_s"] = std::round(wall * 1000) / 1000;
  r["resumed"] = resumed;
  r["host"] = host_name();
  r["error"] = error;

  std::error_code ec;
  fs::create_directories(dir, ec);
  write_file_atomically(dir / "result.json", [&](std::ostream& out) { out << r.dump(2) << "\n"; });
  {
    FolderLock lock(o.out);
    const fs::path lines = o.out / "results.jsonl";
    const int fd = ::open(lines.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (fd < 0) throw std::runtime_error(lines.string() + ": cannot open: " + std::strerror(errno));
    try {
      write_whole(fd, r.dump() + "\n", lines.string());
    } catch (...) {
      ::close(fd);
      throw;
    }
    ::close(fd);
  }
  if (result) *result = r;
  return CaseOutcome::ran;
}

std::string results_csv(const Sweep& s, const fs::path& out) {
  static const char* kColumns[] = {"status",        "clean",          "frames",        "bad_frames",
                                   "max_crossings", "max_vertices_inside", "pinched_frames", "max_vertices_pinched",
                                   "steps",         "steps_per_second", "wall_s",        "error"};
  std::string csv = "case";
  for (const auto& v : s.vary) csv.append(",").append(csv_field(v.first));
  for (const char* c : kColumns) csv.append(",").append(c);
  csv += "\n";
  for (size_t i = 0; i < s.cases(); ++i) {
    const std::optional<ojson> r = read_case_result(out, i);
    if (!r) continue;
    csv += case_id(i);
    for (const auto& v : s.vary) csv.append(",").append(csv_field(csv_value(r->at("values").value(v.first, ojson()))));
    for (const char* c : kColumns) csv.append(",").append(csv_field(csv_value(r->value(c, ojson()))));
    csv += "\n";
  }
  return csv;
}

std::vector<size_t> select_cases(size_t count, std::optional<long> index, const std::string& shard,
                                 const std::function<const char*(const char*)>& getenv_fn) {
  auto number = [](const std::string& text, long& v) {
    if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos || text.size() > 12) return false;
    v = std::stol(text);
    return true;
  };
  std::vector<size_t> cases;
  auto share = [&](long k, long n) {
    for (size_t i = size_t(k); i < count; i += size_t(n)) cases.push_back(i);
    return cases;
  };
  if (index) {
    if (*index < 0 || size_t(*index) >= count)
      throw InputError("command line", "--index",
                       fmt::format("no case {}: the sweep has {} cases (0 to {})", *index, count, count - 1));
    return {size_t(*index)};
  }
  if (!shard.empty()) {
    const size_t slash = shard.find('/');
    long k = 0, n = 0;
    if (slash == std::string::npos || !number(shard.substr(0, slash), k) || !number(shard.substr(slash + 1), n) ||
        n < 1 || k >= n)
      throw InputError("command line", "--shard",
                       fmt::format("'{}' is not a share I/N with 0 <= I < N (such as 0/4)", shard));
    return share(k, n);
  }
  const char* id_text = getenv_fn("SLURM_ARRAY_TASK_ID");
  if (!id_text) {
    for (size_t i = 0; i < count; ++i) cases.push_back(i);
    return cases;
  }
  auto env = [&](const char* name, long fallback) {
    const char* t = getenv_fn(name);
    if (!t) return fallback;
    long v = 0;
    if (!number(t, v)) throw InputError("environment", name, fmt::format("'{}' is not a whole number", t));
    return v;
  };
  const long id = env("SLURM_ARRAY_TASK_ID", 0);
  const long min = env("SLURM_ARRAY_TASK_MIN", 0);
  const long step = std::max(1L, env("SLURM_ARRAY_TASK_STEP", 1));
  const long tasks = env("SLURM_ARRAY_TASK_COUNT", 0);
  if (id < min || (id - min) % step != 0)
    throw InputError("environment", "SLURM_ARRAY_TASK_ID",
                     fmt::format("{} is not in the array (SLURM_ARRAY_TASK_MIN {}, step {})", id, min, step));
  const long k = (id - min) / step;
  if (tasks <= 0) {  // no count: the task's number is the case
    if (size_t(id) >= count)
      throw InputError("environment", "SLURM_ARRAY_TASK_ID",
                       fmt::format("no case {}: the sweep has {} cases (0 to {})", id, count, count - 1));
    return {size_t(id)};
  }
  if (k >= tasks)
    throw InputError("environment", "SLURM_ARRAY_TASK_ID",
                     fmt::format("task {} of an array of {} (SLURM_ARRAY_TASK_COUNT)", k, tasks));
  return share(k, tasks);
}

}  // namespace raycloth
