#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>
#include <tbb/global_control.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "camera_options.h"
#include "commands.h"
#include "common.h"
#include "io/checkpoint.h"
#include "io/run.h"
#include "raycloth/error.h"
#include "raycloth/scene.h"
#include "render/image_frames.h"

namespace raycloth::cli {

namespace {
struct RunArgs {
  std::string scene;
  std::string out = "out";
  std::string device = "cpu";
  std::vector<std::string> formats;
  double duration = 0;
  // Overrides of the scene's time settings (empty: the scene's own).
  std::string integrator;
  std::optional<double> dt;
  std::optional<int> iterations;
  int threads = 0;
  bool quiet = false;
  bool allow_unstable = false;
  bool render = false;
  bool video = false;
  bool no_check = false;
  bool formats_given = false;
  bool resume = false;
  int checkpoint_every = 5;
  CameraArgs camera;
};

// What `raycloth resume DIR` needs to run the same command again (kept in the checkpoint).
std::string invocation_json(const RunArgs& a) {
  nlohmann::json j = {{"scene", a.scene.empty() ? std::string() : std::filesystem::absolute(a.scene).string()},
                      {"device", a.device},
                      {"duration", a.duration},
                      {"integrator", a.integrator},
                      {"dt", a.dt ? nlohmann::json(*a.dt) : nlohmann::json(nullptr)},
                      {"iterations", a.iterations ? nlohmann::json(*a.iterations) : nlohmann::json(nullptr)},
                      {"allow_unstable_dt", a.allow_unstable},
                      {"render", a.render},
                      {"video", a.video},
                      {"no_check", a.no_check},
                      {"checkpoint_every", a.checkpoint_every},
                      {"camera", {{"position", a.camera.position}, {"target", a.camera.target}, {"fov", a.camera.fov},
                                  {"resolution", a.camera.resolution}, {"samples", a.camera.samples}}}};
  if (a.formats_given) j["formats"] = a.formats;
  return j.dump();
}

// The run command stored in DIR's checkpoint, to be continued there.
RunArgs args_from_checkpoint(const std::string& dir) {
  const CheckpointFile cp = read_checkpoint(dir);
  const std::string file = (std::filesystem::path(dir) / kCheckpointName).string();
  try {
    const nlohmann::json j = nlohmann::json::parse(cp.header.invocation);
    if (j.contains("batch"))  // a case of a sweep: its scene is the sweep's, not a file
      throw InputError(file, "",
                       "is a case of the sweep " + j["batch"].get<std::string>() +
                           "; resume it with `raycloth batch SWEEP --out DIR` (it continues from this checkpoint)");
    RunArgs a;
    a.scene = j.at("scene").get<std::string>();
    a.device = j.at("device").get<std::string>();
    a.duration = j.at("duration").get<double>();
    // Checkpoints written before these options were added lack them.
    a.integrator = j.value("integrator", std::string());
    if (j.contains("dt") && !j["dt"].is_null()) a.dt = j["dt"].get<double>();
    if (j.contains("iterations") && !j["iterations"].is_null()) a.iterations = j["iterations"].get<int>();
    a.allow_unstable = j.at("allow_unstable_dt").get<bool>();
    a.render = j.at("render").get<bool>();
    a.video = j.at("video").get<bool>();
    a.no_check = j.at("no_check").get<bool>();
    a.checkpoint_every = j.at("checkpoint_every").get<int>();
    const nlohmann::json& c = j.at("camera");
    a.camera = {c.at("position").get<std::string>(), c.at("target").get<std::string>(), c.at("fov").get<std::string>(),
                c.at("resolution").get<std::string>(), c.at("samples").get<std::string>()};
    if (j.contains("formats")) {
      a.formats = j.at("formats").get<std::vector<std::string>>();
      a.formats_given = true;
    }
    a.out = dir;
    a.resume = true;
    return a;
  } catch (const nlohmann::json::exception&) {
    throw InputError(file, "", "does not say how the run was started; resume with `raycloth run ... --resume`");
  }
}
std::string pinch_note(const RunCheck& c) {
  if (c.pinched_frames == 0) return "";
  return fmt::format("; {} frames pinched only (at most {} cloth vertices inside the body where its own gap is below "
                     "twice the thickness, body gap {:.3g} mm at the least); first, frame {}: {}",
                     c.pinched_frames, c.max_vertices_pinched, 1e3 * c.min_pinch_gap, c.first_pinched_frame,
                     c.first_pinch);
}

std::string check_line(const RunCheck& c) {
  if (!c.enabled) return "exact check: off (--no-check)";
  if (c.bad_frames == 0)
    return fmt::format("exact check of all {} frames: 0 cloth edges through cloth, 0 cloth vertices inside obstacles{}",
                       c.frames_checked, pinch_note(c));
  return fmt::format("exact check: {} of {} frames FAIL (at most {} crossings, {} vertices inside); first, frame {}: {}{}",
                     c.bad_frames, c.frames_checked, c.max_crossings, c.max_vertices_inside, c.first_bad_frame,
                     c.first_problem, pinch_note(c));
}

// The scene's time settings as --integrator, --dt and --iterations change them (trying another
// integrator or step on a scene without editing its file), checked as the file's would be.
void apply_time_options(const RunArgs& args, TimeDef& t) {
  if (!args.integrator.empty()) t.integrator = args.integrator == "implicit" ? Integrator::Implicit : Integrator::Explicit;
  if (args.dt) {
    if (!(*args.dt > 0 && std::isfinite(*args.dt)))
      throw InputError("command line", "--dt", fmt::format("must be positive (got {:g})", *args.dt));
    t.dt = *args.dt;
    t.dt_given = true;
    t.max_dt = 0;
  }
  if (args.iterations) {
    if (t.integrator != Integrator::Implicit)
      throw InputError("command line", "--iterations", "applies to the implicit integrator only (add --integrator implicit)");
    if (*args.iterations < 1 || *args.iterations > 1000)
      throw InputError("command line", "--iterations", fmt::format("must be between 1 and 1000 (got {})", *args.iterations));
    t.iterations = *args.iterations;
  }
}

// `raycloth run` (and `raycloth resume`, with the arguments kept in the checkpoint).
int run_command(const RunArgs& args) {
  std::optional<tbb::global_control> threads;
  if (args.threads > 0) threads.emplace(tbb::global_control::max_allowed_parallelism, size_t(args.threads));
  SceneDef scene = args.scene.empty() ? default_scene() : load_scene_file(args.scene);
  apply_time_options(args, scene.time);
  apply_camera_options(args.camera, scene.output);
  const bool video = args.video || scene.output.video;
  const bool render = args.render || scene.output.render || video;
  RunOptions opt;
  opt.out_dir = args.out;
  opt.sim.device = args.device;
  opt.sim.allow_unstable_dt = args.allow_unstable;
  opt.quiet = args.quiet;
  opt.check = !args.no_check;
  opt.checkpoint_every = args.checkpoint_every;
  opt.resume = args.resume;
  if (args.scene.empty()) opt.scene_text = std::string(default_scene_text());
  opt.invocation = invocation_json(args);
  if (args.duration != 0) opt.duration = args.duration;
  if (args.formats_given) {
    OutputDef formats;  // checked alone, as the scene file's output.formats is
    formats.formats = args.formats;
    try {
      validate_output(formats, "command line");
    } catch (const InputError& e) {
      throw InputError(e.file(), "--format", e.reason());
    }
    opt.formats = args.formats;
  }
  if (render) opt.sinks.push_back(std::make_shared<ImageFrames>(scene.output.camera));
  if (!args.quiet) spdlog::info("scene '{}' on {}, output in {}", scene.name, args.device, args.out);
  // A step the mesh cannot take came from --dt where it was given: the message names the option.
  const RunReport r = [&] {
    try {
      return run_scene(scene, opt);
    } catch (const InputError& e) {
      if (args.dt && e.field() == "/time/dt") throw InputError("command line", "--dt", e.reason());
      throw;
    }
  }();
  if (!args.quiet) {
    std::cout << fmt::format(
        "{}: {} steps, {:.3f} s simulated in {:.2f} s: {:.0f} steps/s on {}\n"
        "stages per step: forces+integration {:.3f} ms, update {:.3f} ms, rays {:.3f} ms, response {:.3f} ms, "
        "bound {:.3f} ms (recomputed in {:.1f} % of steps)\n"
        "{}\n"
        "wrote {} frames to {}: {}\n",
        r.scene, r.steps, r.simulated_time, r.wall_time, r.steps_per_second, r.device,
        1e3 * r.stages.integrate / r.steps, 1e3 * r.stages.update / r.steps, 1e3 * r.stages.cast / r.steps,
        1e3 * r.stages.respond / r.steps, 1e3 * r.stages.bound / r.steps,
        r.steps ? 100.0 * double(r.bound_refreshes) / double(r.steps) : 0.0, check_line(r.check), r.frames.size(), args.out,
        fmt::join(r.outputs, ", "));
    if (render) std::cout << fmt::format("wrote {}/images/frame_*.png ({} frames)\n", args.out, r.frames.size());
  }
  const int video_code = video ? assemble_video(args.out, int(r.frames.size()), scene.time.fps, args.quiet) : 0;
  // Penetration is an error, not a note: everything is written, and the exit code says so (1; 3 when
  // the only problems are pinches).
  if (r.check.bad_frames > 0) {
    std::cerr << fmt::format(
        "raycloth: error: {}: the exact check found penetration in {} of {} frames (first, frame {}: {}); the "
        "frames and run.json are written\n",
        args.out, r.check.bad_frames, r.check.frames_checked, r.check.first_bad_frame, r.check.first_problem);
    return 1;
  }
  // Only pinches: not a failure, not clean either; a code of its own.
  if (r.check.pinched_frames > 0) {
    std::cerr << fmt::format(
        "raycloth: pinched: {}: the only problems are pinches, in {} of {} frames (cloth vertices inside the body where "
        "its own surfaces are closer than twice the cloth thickness, body gap {:.3g} mm at the least; first, frame {}: "
        "{}); the frames and run.json are written (exit status 3)\n",
        args.out, r.check.pinched_frames, r.check.frames_checked, 1e3 * r.check.min_pinch_gap,
        r.check.first_pinched_frame, r.check.first_pinch);
    return 3;
  }
  return video_code;
}

}  // namespace

Action add_run_command(CLI::App& app) {
  auto args = std::make_shared<RunArgs>();
  CLI::App* run = app.add_subcommand("run", "Run a scene (default: the paper's experiment, scenes/seed_drape.json)");
  run->add_option("scene", args->scene, "Scene file (JSON); omit for the built-in default scene");
  run->add_option("-o,--out", args->out, "Output folder")->capture_default_str();
  run->add_option("--device", args->device, "cpu, cuda or auto")
      ->check(CLI::IsMember({"cpu", "cuda", "auto"}))
      ->capture_default_str();
  run->add_option("--format", args->formats, "Mesh formats, comma-separated: obj, ply, pc2, glb (overrides the scene; default obj)")
      ->delimiter(',');
  run->add_option("--duration", args->duration, "Simulated seconds (overrides the scene)");
  run->add_option("--integrator", args->integrator, "explicit or implicit (overrides the scene's time.integrator)")
      ->check(CLI::IsMember({"explicit", "implicit"}));
  run->add_option("--dt", args->dt, "Seconds per step (overrides the scene's time.dt)");
  run->add_option("--iterations", args->iterations, "Sweeps per step of the implicit integrator (overrides time.iterations)");
  run->add_option("--threads", args->threads, "Worker threads (default: all cores)");
  run->add_flag("-q,--quiet", args->quiet, "No progress output");
  run->add_flag("--allow-unstable-dt", args->allow_unstable, "Run even when dt >= T0 = pi sqrt(m/K)");
  run->add_flag("--render", args->render, "Ray-trace images/frame_NNNN.png for every frame");
  run->add_flag("--no-check", args->no_check, "Skip the exact penetration check of every frame (run.json's check)");
  run->add_flag("--video", args->video, "Also assemble video.mp4 from the images (needs ffmpeg; implies --render)");
  add_camera_options(run, args->camera);
  run->add_flag("--resume", args->resume,
                "Continue the interrupted run in --out from its checkpoint (same scene and options)");
  run->add_option("--checkpoint-every", args->checkpoint_every,
                  "Write OUT/checkpoint.bin after every N frames (0: never)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  return [run, args] {
    if (!run->parsed()) return 0;
    args->formats_given = run->count("--format") > 0;
    return guarded([&] { return run_command(*args); });
  };
}

Action add_resume_command(CLI::App& app) {
  auto dir = std::make_shared<std::string>();
  auto quiet = std::make_shared<bool>(false);
  auto threads = std::make_shared<int>(0);
  CLI::App* resume = app.add_subcommand("resume", "Continue an interrupted `raycloth run` in DIR from its checkpoint");
  resume->add_option("dir", *dir, "The run's output folder")->required();
  resume->add_flag("-q,--quiet", *quiet, "No progress output");
  resume->add_option("--threads", *threads, "Worker threads (default: all cores)");
  return [resume, dir, quiet, threads] {
    if (!resume->parsed()) return 0;
    return guarded([&] {
      RunArgs a = args_from_checkpoint(*dir);
      a.quiet = *quiet;
      a.threads = *threads;
      return run_command(a);
    });
  };
}

}  // namespace raycloth::cli
