// run_scene: a scene run to an output folder, frame by frame. The frame writers are FrameSinks
// (io/obj_writer.h, ply_writer.h, pc2_writer.h, gltf_writer.h), run.json and timing.json come from
// io/run_report.h, checkpoints from io/run_checkpoint.h.
#include "io/run.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <exception>
#include <fstream>
#include <future>
#include <optional>

#include "io/atomic_file.h"
#include "io/gltf_writer.h"
#include "io/obj_writer.h"
#include "io/pc2_writer.h"
#include "io/ply_writer.h"
#include "io/progress.h"
#include "io/run_checkpoint.h"
#include "io/run_report.h"
#include "io/run_summary.h"
#include "raycloth/error.h"
#include "sim/model.h"
#include "sim/model_check.h"
#include "sim/seams.h"

namespace raycloth {

namespace fs = std::filesystem;

std::string frame_name(const std::string& prefix, int index, const std::string& ext) {
  return fmt::format("{}_{:04d}.{}", prefix, index, ext);
}

double check_thickness(const SceneDef& scene) { return std::stod(fmt::format("{}", scene.collision.thickness)); }

namespace {

// The scene as the options change it: the mesh formats and the duration.
SceneDef scene_with_options(const SceneDef& scene_in, const RunOptions& opt) {
  SceneDef scene = scene_in;
  if (opt.formats) {
    scene.output.formats = *opt.formats;
    validate_output(scene.output, scene.source);
  }
  if (opt.duration) {
    if (!(*opt.duration > 0)) throw InputError(scene.source, "duration", fmt::format("must be positive (got {:g})", *opt.duration));
    scene.time.duration = *opt.duration;
  }
  return scene;
}

// How the run's steps fall into output frames.
struct FramePlan {
  int steps_per_frame = 1;
  uint64_t total_steps = 0;
  int num_frames = 0;
  explicit FramePlan(const TimeDef& t)
      : steps_per_frame(std::max(1, int(std::lround(1.0 / (t.fps * t.dt))))),
        total_steps(uint64_t(std::llround(t.duration / t.dt))),
        num_frames(int((total_steps + steps_per_frame - 1) / steps_per_frame)) {}
};

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

double kinetic_energy(const ClothModel& m, const std::vector<Vec3>& v) {
  double e = 0;
  for (size_t i = 0; i < v.size(); ++i)
    if (m.inv_mass[i] > 0) e += 0.5 * double(m.mass[i]) * double(length_sq(v[i]));
  return e;
}

// Frame `index`'s exact check into the run's: the worst counts, the first bad and first pinched frame.
void add_frame_check(RunCheck& rc, const CheckReport& c, int index) {
  ++rc.frames_checked;
  rc.closed_obstacles = c.closed_obstacles;
  rc.open_obstacles = c.open_obstacles;
  rc.max_crossings = std::max(rc.max_crossings, c.crossings);
  rc.max_vertices_inside = std::max(rc.max_vertices_inside, c.vertices_inside);
  rc.max_vertices_pinched = std::max(rc.max_vertices_pinched, c.vertices_pinched);
  rc.min_pinch_gap = std::min(rc.min_pinch_gap, c.min_pinch_gap);
  if (c.failed()) {
    if (rc.bad_frames++ == 0) {
      rc.first_bad_frame = index;
      rc.first_problem = describe(c);
    }
  } else if (c.pinched_only()) {
    if (rc.pinched_frames++ == 0) {
      rc.first_pinched_frame = index;
      rc.first_pinch = describe(c);
    }
  }
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

// One run in progress: its outputs (the sinks), its report so far and its checkpoints.
class Run {
 public:
  Run(const SceneDef& scene, const RunOptions& opt, Simulator& sim, const FramePlan& plan)
      : scene_(scene), opt_(opt), sim_(sim), plan_(plan), thickness_(check_thickness(scene)) {
    report_.check.enabled = opt.check;
    for (const std::string& f : scene.output.formats)
      if (f != "obj" || opt.write_obj) sinks_.push_back(format_sink(f, sim.obstacles().any_moving, report_.outputs));
    sinks_.insert(sinks_.end(), opt.sinks.begin(), opt.sinks.end());
    report_.outputs.insert(report_.outputs.end(), {"obstacles.obj", "run.json", "timing.json", "summary.png"});
    report_.scene = scene.name;
    report_.device = sim.device();
    header_ = run_checkpoint_header(scene, opt, sim.device());
    checkpoints_ = opt.checkpoint_every > 0 && sim.can_checkpoint();
    if (opt.checkpoint_every > 0 && !checkpoints_)
      spdlog::warn("device {} cannot write checkpoints: this run cannot be resumed", sim.device());
  }

  // A fresh run: obstacles.obj and the sinks' beginnings. Returns the first frame to step to.
  int start() {
    remove_run_checkpoint(opt_.out_dir);  // a stale one from an earlier run in this folder
    write_obstacles_obj(opt_.out_dir / "obstacles.obj", sim_.obstacles(), sim_.obstacle_vertices());
    for (auto& s : sinks_) s->begin(sim_, opt_.out_dir);
    return 1;
  }

  // A run continued from its checkpoint. Returns the first frame to step to.
  int resume() {
    const int done = resume_run_checkpoint(opt_.out_dir, header_, plan_.num_frames, sim_, report_, sinks_);
    clamped_seen_ = sim_.totals().clamped;
    pushed_seen_ = sim_.totals().pushed;
    if (!opt_.quiet) spdlog::info("resuming at frame {} of {} (step {})", done, plan_.num_frames, sim_.steps());
    return done + 1;
  }

  // Steps frames first_frame..num_frames (frame 0 first on a fresh run), a checkpoint every
  // checkpoint_every frames. A blow-up or the caller's exception stops the run and is rethrown.
  void step_frames(int first_frame) {
    Progress progress(opt_.quiet, plan_.num_frames);
    using Clock = std::chrono::steady_clock;
    const auto run_start = Clock::now();
    try {
      if (first_frame == 1) emit(FrameRecord{});
      for (int f = first_frame; f <= plan_.num_frames; ++f) {
        const int n = int(std::min<uint64_t>(plan_.steps_per_frame, plan_.total_steps - sim_.steps()));
        const auto t0 = Clock::now();
        if (opt_.between_steps) {
          for (int k = 0; k < n; ++k) {
            sim_.step(1);
            call_caller(opt_.between_steps);
          }
        } else {
          sim_.step(n);
        }
        const double dt = std::chrono::duration<double>(Clock::now() - t0).count();
        report_.wall_time += dt;
        FrameRecord rec;
        rec.index = f;
        rec.steps_per_second = dt > 0 ? n / dt : 0.0;
        emit(rec);
        if (checkpoints_ && f % opt_.checkpoint_every == 0 && f < plan_.num_frames) {
          take_check();
          save_run_checkpoint(opt_.out_dir, header_, f, sim_, report_, sinks_);
        }
        progress.update(f, std::chrono::duration<double>(Clock::now() - run_start).count());
      }
      take_check();
    } catch (const SimulationError& e) {
      stop(e.what());
      throw;
    } catch (const CallerStop& s) {
      stop(fmt::format("stopped by the caller at step {} (t = {:g} s): {}", sim_.steps(), sim_.time(), s.what));
      std::rethrow_exception(s.error);
    }
  }

  // The run completed: the sinks' ends, run.json, timing.json and summary.png, and the warnings.
  RunReport finish() {
    for (auto& s : sinks_) s->end(sim_);
    write_report();
    remove_run_checkpoint(opt_.out_dir);
    warn_unconverged(scene_, sim_);
    warn_open_seams(sim_, report_);
    return std::move(report_);
  }

 private:
  // Records a frame (the simulator's state now, its exact check) and hands it to the sinks and the caller.
  void emit(FrameRecord rec) {
    rec.time = sim_.time();
    rec.step = sim_.steps();
    rec.hits = sim_.last_hits();
    rec.clamped = sim_.totals().clamped - clamped_seen_;
    rec.pushed = sim_.totals().pushed - pushed_seen_;
    clamped_seen_ = sim_.totals().clamped;
    pushed_seen_ = sim_.totals().pushed;
    rec.kinetic_energy = kinetic_energy(sim_.model(), sim_.velocities());
    rec.seam_gap = largest_stitch_gap(sim_.model(), sim_.positions());
    if (opt_.check) {
      CheckMesh cloth = cloth_check_mesh(sim_.model(), sim_.positions());
      CheckMesh obstacles = obstacle_check_mesh(sim_.obstacles(), sim_.obstacle_vertices());
      take_check();  // the last frame's first: the run's check is added up in frame order
      if (opt_.on_frame) {
        // The caller is shown the frame with its check: checked here, before it is called.
        report_.frames.push_back(rec);
        apply_check(check_state(cloth, obstacles, thickness_), report_.frames.size() - 1);
        rec = report_.frames.back();
      } else {
        // Checked beside the steps of the next frame (a thread of its own, on copies of the meshes):
        // the steps leave a core idle for part of the time, most where substeps are many and short.
        report_.frames.push_back(rec);
        pending_check_.emplace(PendingCheck{
            std::async(std::launch::async,
                       [cloth = std::move(cloth), obstacles = std::move(obstacles), t = thickness_] {
                         return check_state(cloth, obstacles, t);
                       }),
            report_.frames.size() - 1});
      }
    } else {
      report_.frames.push_back(rec);
    }
    for (auto& s : sinks_) s->frame(sim_, rec);
    if (opt_.on_frame) call_caller([&] { opt_.on_frame(sim_, report_.frames.back()); });
  }

  // A frame's check into its record and into the run's.
  void apply_check(const CheckReport& c, size_t slot) {
    FrameRecord& rec = report_.frames[slot];
    rec.crossings = long(c.crossings);
    rec.vertices_inside = long(c.vertices_inside);
    rec.pinched = long(c.vertices_pinched);
    rec.pinch_gap = c.min_pinch_gap;
    add_frame_check(report_.check, c, rec.index);
  }

  // Waits for the check still running, if any, and adds it up.
  void take_check() {
    if (!pending_check_) return;
    PendingCheck p = std::move(*pending_check_);
    pending_check_.reset();
    apply_check(p.result.get(), p.slot);
  }

  void write_report() {
    report_.steps = sim_.steps();
    report_.simulated_time = sim_.time();
    report_.stages = sim_.stage_times();
    report_.bound_refreshes = sim_.totals().refreshes;
    report_.steps_per_second = report_.wall_time > 0 ? double(report_.steps) / report_.wall_time : 0.0;
    const nlohmann::json j = run_json(report_, sim_);
    write_file_atomically(opt_.out_dir / "run.json", [&](std::ostream& out) { out << j.dump(2) << "\n"; });
    const nlohmann::json t = timing_json(report_);
    write_file_atomically(opt_.out_dir / "timing.json", [&](std::ostream& out) { out << t.dump(2) << "\n"; });
    write_run_summary(opt_.out_dir / "summary.png", report_);
  }

  // The run stopped by a blow-up or by the caller: the outputs end with the frames so far.
  void stop(const std::string& error) {
    report_.error = error;
    try {
      take_check();  // the last frame written is checked too
    } catch (const std::exception& check_error) {
      spdlog::error("{}", check_error.what());
    }
    for (auto& s : sinks_) {
      try {
        s->end(sim_);  // the frames so far
      } catch (const std::exception& sink_error) {
        spdlog::error("{}", sink_error.what());
      }
    }
    write_report();
    remove_run_checkpoint(opt_.out_dir);
  }

  const SceneDef& scene_;
  const RunOptions& opt_;
  Simulator& sim_;
  const FramePlan plan_;
  const double thickness_;
  RunReport report_;
  std::vector<std::shared_ptr<FrameSink>> sinks_;
  CheckpointHeader header_;
  bool checkpoints_ = false;
  uint64_t clamped_seen_ = 0, pushed_seen_ = 0;
  // The exact check of the last frame written, running beside the steps (emit).
  struct PendingCheck {
    std::future<CheckReport> result;
    size_t slot;  // its frame in report_.frames
  };
  std::optional<PendingCheck> pending_check_;
};

}  // namespace

RunReport run_scene(const SceneDef& scene_in, const RunOptions& opt) {
  const SceneDef scene = scene_with_options(scene_in, opt);
  Simulator sim(scene, opt.sim);  // every input check happens here, before anything is written
  const FramePlan plan(sim.scene().time);  // its dt may be the mesh's choice
  prepare_output_folder(opt.out_dir);
  Run run(scene, opt, sim, plan);
  run.step_frames(opt.resume ? run.resume() : run.start());
  return run.finish();
}

}  // namespace raycloth
