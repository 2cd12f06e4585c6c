// Edits of a Simulator between steps: a state set from outside, vertices pinned, obstacles moved by
// hand. The Python module drives a simulation through these.
#include <fmt/format.h>

#include "raycloth/error.h"
#include "raycloth/simulator.h"
#include "sim/backend.h"
#include "sim/model.h"

namespace raycloth {

namespace {

void require_edits(const Backend& backend, const char* what) {
  if (!backend.can_edit())
    throw SimulationError(fmt::format("{}: not supported on the {} backend (use device cpu)", what, backend.name()));
}

void require_finite(const std::vector<Vec3>& a, const std::string& source, const char* field) {
  for (size_t i = 0; i < a.size(); ++i)
    if (!is_finite(a[i]))
      throw InputError(source, fmt::format("{}[{}]", field, i),
                       fmt::format("must be finite (got {:g}, {:g}, {:g})", a[i].x, a[i].y, a[i].z));
}

}  // namespace

void Simulator::set_state(const std::vector<Vec3>& x, const std::vector<Vec3>& v) {
  require_edits(*backend_, "set_state");
  const size_t n = model_->num_vertices();
  for (const auto& [a, field] : {std::pair{&x, "positions"}, std::pair{&v, "velocities"}}) {
    if (a->size() != n)
      throw InputError(scene_.source, field, fmt::format("expected {} cloth vertices (got {})", n, a->size()));
    require_finite(*a, scene_.source, field);
  }
  positions();  // the host copies up to date: they are overwritten in place (views of them stay valid)
  for (size_t i = 0; i < n; ++i) {
    const uint32_t r = model_->alias[i];  // seam partners follow their representative
    x_[i] = x[r];
    v_[i] = v[r];
  }
  backend_->replace_state(x_, v_);
  synced_ = true;
}

void Simulator::pin(const std::vector<uint32_t>& vertices) {
  require_edits(*backend_, "pin");
  const uint32_t n = model_->num_vertices();
  for (uint32_t i : vertices)
    if (i >= n) throw InputError(scene_.source, "pin", fmt::format("vertex {} is not a cloth vertex (there are {})", i, n));
  for (uint32_t i : vertices) model_->inv_mass[model_->alias[i]] = 0.0f;
}

void Simulator::move_obstacle(size_t obstacle, const std::vector<Vec3>& vertices) {
  require_edits(*backend_, "move_obstacle");
  ObstacleSet& o = *obstacles_;
  if (obstacle >= o.defs.size())
    throw InputError(scene_.source, "obstacle",
                     fmt::format("obstacle {} does not exist (the scene has {})", obstacle, o.defs.size()));
  const size_t first = o.first_vertex[obstacle];
  const size_t end = obstacle + 1 < o.first_vertex.size() ? o.first_vertex[obstacle + 1] : o.world.vertices.size();
  const std::string field = "/obstacles/" + std::to_string(obstacle);
  if (vertices.size() != end - first)
    throw InputError(scene_.source, field,
                     fmt::format("obstacle '{}' has {} vertices (got {})", o.names[obstacle], end - first, vertices.size()));
  require_finite(vertices, scene_.source, "vertices");
  std::vector<Vec3> now, velocity;
  o.pose_at(time(), now, velocity);
  o.scripted.resize(o.defs.size());
  ObstacleSet::Scripted& s = o.scripted[obstacle];
  s.from.assign(now.begin() + long(first), now.begin() + long(end));
  s.to = vertices;
  s.t0 = time();
  s.t1 = double(steps_ + 1) * scene_.time.dt;  // the time the backend poses the next step's end at
  o.any_moving = true;
}

}  // namespace raycloth
