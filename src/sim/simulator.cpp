#include "raycloth/simulator.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

#include "sim/model_check.h"
#include "core/bytes.h"
#include "raycloth/error.h"
#include "sim/backend.h"
#include "sim/body_reach.h"
#include "sim/garment_fit.h"
#include "sim/model.h"
#include "sim/seams.h"

namespace raycloth {

double natural_period(const SceneDef& scene) { return build_cloth_model(scene).natural_period(); }

Simulator::Simulator(const SceneDef& scene, const SimOptions& options)
    : scene_(scene), take_steps_again_(options.take_steps_again) {
  validate_scene(scene_);
  model_ = std::make_unique<ClothModel>(build_cloth_model(scene_));
  obstacles_ = std::make_unique<ObstacleSet>(build_obstacles(scene_));
  // Garments named on a body are fitted to it, and their panels moved out of it, before anything
  // reads the start positions.
  for (const PanelFit& f : fit_garments(*model_, *obstacles_, scene_)) panel_moves_.push_back({f.panel, f.moved, f.wrapped, f.stretched});
  resolve_attachments(*model_, *obstacles_, scene_);
  // The displacement bound keeps apart what starts apart; it cannot undo a crossing.
  refuse_crossing_start(*model_, scene_.source);
  // Nor can it bring out a vertex that starts inside a body: the exact check would fail every frame.
  refuse_inside_start(*model_, *obstacles_, scene_);

  // The stability limits are the explicit step's; the implicit one is stable at any dt and reports
  // its convergence instead (run.json's "integrator").
  const bool expl = scene_.time.integrator == Integrator::Explicit;
  const double t0 = model_->natural_period();
  if (expl && !scene_.time.dt_given) choose_dt(t0);
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
  // keep every body point within reach of the cloth in that step within kImplicitMaxBodyMove per
  // substep (substeps_now), 1 mm at first and less where a step is taken again (advance). The backend
  // steps the substeps; this class counts whole steps.
  if (!expl && obstacles_->any_moving)
    reach_ = std::make_unique<BodyReach>(*model_, *obstacles_, scene_.collision.thickness + scene_.collision.tolerance);
  const BackendInput in{&scene_, model_.get(), obstacles_.get(), {}};
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
  // Stitches are welded as they close: every kWeldCheckTime of simulated time, each stitch within
  // the close tolerance becomes one vertex (a pair welded as soon as it arrives cannot overshoot
  // its partner through the triangles beside it).
  if (!model_->stitches.empty()) {
    weld_from_ = 0;
    weld_every_ = uint64_t(std::max(1.0, std::round(kWeldCheckTime / scene_.time.dt)));
  }
}

// The backend again, over the model as it is now, from the state (x_, v_): a backend that takes
// edits keeps the velocities; another starts from the model's start positions at rest.
void Simulator::rebuild_backend() {
  const BackendInput in{&scene_, model_.get(), obstacles_.get(), {}, time()};
  const bool cuda = backend_->name() == "cuda";
  backend_.reset();
  backend_ = cuda ? make_cuda_backend(in) : make_cpu_backend(in);
  if (backend_->can_edit()) backend_->replace_state(x_, v_);
  else v_.assign(v_.size(), make_vec3(0, 0, 0));
  synced_ = true;
}

namespace {

// Edges through triangles in the cloth welded as `alias` says, every group at the centre of its
// members' positions in x (where weld_seams would put it).
size_t welded_crossings(const ClothModel& m, const std::vector<uint32_t>& alias, const std::vector<Vec3>& x) {
  CheckMesh mesh = cloth_check_mesh(m, welded_positions(alias, x));
  for (size_t k = 0; k < m.triangles.size(); ++k) mesh.triangles[k] = alias[m.triangles[k]];
  CheckReport r;
  check_cloth_crossings(mesh, r);
  return r.crossings;
}

// The centres of the groups of `alias` that differ from the model's (welded by it), as a check mesh
// of points (one degenerate triangle each), and whether any lies strictly inside an obstacle posed as
// `body` has it: a weld of two sides on either side of a limb must wait.
bool welded_inside(const ClothModel& m, const CheckMesh& body, const std::vector<uint32_t>& alias,
                   const std::vector<Vec3>& x) {
  if (body.num_triangles() == 0) return false;
  const std::vector<Vec3> p = welded_positions(alias, x);
  std::vector<char> changed(x.size(), 0);
  for (uint32_t i = 0; i < x.size(); ++i)
    if (alias[i] != m.alias[i]) changed[alias[i]] = 1;
  CheckMesh points;
  for (uint32_t r = 0; r < x.size(); ++r) {
    if (!changed[r]) continue;
    const uint32_t k = uint32_t(points.vertices.size());
    points.vertices.push_back(p[r]);
    points.triangles.insert(points.triangles.end(), {k, k, k});
  }
  return !points.vertices.empty() && !find_vertices_inside(points, body).empty();
}

}  // namespace

// Joins every open stitch whose two vertices are within the close tolerance, and every open stitch
// between two welded stitches of its seam no wider than they are apart, into one vertex (the
// group's centroid, its mass-weighted velocity): the model is welded again (sim/model.h,
// weld_seams) and the backend rebuilt from the current state. Returns how many were welded.
size_t Simulator::weld_closed_stitches() {
  ClothModel& m = *model_;
  positions();
  const float tol = seam_close_tolerance(scene_);
  std::vector<uint32_t>& alias = m.alias;
  const std::vector<uint32_t> old_alias = alias;
  const size_t count = m.stitch_seam.size();
  auto side = [&](const std::vector<uint32_t>& a, size_t k, int s) { return a[m.stitches[2 * k + size_t(s)]]; };
  auto join = [&](std::vector<uint32_t>& a, size_t k) {  // false when its sides are one vertex already
    const uint32_t ra = side(a, k, 0), rb = side(a, k, 1);
    if (ra == rb) return false;
    const uint32_t lo = std::min(ra, rb), hi = std::max(ra, rb);
    for (uint32_t& r : a)
      if (r == hi) r = lo;
    return true;
  };
  std::vector<uint32_t> trial = alias;
  std::vector<size_t> chosen;
  for (size_t k = 0; k < count; ++k) {
    if (length(x_[side(trial, k, 0)] - x_[side(trial, k, 1)]) > tol) continue;
    if (join(trial, k)) chosen.push_back(k);
  }
  // Stitches still open between two welded stitches of their seam (a run of them, its neighbours on
  // both ends welded) are welded too, each when it is no wider than those two are apart: their sides
  // are held at both ends, and where they lie crossed (each side's edge to a welded neighbour crossing
  // the other's) the bound lets them touch but never pass, so they would freeze there, touching, for
  // the rest of the run (the pencil dress's skirt: four vertices, one stitch; the gathered cuff of
  // rand_1KMN65OI4O: four stitches, 6 cm open).
  auto joined = [&](size_t k) { return side(trial, k, 0) == side(trial, k, 1); };
  for (size_t k = 1; k + 1 < count; ++k) {
    if (m.stitch_seam[k - 1] != m.stitch_seam[k] || joined(k) || !joined(k - 1)) continue;
    size_t end = k;  // the run k .. end - 1, open; end its welded neighbour
    while (end < count && m.stitch_seam[end] == m.stitch_seam[k] && !joined(end)) ++end;
    if (end == count || m.stitch_seam[end] != m.stitch_seam[k]) continue;
    const float span = length(x_[side(trial, k - 1, 0)] - x_[side(trial, end, 0)]);
    for (size_t j = k; j < end; ++j)
      if (length(x_[side(trial, j, 0)] - x_[side(trial, j, 1)]) <= span && join(trial, j)) chosen.push_back(j);
    k = end;
  }
  if (chosen.empty()) return 0;
  // A weld moves both sides to their centre, a jump that nothing bounded: it must not put a cloth edge
  // through a cloth triangle (the standing-lapel top: 3 to 21 edges through cloth from the weld at
  // 0.47 s on). When the welds together would, each is tried in turn and kept only if it adds none;
  // one put off is tried again at the next check, nearer.
  // Nor may it put the welded vertex inside the body (two sides on either side of a wrist).
  size_t welded = chosen.size();
  const size_t before = welded_crossings(m, alias, x_);
  std::vector<Vec3> posed, velocities;
  obstacles_->pose_at(time(), posed, velocities);
  const CheckMesh body = obstacle_check_mesh(*obstacles_, posed);
  auto fine = [&](const std::vector<uint32_t>& a) {
    return welded_crossings(m, a, x_) <= before && !welded_inside(m, body, a, x_);
  };
  if (!fine(trial)) {
    trial = alias;
    welded = 0;
    for (size_t k : chosen) {
      std::vector<uint32_t> next = trial;
      if (!join(next, k)) continue;  // joined already through the welds kept before it
      if (!fine(next)) {
        ++welds_put_off_;
        continue;
      }
      trial = std::move(next);
      ++welded;
    }
    if (welded == 0) return 0;
  }
  alias = std::move(trial);
  // The groups' velocities, mass-weighted over the old representatives.
  std::vector<Vec3> momentum(x_.size(), make_vec3(0, 0, 0));
  std::vector<float> group_mass(x_.size(), 0.0f);
  for (uint32_t i = 0; i < x_.size(); ++i)
    if (old_alias[i] == i) {
      momentum[alias[i]] += v_[i] * m.mass[i];
      group_mass[alias[i]] += m.mass[i];
    }
  m.initial_positions = x_;
  weld_seams(m);
  build_adjacency(m);
  for (uint32_t i = 0; i < x_.size(); ++i) {
    const uint32_t r = alias[i];
    x_[i] = m.initial_positions[i];
    v_[i] = group_mass[r] > 0 ? momentum[r] / group_mass[r] : v_[r];
  }
  stitches_welded_ += welded;
  rebuild_backend();
  return welded;
}

Simulator::~Simulator() = default;

std::string Simulator::device() const { return backend_->name(); }

void Simulator::step(int n) {
  while (n > 0) {
    int chunk = n;
    const bool open = !model_->stitches.empty() && stitches_welded_ < model_->stitch_seam.size();
    if (open) {  // stop at the next weld check
      const uint64_t next = steps_ < weld_from_ ? weld_from_ : steps_ + weld_every_ - (steps_ - weld_from_) % weld_every_;
      chunk = int(std::min<uint64_t>(uint64_t(n), next - steps_));
    }
    advance(chunk);
    n -= chunk;
    if (open && steps_ >= weld_from_ && (steps_ - weld_from_) % weld_every_ == 0) weld_closed_stitches();
  }
}

void Simulator::advance(int n) {
  if (n <= 0) return;
  if (!reach_) {
    take(backend_->step(n, steps_, times_), n);
    return;
  }
  // Step by step, each cut into its own substeps, the sweeps shared out among them: a substep's
  // solve starts nearer its answer (k dt^2 / m is substeps^2 times smaller), at least
  // kMinSubstepSweeps each. A step is taken again from the same state (Backend::keep, back) with
  // half as much body motion a substep when its substeps let a vertex into a body it was not inside
  // of (entered_obstacles: stage_entered) or blew up, or when at the first try's length the bound
  // shortened a body's push (kImplicitPushLevel); down to kImplicitRetries halvings, and only where
  // the finer length makes more substeps. The steps after a retry start at its length, and go back
  // up one level after kImplicitRetryHold steps taken at once.
  const bool can_retry = take_steps_again_ && backend_->can_go_back();
  for (int k = 0; k < n; ++k) {
    if (can_retry) backend_->keep();
    int level = retry_level_;
    int sub = substeps_now(kImplicitMaxBodyMove / double(1 << level));
    for (;;) {
      const int sweeps =
          std::max(std::min(kMinSubstepSweeps, scene_.time.iterations), (scene_.time.iterations + sub - 1) / sub);
      backend_->set_clock(StepClock{0, time(), {scene_.time.dt / double(sub), sweeps, sub}});
      StepResult r = backend_->step(sub, 0, times_);
      // Taken again: a vertex entered a body or the step blew up; or, at the first try's length, the
      // bound shortened a body's push (cloth caught between the body and other cloth: kImplicitPushLevel).
      const bool entered = r.totals.entered > 0 || r.bad_vertex >= 0;
      const bool shortened = level < kImplicitPushLevel && r.totals.push_clamped > 0;
      if ((entered || shortened) && can_retry && level < kImplicitRetries) {
        const int finer = substeps_now(kImplicitMaxBodyMove / double(1 << (level + 1)));
        if (finer > sub) {  // else the body moves too little for more substeps to change the step
          backend_->back();
          ++totals_.retried;
          retry_level_ = ++level;
          retry_clean_ = 0;
          sub = finer;
          continue;
        }
      }
      r.totals.max_substeps = uint64_t(sub);
      if (r.bad_vertex >= 0) r.bad_step = steps_;
      take(r, 1);
      break;
    }
    if (retry_level_ > 0 && ++retry_clean_ >= kImplicitRetryHold) {
      --retry_level_;
      retry_clean_ = 0;
    }
  }
}

// The substeps of the next step: as many as keep the longest way of a body point within reach of the
// cloth over it (BodyReach) within `most` metres each.
int Simulator::substeps_now(double most) {
  const double g = std::sqrt(double(scene_.gravity[0]) * scene_.gravity[0] + double(scene_.gravity[1]) * scene_.gravity[1] +
                             double(scene_.gravity[2]) * scene_.gravity[2]);
  // The cloth from the backend only where a body moves farther than one substep allows.
  auto cloth = [this](const std::vector<Vec3>*& x, const std::vector<Vec3>*& v) {
    x = &positions();
    v = &velocities();
  };
  const double way = reach_->way_near_cloth(cloth, time(), scene_.time.dt, g, most);
  return int(std::max(1.0, std::ceil(way / most - 1e-9)));
}

// What n steps the backend took left: the totals, and on a blow-up (r.bad_step, a scene step) the
// error naming the vertex.
void Simulator::take(const StepResult& r, int n) {
  synced_ = false;
  last_hits_ = r.hits;
  totals_.add(r.totals);
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

// A scene file without dt: its dt (the default, or max_dt) where the explicit step can take it, else
// the largest step of two significant digits below 0.9 of the mesh's limit (the smaller of T0 and the
// per-vertex limit; ClothModel::stability_limit).
void Simulator::choose_dt(double t0) {
  uint32_t worst = 0;
  const double limit = std::min(t0, model_->stability_limit(&worst));
  const double want = scene_.time.dt;
  if (want < limit) return;
  const double target = 0.9 * limit;
  const double unit = std::pow(10.0, std::floor(std::log10(target)) - 1.0);
  scene_.time.dt = std::floor(target / unit) * unit;
  dt_from_mesh_ = true;
  const Piece& piece = model_->piece_of(worst);
  spdlog::info("time.dt {:g} s, chosen from the mesh: {:g} s is not below the explicit step's limit {:g} s (vertex {} of "
               "panel '{}')",
               scene_.time.dt, want, limit, worst - piece.first_vertex, piece.name);
}

bool Simulator::can_checkpoint() const { return backend_->can_checkpoint(); }

bool Simulator::bound_balls(std::vector<Vec3>& centre, std::vector<float>& radius,
                            std::vector<std::vector<Vec3>>* planes) {
  return backend_->download_balls(centre, radius, planes);
}

void Simulator::save_state(ByteWriter& out) {
  out.u64(steps_);
  out.u64(last_hits_);
  out.pod(totals_);
  out.pod(times_);
  // Which stitches have been welded (the model's seam groups now), and what the welds made of the
  // model: its start positions (the positions at the last weld), masses (summed weld by weld) and so
  // its mean edge length, which welding the pattern's start positions in one go would not give.
  out.u64(stitches_welded_);
  out.u64(welds_put_off_);
  out.u64(uint64_t(retry_level_));
  out.u64(uint64_t(retry_clean_));
  out.vec(model_->alias);
  out.vec(model_->initial_positions);
  out.vec(model_->mass);
  out.vec(model_->inv_mass);
  out.pod(model_->mean_edge);
  backend_->save(out);
}

void Simulator::restore_state(ByteReader& in) {
  steps_ = in.u64();
  last_hits_ = in.u64();
  in.pod(totals_);
  in.pod(times_);
  const uint64_t welded = in.u64();
  welds_put_off_ = in.u64();
  retry_level_ = int(std::min<uint64_t>(in.u64(), uint64_t(kImplicitRetries)));
  retry_clean_ = int(std::min<uint64_t>(in.u64(), uint64_t(kImplicitRetryHold)));
  const size_t n = model_->num_vertices();
  std::vector<uint32_t> alias;
  std::vector<Vec3> start;
  std::vector<float> mass, inv_mass;
  in.vec(alias, n, "seam groups");
  in.vec(start, n, "start positions");
  in.vec(mass, n, "masses");
  in.vec(inv_mass, n, "inverse masses");
  float mean_edge = 0;
  in.pod(mean_edge);
  if (alias != model_->alias) {
    // As the welds left the model: weld_seams then adds nothing to the groups' masses (the partners'
    // are 0), and its start positions and mean edge are put back as they were (averaging a group
    // again could round them).
    model_->alias = alias;
    model_->mass = std::move(mass);
    model_->inv_mass = std::move(inv_mass);
    weld_seams(*model_);
    model_->initial_positions = std::move(start);
    model_->mean_edge = mean_edge;
    build_adjacency(*model_);
    x_ = model_->initial_positions;
    v_.assign(x_.size(), make_vec3(0, 0, 0));
    rebuild_backend();
  }
  stitches_welded_ = welded;
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
