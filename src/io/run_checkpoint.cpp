#include "io/run_checkpoint.h"

#include <fmt/format.h>

#include <type_traits>

#include "io/run_report.h"
#include "raycloth/error.h"

namespace raycloth {

namespace fs = std::filesystem;

namespace {

// The keys whose values differ between two settings objects, for the message refusing a resume.
std::string settings_difference(const std::string& a, const std::string& b) {
  const nlohmann::json ja = nlohmann::json::parse(a, nullptr, false), jb = nlohmann::json::parse(b, nullptr, false);
  std::string out;
  if (ja.is_object() && jb.is_object()) {
    for (const auto& [key, value] : jb.items())
      if (!ja.contains(key) || ja[key] != value)
        out += fmt::format("{}{}: {} then, {} now", out.empty() ? "" : "; ", key, ja.contains(key) ? ja[key].dump() : "none", value.dump());
  }
  return out.empty() ? "the settings differ" : out;
}

void save_check(ByteWriter& w, const RunCheck& c) {
  for (uint64_t v : {uint64_t(c.frames_checked), uint64_t(c.bad_frames), uint64_t(int64_t(c.first_bad_frame)),
                     uint64_t(c.max_crossings), uint64_t(c.max_vertices_inside), uint64_t(c.closed_obstacles),
                     uint64_t(c.open_obstacles), uint64_t(c.pinched_frames), uint64_t(c.max_vertices_pinched),
                     uint64_t(int64_t(c.first_pinched_frame))})
    w.u64(v);
  w.f64(c.min_pinch_gap);
  w.str(c.first_problem);
  w.str(c.first_pinch);
}

void restore_check(ByteReader& r, RunCheck& c) {
  c.frames_checked = r.u64();
  c.bad_frames = r.u64();
  c.first_bad_frame = int(int64_t(r.u64()));
  c.max_crossings = r.u64();
  c.max_vertices_inside = r.u64();
  c.closed_obstacles = r.u64();
  c.open_obstacles = r.u64();
  c.pinched_frames = r.u64();
  c.max_vertices_pinched = r.u64();
  c.first_pinched_frame = int(int64_t(r.u64()));
  c.min_pinch_gap = r.f64();
  c.first_problem = r.str();
  c.first_pinch = r.str();
}

}  // namespace

CheckpointHeader run_checkpoint_header(const SceneDef& scene, const RunOptions& opt, const std::string& device) {
  const nlohmann::json settings = {{"scene", scene.name},
                                   {"formats", scene.output.formats},
                                   {"write_obj", opt.write_obj},
                                   {"duration", scene.time.duration},
                                   {"check", opt.check},
                                   {"device", device},
                                   {"allow_unstable_dt", opt.sim.allow_unstable_dt},
                                   {"other_outputs", opt.sinks.size()},
                                   {"camera", camera_json(scene.output.camera)}};
  return {kCheckpointFormat, raycloth_version(), scene_fingerprint(scene, opt.scene_text), settings.dump(), opt.invocation};
}

void save_run_checkpoint(const fs::path& out_dir, const CheckpointHeader& header, int done, Simulator& sim,
                         const RunReport& report, const std::vector<std::shared_ptr<FrameSink>>& sinks) {
  ByteWriter w;
  w.u32(uint32_t(done));
  sim.save_state(w);
  w.vec(report.frames);
  w.f64(report.wall_time);
  save_check(w, report.check);
  w.u64(sinks.size());
  for (auto& s : sinks) {
    ByteWriter sw;
    s->save(sw);
    w.str(sw.bytes());
  }
  write_checkpoint(out_dir, header, w.bytes());
}

int resume_run_checkpoint(const fs::path& out_dir, const CheckpointHeader& header, int num_frames, Simulator& sim,
                          RunReport& report, const std::vector<std::shared_ptr<FrameSink>>& sinks) {
  static_assert(std::is_trivially_copyable_v<FrameRecord>);
  const CheckpointFile cp = read_checkpoint(out_dir);
  const std::string file = (out_dir / kCheckpointName).string();
  if (cp.header.scene_hash != header.scene_hash)
    throw InputError(file, "", "was written for another scene (the scene file or a mesh it uses has changed); start "
                               "the run again without --resume");
  if (cp.header.settings != header.settings)
    throw InputError(file, "", "was written by a run with other settings (" +
                                   settings_difference(cp.header.settings, header.settings) +
                                   "); resume with the same options, or start again without --resume");
  if (!sim.can_checkpoint()) throw InputError(file, "", "device " + sim.device() + " cannot resume from a checkpoint");
  ByteReader in(cp.state, file);
  const uint32_t done = in.u32();
  if (done < 1 || done > uint32_t(num_frames)) in.fail("holds frame " + std::to_string(done) + ", not one of this run's");
  sim.restore_state(in);
  in.vec(report.frames, size_t(done) + 1, "frame records");
  report.wall_time = in.f64();
  restore_check(in, report.check);
  if (in.u64() != sinks.size()) in.fail("was written for other outputs");
  for (auto& s : sinks) {
    const std::string blob = in.str();
    ByteReader sr(blob, file);
    s->resume(sim, out_dir, sr);
  }
  if (!in.at_end()) in.fail("is truncated or damaged; start the run again without --resume");
  return int(done);
}

void remove_run_checkpoint(const fs::path& out_dir) {
  const fs::path path = out_dir / kCheckpointName;
  std::error_code ignored;
  fs::remove(path, ignored);
  fs::remove(fs::path(path.string() + ".tmp"), ignored);
}

}  // namespace raycloth
