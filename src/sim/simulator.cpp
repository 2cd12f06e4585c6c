#include "raycloth/simulator.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>

#include "check/state_check.h"
#include "io/checkpoint.h"
#include "raycloth/error.h"
#include "sim/backend.h"
#include "sim/model.h"

namespace raycloth {

double natural_period(const SceneDef& scene) { return build_cloth_model(scene).natural_period(); }

Simulator::Simulator(const SceneDef& scene, const SimOptions& options) : scene_(scene) {
  validate_scene(scene_);
  model_ = std::make_unique<ClothModel>(build_cloth_model(scene_));
  obstacles_ = std::make_unique<ObstacleSet>(build_obstacles(scene_));
  resolve_attachments(*model_, *obstacles_, scene_);
  // An attachment's damping is explicit too: past 2 m / dt it overshoots and grows.
  for (size_t k = 0; k < model_->attach_kd.size(); ++k) {
    uint32_t vi = 0;
    while (model_->attach_slot[vi] != uint32_t(k)) ++vi;
    const double limit = 2.0 * double(model_->mass[vi]) / scene_.time.dt;
    if (double(model_->attach_kd[k]) >= limit)
      for (size_t ai = 0; ai < scene_.attachments.size(); ++ai)
        if (scene_.attachments[ai].damping == model_->attach_kd[k])
          throw InputError(scene_.source, "/attachments/" + std::to_string(ai) + "/damping",
                           fmt::format("{:g} N s/m is unstable at dt = {:g} s on an attached vertex of {:g} kg; "
                                       "keep it below 2 m / dt = {:g}",
                                       double(model_->attach_kd[k]), scene_.time.dt, double(model_->mass[vi]), limit));
  }
  // The displacement bound keeps apart what starts apart; it cannot undo a crossing.
  refuse_crossing_start(*model_, scene_.source);

  const double t0 = model_->natural_period();
  if (scene_.time.dt >= t0) {
    const std::string why = fmt::format(
        "time step {:g} s is not below the natural period T0 = pi*sqrt(m/K) = {:g} s (lightest vertex m = {:g} kg, "
        "stiffest spring K = {:g} N/m); lower dt below {:g} s",
        scene_.time.dt, t0, model_->min_mass(), model_->max_stiffness(), t0);
    if (!options.allow_unstable_dt) throw InputError(scene_.source, "/time/dt", why + " or allow it explicitly");
    spdlog::warn("{} (allowed by request)", why);
  }

  uint32_t worst = 0;
  const double limit = model_->stability_limit(&worst);
  if (scene_.time.dt < t0 && scene_.time.dt >= limit) {
    const Piece* piece = &model_->pieces.front();
    for (const auto& p : model_->pieces)
      if (worst >= p.first_vertex && worst < p.first_vertex + p.num_vertices()) piece = &p;
    double k = 0;
    for (uint32_t e = model_->adj_offset[worst]; e < model_->adj_offset[worst + 1]; ++e) k += model_->adj_k[e];
    if (!model_->attach_slot.empty() && model_->attach_slot[worst] != kNoAttachment)
      k += model_->attach_k[model_->attach_slot[worst]];
    const std::string why = fmt::format(
        "time step {:g} s is not below the mesh's stability limit {:g} s: vertex {} of panel '{}' has mass {:g} kg and "
        "springs summing to K = {:g} N/m, and explicit Euler needs dt < 2 sqrt(m / K); lower dt below {:g} s, or make "
        "the panel's edges longer or its springs softer",
        scene_.time.dt, limit, worst - piece->first_vertex, piece->name, double(model_->mass[worst]), k, limit);
    if (!options.allow_unstable_dt) throw InputError(scene_.source, "/time/dt", why + " or allow it explicitly");
    spdlog::warn("{} (allowed by request)", why);
  }

  const BackendInput in{&scene_, model_.get(), obstacles_.get()};
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
  const StepResult r = backend_->step(n, steps_, times_);
  synced_ = false;
  last_hits_ = r.hits;
  pushed_total_ += r.pushed;
  clamped_total_ += r.clamped;
  conflicts_total_ += r.conflicts;
  refreshes_total_ += r.refreshes;
  if (r.bad_vertex >= 0) {
    steps_ = r.bad_step + 1;
    const std::vector<Vec3>& x = positions();
    const uint32_t vi = uint32_t(r.bad_vertex);
    const Piece* piece = &model_->pieces.front();
    for (const auto& p : model_->pieces)
      if (vi >= p.first_vertex && vi < p.first_vertex + p.num_vertices()) piece = &p;
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

void Simulator::save_state(ByteWriter& out) {
  for (uint64_t v : {steps_, last_hits_, pushed_total_, clamped_total_, conflicts_total_, refreshes_total_}) out.u64(v);
  out.pod(times_);
  backend_->save(out);
}

void Simulator::restore_state(ByteReader& in) {
  for (uint64_t* v : {&steps_, &last_hits_, &pushed_total_, &clamped_total_, &conflicts_total_, &refreshes_total_})
    *v = in.u64();
  in.pod(times_);
  backend_->restore(in, steps_);
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
