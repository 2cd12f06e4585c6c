#include "raycloth/simulator.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

#include "sim/model_check.h"
#include "core/bytes.h"
#include "raycloth/error.h"
#include "sim/backend.h"
#include "sim/garment_fit.h"
#include "sim/model.h"

namespace raycloth {

double natural_period(const SceneDef& scene) { return build_cloth_model(scene).natural_period(); }

Simulator::Simulator(const SceneDef& scene, const SimOptions& options) : scene_(scene) {
  validate_scene(scene_);
  model_ = std::make_unique<ClothModel>(build_cloth_model(scene_));
  obstacles_ = std::make_unique<ObstacleSet>(build_obstacles(scene_));
  // Garments named on a body are fitted to it, and their panels moved out of it, before anything
  // reads the start positions.
  for (const PanelFit& f : fit_garments(*model_, *obstacles_, scene_)) panel_moves_.push_back({f.panel, f.moved});
  resolve_attachments(*model_, *obstacles_, scene_);
  // The displacement bound keeps apart what starts apart; it cannot undo a crossing.
  refuse_crossing_start(*model_, scene_.source);
  // Nor can it bring out a vertex that starts inside a body: the exact check would fail every frame.
  refuse_inside_start(*model_, *obstacles_, scene_);

  // The stability limits are the explicit step's; the implicit one is stable at any dt and reports
  // its convergence instead (run.json's "integrator").
  const bool expl = scene_.time.integrator == Integrator::Explicit;
  const double t0 = model_->natural_period();
  if (expl && scene_.time.dt >= t0) {
    const std::string why = fmt::format(
        "time step {:g} s is not below the natural period T0 = pi*sqrt(m/K) = {:g} s (lightest vertex m = {:g} kg, "
        "stiffest spring K = {:g} N/m); lower dt below {:g} s",
        scene_.time.dt, t0, model_->min_mass(), model_->max_stiffness(), t0);
    if (!options.allow_unstable_dt) throw InputError(scene_.source, "/time/dt", why + " or allow it explicitly");
    spdlog::warn("{} (allowed by request)", why);
  }

  uint32_t worst = 0;
  const double limit = model_->stability_limit(&worst);
  if (expl && scene_.time.dt < t0 && scene_.time.dt >= limit) {
    const Piece* piece = &model_->piece_of(worst);
    const double k = model_->stiffness_sum(worst);
    const std::string why = fmt::format(
        "time step {:g} s is not below the mesh's stability limit {:g} s: vertex {} of panel '{}' has mass {:g} kg and "
        "springs summing to K = {:g} N/m, and explicit Euler needs dt < 2 sqrt(m / K); lower dt below {:g} s, or make "
        "the panel's edges longer or its springs softer",
        scene_.time.dt, limit, worst - piece->first_vertex, piece->name, double(model_->mass[worst]), k, limit);
    if (!options.allow_unstable_dt) throw InputError(scene_.source, "/time/dt", why + " or allow it explicitly");
    spdlog::warn("{} (allowed by request)", why);
  }

  // The implicit integrator's long steps are cut where a body moves: the contact that pushes cloth in
  // layers out of a moving body (the response, the two-sided solve and the bound's passes) keeps
  // every vertex out only while a body point moves at most about a millimetre per step (a sphere at
  // 2 m/s through three hanging layers 8 mm apart: clean at 0.6 mm per step, 1 to 2 vertices left
  // inside at 0.8 mm and more, with either integrator), so each step is done in as many substeps as
  // keep the fastest body point within kImplicitMaxBodyMove per substep. The backend steps the
  // substeps; this class counts whole steps.
  step_scene_ = scene_;
  if (!expl && obstacles_->any_moving) {
    const double speed = obstacles_->max_speed(scene_.time.duration, std::min(scene_.time.dt, 1.0 / 120.0));
    substeps_ = int(std::max(1.0, std::ceil(speed * scene_.time.dt / kImplicitMaxBodyMove - 1e-9)));
    step_scene_.time.dt = scene_.time.dt / double(substeps_);
    // A substep's solve starts nearer its answer (k dt^2 / m is substeps^2 times smaller): the sweeps
    // are shared out among the substeps, at least kMinSubstepSweeps each.
    step_scene_.time.iterations =
        std::max(std::min(kMinSubstepSweeps, scene_.time.iterations), (scene_.time.iterations + substeps_ - 1) / substeps_);
    if (substeps_ > 1)
      spdlog::info("implicit integrator: {} substeps of {:g} s per step (the fastest body point moves at {:.3g} m/s)",
                   substeps_, step_scene_.time.dt, speed);
  }
  const BackendInput in{&step_scene_, model_.get(), obstacles_.get()};
  if (options.device == "cpu") {
    backend_ = make_cpu_backend(in);
  } else if (options.device == "cuda") {
    backend_ = make_cuda_backend(in);
  } else if (options.device == "auto") {
    std::string why;
    if (cuda_usable(&why)) {
      backend_ = make_cuda_backend(in);
    } else {
      spdlog::warn("device auto: using the CPU ({})", why);
      backend_ = make_cpu_backend(in);
    }
  } else {
    throw InputError(scene_.source, "device", "unknown device '" + options.device + "' (expected cpu, cuda or auto)");
  }
  x_ = model_->initial_positions;
  v_.assign(x_.size(), make_vec3(0, 0, 0));
}

Simulator::~Simulator() = default;

std::string Simulator::device() const { return backend_->name(); }

void Simulator::step(int n) {
  if (n <= 0) return;
  const uint64_t k = uint64_t(substeps_);
  StepResult r = backend_->step(n * substeps_, steps_ * k, times_);
  if (r.bad_vertex >= 0) r.bad_step /= k;
  synced_ = false;
  last_hits_ = r.hits;
  pushed_total_ += r.pushed;
  clamped_total_ += r.clamped;
  conflicts_total_ += r.conflicts;
  push_clamped_total_ += r.push_clamped;
  refreshes_total_ += r.refreshes;
  partial_refreshes_total_ += r.partial_refreshes;
  contact_pairs_total_ += r.contact_pairs;
  contact_moved_total_ += r.contact_moved;
  contact_rounds_total_ += r.contact_rounds;
  bound_passes_total_ += r.bound_passes;
  unconverged_total_ += r.unconverged;
  max_residual_ = std::max(max_residual_, r.max_residual);
  if (r.bad_vertex >= 0) {
    steps_ = r.bad_step + 1;
    const std::vector<Vec3>& x = positions();
    const uint32_t vi = uint32_t(r.bad_vertex);
    const Piece* piece = &model_->piece_of(vi);
    const uint32_t local = vi - piece->first_vertex;
    const std::string where = piece->resolution_u > 0 ? fmt::format(" (u {}, v {})", local % piece->resolution_u,
                                                                    local / piece->resolution_u)
                                                      : std::string();
    throw SimulationError(fmt::format(
        "the simulation blew up at step {} (t = {:g} s): vertex {} of panel '{}'{} reached ({:g}, {:g}, "
        "{:g}); lower time.dt or the stiffnesses",
        r.bad_step, double(r.bad_step + 1) * scene_.time.dt, local, piece->name, where, x[vi].x, x[vi].y, x[vi].z));
  }
  steps_ += uint64_t(n);
}

bool Simulator::can_checkpoint() const { return backend_->can_checkpoint(); }

bool Simulator::bound_balls(std::vector<Vec3>& centre, std::vector<float>& radius) {
  return backend_->download_balls(centre, radius);
}

void Simulator::save_state(ByteWriter& out) {
  for (uint64_t v : {steps_, last_hits_, pushed_total_, clamped_total_, conflicts_total_, refreshes_total_,
                     partial_refreshes_total_, contact_pairs_total_, contact_moved_total_, contact_rounds_total_,
                     push_clamped_total_, bound_passes_total_, unconverged_total_})
    out.u64(v);
  out.f64(max_residual_);
  out.pod(times_);
  backend_->save(out);
}

void Simulator::restore_state(ByteReader& in) {
  for (uint64_t* v : {&steps_, &last_hits_, &pushed_total_, &clamped_total_, &conflicts_total_, &refreshes_total_,
                      &partial_refreshes_total_, &contact_pairs_total_, &contact_moved_total_, &contact_rounds_total_,
                      &push_clamped_total_, &bound_passes_total_, &unconverged_total_})
    *v = in.u64();
  max_residual_ = in.f64();
  in.pod(times_);
  backend_->restore(in, steps_ * uint64_t(substeps_));
  synced_ = false;
}

const std::vector<Vec3>& Simulator::positions() {
  if (!synced_) {
    backend_->download(x_, v_);
    synced_ = true;
  }
  return x_;
}

const std::vector<Vec3>& Simulator::velocities() {
  positions();
  return v_;
}

std::vector<Vec3> Simulator::obstacle_vertices() const {
  std::vector<Vec3> x, v;
  obstacles_->pose_at(time(), x, v);
  return x;
}

}  // namespace raycloth
