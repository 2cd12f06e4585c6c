#include "io/run.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cerrno>
#include <exception>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "sim/model_check.h"
#include "io/atomic_file.h"
#include "io/checkpoint.h"
#include "io/gltf_writer.h"
#include "io/obj_writer.h"
#include "io/pc2_writer.h"
#include "io/ply_writer.h"
#include "io/run_summary.h"
#include "raycloth/error.h"
#include "sim/model.h"
#include "sim/seams.h"

namespace raycloth {

namespace fs = std::filesystem;

std::string frame_name(const std::string& prefix, int index, const std::string& ext) {
  return fmt::format("{}_{:04d}.{}", prefix, index, ext);
}

double check_thickness(const SceneDef& scene) { return std::stod(fmt::format("{}", scene.collision.thickness)); }

namespace {

double kinetic_energy(const ClothModel& m, const std::vector<Vec3>& v) {
  double e = 0;
  for (size_t i = 0; i < v.size(); ++i)
    if (m.inv_mass[i] > 0) e += 0.5 * double(m.mass[i]) * double(length_sq(v[i]));
  return e;
}

class ObjFrames final : public FrameSink {
 public:
  void begin(Simulator&, const fs::path& out) override { dir_ = out / "frames"; }
  void frame(Simulator& sim, const FrameRecord& r) override {
    write_cloth_obj(dir_ / frame_name("cloth", r.index, "obj"), sim.model(), sim.positions());
    if (sim.obstacles().any_moving)
      write_obstacles_obj(dir_ / frame_name("obstacles", r.index, "obj"), sim.obstacles(), sim.obstacle_vertices());
  }

 private:
  fs::path dir_;
};

// The writer of one mesh format, and the files it writes.
std::shared_ptr<FrameSink> format_sink(const std::string& format, bool moving, std::vector<std::string>& outputs) {
  auto frames = [&](const char* ext) {
    outputs.push_back(fmt::format("frames/cloth_*.{}", ext));
    if (moving) outputs.push_back(fmt::format("frames/obstacles_*.{}", ext));
  };
  if (format == "obj") {
    frames("obj");
    return std::make_shared<ObjFrames>();
  }
  if (format == "ply") {
    frames("ply");
    return std::make_shared<PlyFrames>();
  }
  if (format == "pc2") {
    outputs.insert(outputs.end(), {"cloth.pc2", "cloth_rest.obj"});
    return std::make_shared<Pc2Sink>();
  }
  if (format == "glb") {
    outputs.push_back("cloth.glb");
    return std::make_shared<GlbSink>();
  }
  throw std::invalid_argument("unknown output format '" + format + "'");
}

// A bar with an ETA on a terminal, a log line per tenth of the run otherwise.
class Progress {
 public:
  Progress(bool quiet, int total) : quiet_(quiet), tty_(isatty(STDERR_FILENO)), total_(total) {}
  void update(int done, double elapsed) {
    if (quiet_ || total_ <= 0) return;
    const double frac = double(done) / total_;
    const double eta = done > 0 ? elapsed * (total_ - done) / done : 0.0;
    if (tty_) {
      const int width = 30, filled = int(frac * width);
      std::cerr << fmt::format("\r[{}{}] {:3.0f}% frame {}/{} ETA {:.0f}s ", std::string(filled, '#'),
                               std::string(width - filled, '.'), frac * 100, done, total_, eta)
                << std::flush;
      if (done == total_) std::cerr << "\n";
    } else if (done * 10 / total_ != last_decile_ || done == total_) {
      last_decile_ = done * 10 / total_;
      spdlog::info("frame {}/{} ({:.0f}%), ETA {:.0f} s", done, total_, frac * 100, eta);
    }
  }

 private:
  bool quiet_, tty_;
  int total_;
  int last_decile_ = 0;
};

// Seams sewn from apart: the stitches, the tolerance, the widest stitch when the seams should have
// closed (the first frame at or after sewing.close_time) and at the end, and the seams still open.
nlohmann::json seams_json(const RunReport& r, Simulator& sim) {
  const SceneDef& s = sim.scene();
  const float tol = seam_close_tolerance(s);
  nlohmann::json j = {{"stitches", sim.model().stitch_seam.size()},
                      {"welded", sim.stitches_welded()},
                      {"close_time", s.sewing.close_time},
                      {"close_tolerance", tol}};
  const FrameRecord* at_close = nullptr;
  for (const FrameRecord& f : r.frames)
    if (!at_close && f.time >= s.sewing.close_time - 1e-9) at_close = &f;
  j["largest_gap_at_close_time"] = at_close ? nlohmann::json(at_close->seam_gap) : nlohmann::json(nullptr);
  j["largest_gap_at_end"] = r.frames.empty() ? 0.0 : r.frames.back().seam_gap;
  nlohmann::json open = nlohmann::json::array();
  for (const SeamGap& g : seam_gaps(sim.model(), sim.positions()))
    if (g.largest > tol) {
      const SeamDef& sd = s.seams[g.seam];
      open.push_back({{"seam", g.seam}, {"a", sd.a.panel}, {"b", sd.b.panel}, {"largest_gap", g.largest}});
    }
  j["open_at_end"] = open;
  return j;
}

// Says so when a seam sewn from apart had not closed by the end of the close time (or is open at the end).
void warn_open_seams(Simulator& sim, const RunReport& r) {
  const ClothModel& m = sim.model();
  if (m.stitches.empty() || r.frames.empty()) return;
  const SceneDef& s = sim.scene();
  const float tol = seam_close_tolerance(s);
  for (const FrameRecord& f : r.frames)
    if (f.time >= s.sewing.close_time - 1e-9) {
      if (f.seam_gap > tol)
        spdlog::warn("seams still open at the end of the close time ({:g} s): the widest stitch is {:.3g} m apart "
                     "(sewing.close_tolerance {:g} m); run.json's seams lists those open at the end",
                     s.sewing.close_time, f.seam_gap, tol);
      break;
    }
  if (r.frames.back().time >= s.sewing.close_time - 1e-9 && r.frames.back().seam_gap > tol)
    spdlog::warn("seams open at the end of the run: the widest stitch is {:.3g} m apart", r.frames.back().seam_gap);
}

nlohmann::json report_json(const RunReport& r, Simulator& sim) {
  const ClothModel& m = sim.model();
  nlohmann::json j;
  j["scene"] = r.scene;
  j["device"] = r.device;
  j["vertices"] = m.num_vertices();
  j["triangles"] = m.num_triangles();
  j["springs"] = {{"stretch", m.spring_counts[0]}, {"shear", m.spring_counts[1]}, {"bend", m.spring_counts[2]},
                  {"seam", m.spring_counts[3]}, {"total", m.springs.size()}};
  j["obstacle_triangles"] = sim.obstacles().world.num_triangles();
  // Openings of the obstacles that the step closed (scene/holes.h): loops found, capped, triangles.
  j["obstacle_holes"] = {{"found", sim.obstacles().holes_found}, {"capped", sim.obstacles().holes_capped},
                         {"cap_triangles", sim.obstacles().cap_triangles}};
  j["dt"] = sim.scene().time.dt;
  j["fps"] = sim.scene().time.fps;
  // The cloth thickness (metres): `raycloth check DIR` reads it to tell pinches from failures.
  j["thickness"] = check_thickness(sim.scene());
  // The scene's camera, so that `raycloth render DIR` shows the run as the run would have.
  const CameraDef& cam = sim.scene().output.camera;
  nlohmann::json camera = {{"fov", cam.fov}, {"resolution", {cam.width, cam.height}}, {"samples", cam.samples}};
  if (cam.position) camera["position"] = *cam.position;
  if (cam.target) camera["target"] = *cam.target;
  j["camera"] = camera;
  j["natural_period_T0"] = m.natural_period();
  j["steps"] = r.steps;
  j["simulated_time"] = r.simulated_time;
  nlohmann::json frames = nlohmann::json::array();
  for (const auto& f : r.frames) {
    nlohmann::json jf = {{"index", f.index}, {"time", f.time}, {"step", f.step}, {"hits", f.hits}, {"clamped", f.clamped},
                         {"pushed", f.pushed}, {"kinetic_energy", f.kinetic_energy}};
    if (f.crossings >= 0) {
      jf["crossings"] = f.crossings;
      jf["vertices_inside"] = f.vertices_inside;
      jf["pinched"] = f.pinched;
      jf["pinch_gap"] = std::isfinite(f.pinch_gap) ? nlohmann::json(f.pinch_gap) : nlohmann::json(nullptr);
    }
    if (!m.stitches.empty()) jf["seam_gap"] = f.seam_gap;
    frames.push_back(jf);
  }
  j["frames"] = frames;
  if (!m.stitches.empty()) j["seams"] = seams_json(r, sim);
  // The run's totals (raycloth/totals.h), each in its section; the integrator's follow.
  j["contact"] = nlohmann::json::object();
  for_each_total(sim.totals(), [&](const char* name, const char* section, uint64_t value) {
    if (std::string(section) == "contact") j["contact"][name] = value;
  });
  // The integrator, and for the implicit one its convergence: the sweeps per step, the tolerance on
  // the last sweep's largest step, the steps (substeps) that did not reach it and the largest such step.
  const TimeDef& td = sim.scene().time;
  if (td.integrator == Integrator::Implicit)
    j["integrator"] = {{"name", "implicit"},           {"method", "implicit Euler, vertex block descent"},
                       {"iterations", td.iterations},  {"tolerance", td.tolerance},
                       {"unconverged_steps", sim.totals().unconverged}, {"max_residual", sim.totals().max_residual},
                       // Where a body moves, each step is done in substeps (Simulator::substeps).
                       {"substeps", sim.substeps()}};
  else
    j["integrator"] = {{"name", "explicit"}, {"method", "explicit Euler, eq. (3)"}};
  if (r.check.enabled) {
    j["check"] = {{"method", "exact: every cloth edge against every cloth triangle sharing no vertex (CGAL filtered "
                             "exact orientation predicates); every cloth vertex against every obstacle (closed: "
                             "CGAL Side_of_triangle_mesh; open: winding number >= 1/2); on every written frame. "
                             "A vertex inside is pinched, not a failure, where the body's own gap at its way out "
                             "is below twice the thickness"},
                  {"frames_checked", r.check.frames_checked},
                  {"bad_frames", r.check.bad_frames},
                  {"first_bad_frame", r.check.first_bad_frame},
                  {"max_crossings", r.check.max_crossings},
                  {"max_vertices_inside", r.check.max_vertices_inside},
                  {"pinched_frames", r.check.pinched_frames},
                  {"first_pinched_frame", r.check.first_pinched_frame},
                  {"max_vertices_pinched", r.check.max_vertices_pinched},
                  {"min_pinch_gap", std::isfinite(r.check.min_pinch_gap) ? nlohmann::json(r.check.min_pinch_gap)
                                                                          : nlohmann::json(nullptr)},
                  {"closed_obstacles", r.check.closed_obstacles},
                  {"open_obstacles", r.check.open_obstacles}};
    if (!r.check.first_problem.empty()) j["check"]["first_problem"] = r.check.first_problem;
    if (!r.check.first_pinch.empty()) j["check"]["first_pinch"] = r.check.first_pinch;
  } else {
    j["check"] = {{"method", "none (run with the check turned off)"}};
  }
  j["outputs"] = r.outputs;
  if (!r.error.empty()) j["error"] = r.error;
  return j;
}

// timing.json: the wall-clock figures, which differ between any two runs of the same scene.
nlohmann::json timing_json(const RunReport& r) {
  nlohmann::json j;
  j["wall_time"] = r.wall_time;
  j["steps_per_second"] = r.steps_per_second;
  // A cheaper step that needs a smaller dt is no gain: simulated time per wall-clock time says so.
  j["simulated_seconds_per_wall_second"] = r.wall_time > 0 ? r.simulated_time / r.wall_time : 0.0;
  const double per = r.steps > 0 ? 1000.0 / double(r.steps) : 0.0;
  j["stage_ms_per_step"] = {{"forces_and_integration", r.stages.integrate * per},
                            {"acceleration_structure_update", r.stages.update * per},
                            {"ray_casting", r.stages.cast * per},
                            {"response", r.stages.respond * per},
                            {"contact_solve", r.stages.contact * per},
                            {"displacement_bound", r.stages.bound * per}};
  nlohmann::json frames = nlohmann::json::array();
  for (const auto& f : r.frames) frames.push_back({{"index", f.index}, {"steps_per_second", f.steps_per_second}});
  j["frames"] = frames;
  return j;
}

// Creates OUT/frames and proves that a file can be written in OUT, before anything is simulated.
void prepare_output_folder(const fs::path& out) {
  const std::string where = out.string();
  auto fail = [&](const std::string& why) { throw InputError(where, "", "cannot write the output folder: " + why); };
  std::error_code ec;
  fs::create_directories(out / "frames", ec);
  if (ec) fail(ec.message());
  const fs::path probe = out / ".raycloth_write_test";
  {
    std::ofstream f(probe, std::ios::binary | std::ios::trunc);
    if (!f) fail(std::strerror(errno));
    f << "raycloth\n";
    f.close();
    if (!f) fail(std::strerror(errno));
  }
  fs::remove(probe, ec);
}

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

// An exception from the caller's on_frame or between_steps, carried out of the run's loop.
struct CallerStop {
  std::exception_ptr error;
  std::string what;
};

template <class F>
void call_caller(F&& f) {
  try {
    f();
  } catch (const std::exception& e) {
    throw CallerStop{std::current_exception(), e.what()};
  } catch (...) {
    throw CallerStop{std::current_exception(), "unknown exception"};
  }
}

}  // namespace

RunReport run_scene(const SceneDef& scene_in, const RunOptions& opt) {
  SceneDef scene = scene_in;
  if (opt.formats) {
    scene.output.formats = *opt.formats;
    validate_output(scene.output, scene.source);
  }
  if (opt.duration) {
    if (!(*opt.duration > 0)) throw InputError(scene.source, "duration", fmt::format("must be positive (got {:g})", *opt.duration));
    scene.time.duration = *opt.duration;
  }
  Simulator sim(scene, opt.sim);  // every input check happens here, before anything is written

  const int steps_per_frame = std::max(1, int(std::lround(1.0 / (scene.time.fps * scene.time.dt))));
  const uint64_t total_steps = uint64_t(std::llround(scene.time.duration / scene.time.dt));
  const int num_frames = int((total_steps + steps_per_frame - 1) / steps_per_frame);

  prepare_output_folder(opt.out_dir);

  RunReport report;
  report.check.enabled = opt.check;
  std::vector<std::shared_ptr<FrameSink>> sinks;
  for (const std::string& f : scene.output.formats)
    if (f != "obj" || opt.write_obj) sinks.push_back(format_sink(f, sim.obstacles().any_moving, report.outputs));
  sinks.insert(sinks.end(), opt.sinks.begin(), opt.sinks.end());
  report.outputs.insert(report.outputs.end(), {"obstacles.obj", "run.json", "timing.json", "summary.png"});

  report.scene = scene.name;
  report.device = sim.device();

  // What a checkpoint must agree with to be resumed: the scene (and its meshes), the raycloth
  // version, and every setting that changes what the run writes.
  const CameraDef& cam = scene.output.camera;
  nlohmann::json camera = {{"fov", cam.fov}, {"resolution", {cam.width, cam.height}}, {"samples", cam.samples}};
  if (cam.position) camera["position"] = *cam.position;
  if (cam.target) camera["target"] = *cam.target;
  const nlohmann::json settings = {{"scene", scene.name},
                                   {"formats", scene.output.formats},
                                   {"write_obj", opt.write_obj},
                                   {"duration", scene.time.duration},
                                   {"check", opt.check},
                                   {"device", sim.device()},
                                   {"allow_unstable_dt", opt.sim.allow_unstable_dt},
                                   {"other_outputs", opt.sinks.size()},
                                   {"camera", camera}};
  const CheckpointHeader header{kCheckpointFormat, raycloth_version(), scene_fingerprint(scene, opt.scene_text),
                                settings.dump(), opt.invocation};
  const fs::path checkpoint_path = opt.out_dir / kCheckpointName;
  auto remove_checkpoint = [&] {
    std::error_code ignored;
    fs::remove(checkpoint_path, ignored);
    fs::remove(fs::path(checkpoint_path.string() + ".tmp"), ignored);
  };
  const bool checkpoints = opt.checkpoint_every > 0 && sim.can_checkpoint();
  if (opt.checkpoint_every > 0 && !checkpoints)
    spdlog::warn("device {} cannot write checkpoints: this run cannot be resumed", sim.device());

  uint64_t clamped_seen = 0, pushed_seen = 0;
  const double thickness = check_thickness(scene);
  auto emit = [&](FrameRecord rec) {
    rec.time = sim.time();
    rec.step = sim.steps();
    rec.hits = sim.last_hits();
    rec.clamped = sim.totals().clamped - clamped_seen;
    rec.pushed = sim.totals().pushed - pushed_seen;
    clamped_seen = sim.totals().clamped;
    pushed_seen = sim.totals().pushed;
    rec.kinetic_energy = kinetic_energy(sim.model(), sim.velocities());
    rec.seam_gap = largest_stitch_gap(sim.model(), sim.positions());
    if (opt.check) {
      const CheckReport c = check_state(cloth_check_mesh(sim.model(), sim.positions()),
                                        obstacle_check_mesh(sim.obstacles(), sim.obstacle_vertices()), thickness);
      rec.crossings = long(c.crossings);
      rec.vertices_inside = long(c.vertices_inside);
      rec.pinched = long(c.vertices_pinched);
      rec.pinch_gap = c.min_pinch_gap;
      RunCheck& rc = report.check;
      ++rc.frames_checked;
      rc.closed_obstacles = c.closed_obstacles;
      rc.open_obstacles = c.open_obstacles;
      rc.max_crossings = std::max(rc.max_crossings, c.crossings);
      rc.max_vertices_inside = std::max(rc.max_vertices_inside, c.vertices_inside);
      rc.max_vertices_pinched = std::max(rc.max_vertices_pinched, c.vertices_pinched);
      rc.min_pinch_gap = std::min(rc.min_pinch_gap, c.min_pinch_gap);
      if (c.failed()) {
        if (rc.bad_frames++ == 0) {
          rc.first_bad_frame = rec.index;
          rc.first_problem = describe(c);
        }
      } else if (c.pinched_only()) {
        if (rc.pinched_frames++ == 0) {
          rc.first_pinched_frame = rec.index;
          rc.first_pinch = describe(c);
        }
      }
    }
    report.frames.push_back(rec);
    for (auto& s : sinks) s->frame(sim, rec);
    if (opt.on_frame) call_caller([&] { opt.on_frame(sim, report.frames.back()); });
  };

  auto write_report = [&] {
    report.steps = sim.steps();
    report.simulated_time = sim.time();
    report.stages = sim.stage_times();
    report.bound_refreshes = sim.totals().refreshes;
    report.steps_per_second = report.wall_time > 0 ? double(report.steps) / report.wall_time : 0.0;
    const nlohmann::json j = report_json(report, sim);
    write_file_atomically(opt.out_dir / "run.json", [&](std::ostream& out) { out << j.dump(2) << "\n"; });
    const nlohmann::json t = timing_json(report);
    write_file_atomically(opt.out_dir / "timing.json", [&](std::ostream& out) { out << t.dump(2) << "\n"; });
    write_run_summary(opt.out_dir / "summary.png", report);
  };
  // The implicit integrator says so when its sweeps did not converge (once, at the end).
  auto warn_unconverged = [&] {
    if (scene.time.integrator != Integrator::Implicit || sim.totals().unconverged == 0) return;
    spdlog::warn("the implicit integrator did not converge in {} of {} steps: its last sweep still moved a vertex up to "
                 "{:.3g} m (time.tolerance {:g} m); raise time.iterations or lower time.dt",
                 sim.totals().unconverged, sim.steps(), sim.totals().max_residual, scene.time.tolerance);
  };

  // After frame `done`: the state, the report so far and the sinks' own state.
  auto save_checkpoint = [&](int done) {
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
    write_checkpoint(opt.out_dir, header, w.bytes());
  };

  int first_frame = 1;
  if (opt.resume) {
    static_assert(std::is_trivially_copyable_v<FrameRecord>);
    const CheckpointFile cp = read_checkpoint(opt.out_dir);
    const std::string file = checkpoint_path.string();
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
      s->resume(sim, opt.out_dir, sr);
    }
    if (!in.at_end()) in.fail("is truncated or damaged; start the run again without --resume");
    clamped_seen = sim.totals().clamped;
    pushed_seen = sim.totals().pushed;
    first_frame = int(done) + 1;
    if (!opt.quiet) spdlog::info("resuming at frame {} of {} (step {})", done, num_frames, sim.steps());
  } else {
    remove_checkpoint();  // a stale one from an earlier run in this folder
    write_obstacles_obj(opt.out_dir / "obstacles.obj", sim.obstacles(), sim.obstacle_vertices());
    for (auto& s : sinks) s->begin(sim, opt.out_dir);
  }

  Progress progress(opt.quiet, num_frames);
  using Clock = std::chrono::steady_clock;
  const auto run_start = Clock::now();
  // The run stopped by a blow-up or by the caller: the outputs end with the frames so far.
  auto stop = [&](const std::string& error) {
    report.error = error;
    for (auto& s : sinks) {
      try {
        s->end(sim);  // the frames so far
      } catch (const std::exception& sink_error) {
        spdlog::error("{}", sink_error.what());
      }
    }
    write_report();
    remove_checkpoint();
  };
  try {
    if (first_frame == 1) emit(FrameRecord{});
    for (int f = first_frame; f <= num_frames; ++f) {
      const int n = int(std::min<uint64_t>(steps_per_frame, total_steps - sim.steps()));
      const auto t0 = Clock::now();
      if (opt.between_steps) {
        for (int k = 0; k < n; ++k) {
          sim.step(1);
          call_caller(opt.between_steps);
        }
      } else {
        sim.step(n);
      }
      const double dt = std::chrono::duration<double>(Clock::now() - t0).count();
      report.wall_time += dt;
      FrameRecord rec;
      rec.index = f;
      rec.steps_per_second = dt > 0 ? n / dt : 0.0;
      emit(rec);
      if (checkpoints && f % opt.checkpoint_every == 0 && f < num_frames) save_checkpoint(f);
      progress.update(f, std::chrono::duration<double>(Clock::now() - run_start).count());
    }
  } catch (const SimulationError& e) {
    stop(e.what());
    throw;
  } catch (const CallerStop& s) {
    stop(fmt::format("stopped by the caller at step {} (t = {:g} s): {}", sim.steps(), sim.time(), s.what));
    std::rethrow_exception(s.error);
  }
  for (auto& s : sinks) s->end(sim);
  write_report();
  remove_checkpoint();
  warn_unconverged();
  warn_open_seams(sim, report);
  return report;
}

}  // namespace raycloth
