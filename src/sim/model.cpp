// The cloth model's own queries (its view for the step, masses, the explicit step's stability limit),
// the seam weld and the per-vertex adjacency with its colouring for the implicit sweeps.
#include "sim/model.h"

#include "sim/integrate/vbd_colors.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <functional>
#include <map>
#include <set>

#include "collide/proximity.h"
#include "collide/rules.h"
#include "raycloth/error.h"
#include "collide/holes.h"
#include "fabric/kes.h"
#include "scene/pattern.h"
#include "scene/transform.h"

namespace raycloth {


std::vector<Vec3> welded_positions(const std::vector<uint32_t>& alias, const std::vector<Vec3>& x) {
  const size_t n = x.size();
  std::vector<Vec3> sum(n, make_vec3(0, 0, 0));
  std::vector<uint32_t> members(n, 0u);
  for (uint32_t i = 0; i < n; ++i) {
    sum[alias[i]] += x[i];
    ++members[alias[i]];
  }
  std::vector<Vec3> p(n);
  for (uint32_t i = 0; i < n; ++i) p[i] = sum[alias[i]] / float(members[alias[i]]);
  return p;
}

namespace {

// CSR of a flat list of element corners (corner k at vertex corner[k]): offset[i] .. offset[i + 1]
// index entry, the corners at vertex i in ascending order. Both empty when there are no corners.
void corners_by_vertex(uint32_t n, const std::vector<uint32_t>& corner, std::vector<uint32_t>& offset,
                       std::vector<uint32_t>& entry) {
  offset.clear(), entry.clear();
  if (corner.empty()) return;
  offset.assign(n + 1, 0);
  for (uint32_t v : corner) ++offset[v + 1];
  for (uint32_t i = 0; i < n; ++i) offset[i + 1] += offset[i];
  entry.resize(offset[n]);
  std::vector<uint32_t> at(offset.begin(), offset.end() - 1);
  for (uint32_t k = 0; k < corner.size(); ++k) entry[at[corner[k]]++] = k;
}

// Each vertex's witness for the bound (RAYCLOTH_MODEL_ARRAYS: bound_witness): of the collision
// triangles that do not hold vertex i but hold a vertex it shares a collision edge with, the nearest
// to it in the panels' own shapes (rest_positions; the start positions where a model has none). The
// bound measures vertex i against it, so i's nearest non-adjacent feature is never farther
// (sim/bound.h, witness_radius); any such triangle would do, the nearest keeps the look-ahead short.
// Rest positions, not the present ones: stitches welded during a run weld again from the start
// positions when the run resumes from a checkpoint (Simulator::restore), and the witnesses must be
// the same both ways.
void find_bound_witnesses(ClothModel& m) {
  const uint32_t n = m.num_vertices();
  const std::vector<uint32_t>& tri = m.collision_triangles;
  std::vector<uint32_t> offset, entry;  // the corners of tri at each vertex
  corners_by_vertex(n, tri, offset, entry);
  if (offset.empty()) offset.assign(n + 1, 0);
  m.bound_witness.assign(n, kNoWitness);
  const std::vector<Vec3>& x = m.rest_positions.size() == n ? m.rest_positions : m.initial_positions;
  for (uint32_t i = 0; i < n; ++i) {
    double best = INFINITY;
    for (uint32_t a = offset[i]; a < offset[i + 1]; ++a)
      for (int k = 0; k < 3; ++k) {
        const uint32_t j = tri[3 * (entry[a] / 3) + k];
        if (j == i) continue;
        for (uint32_t b = offset[j]; b < offset[j + 1]; ++b) {
          const uint32_t t = entry[b] / 3;
          const uint32_t* c = &tri[3 * size_t(t)];
          if (c[0] == i || c[1] == i || c[2] == i) continue;
          const double d2 = closest_on_triangle(dvec(x[i]), dvec(x[c[0]]), dvec(x[c[1]]), dvec(x[c[2]])).dist2;
          if (d2 < best || (d2 == best && t < m.bound_witness[i])) best = d2, m.bound_witness[i] = t;
        }
      }
  }
}

}  // namespace

void weld_seams(ClothModel& m) {
  const uint32_t n = m.num_vertices();
  m.initial_positions = welded_positions(m.alias, m.initial_positions);
  // A pinned partner pins its group. Partners of an earlier weld (this runs again as stitches close)
  // already gave their mass and pin to their representative: mass 0 marks them, and their inverse
  // mass of 0 is no pin.
  for (uint32_t i = 0; i < n; ++i) {
    const uint32_t r = m.alias[i];
    if (r == i) continue;
    if (m.inv_mass[i] == 0.0f && m.mass[i] != 0.0f) m.inv_mass[r] = 0.0f;
    m.mass[r] += m.mass[i];
    m.mass[i] = 0.0f;
    m.inv_mass[i] = 0.0f;
  }
  for (uint32_t i = 0; i < n; ++i)
    if (m.alias[i] == i && m.inv_mass[i] != 0.0f) m.inv_mass[i] = 1.0f / m.mass[i];
  std::vector<Spring> springs;
  springs.reserve(m.springs.size());
  for (Spring sp : m.springs) {
    sp.a = m.alias[sp.a];
    sp.b = m.alias[sp.b];
    if (sp.a != sp.b) springs.push_back(sp);
  }
  m.springs = std::move(springs);
  for (Hinge& h : m.hinges)
    for (uint32_t& v : h.v) v = m.alias[v];
  for (uint32_t& v : m.membrane_vertex) v = m.alias[v];
  m.collision_triangles.resize(m.triangles.size());
  for (size_t k = 0; k < m.triangles.size(); ++k) m.collision_triangles[k] = m.alias[m.triangles[k]];
  m.tri_alias = m.collision_triangles;
  std::vector<std::pair<uint32_t, uint32_t>> e;
  e.reserve(m.triangles.size());
  std::set<std::pair<uint32_t, uint32_t>> seen;
  m.tri_edge_owner.assign(m.num_collision_triangles(), 0);
  for (size_t t = 0; t < m.collision_triangles.size(); t += 3)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = m.collision_triangles[t + k], b = m.collision_triangles[t + (k + 1) % 3];
      e.emplace_back(std::min(a, b), std::max(a, b));
      if (seen.insert(e.back()).second) m.tri_edge_owner[t / 3] |= uint8_t(1u << k);
    }
  // Corner ownership (bits 3..5): the lowest-numbered triangle holding each vertex.
  std::vector<char> has_owner(m.num_vertices(), 0);
  for (size_t t = 0; t < m.collision_triangles.size(); t += 3)
    for (int k = 0; k < 3; ++k) {
      char& owned = has_owner[m.collision_triangles[t + k]];
      if (!owned) owned = 1, m.tri_edge_owner[t / 3] |= uint8_t(1u << (3 + k));
    }
  find_bound_witnesses(m);
  std::sort(e.begin(), e.end());
  e.erase(std::unique(e.begin(), e.end()), e.end());
  m.edges.clear();
  m.edges.reserve(2 * e.size());
  double total = 0;
  for (const auto& [a, b] : e) {
    m.edges.insert(m.edges.end(), {a, b});
    total += double(length(m.initial_positions[a] - m.initial_positions[b]));
  }
  m.mean_edge = e.empty() ? 0.0f : float(total / double(e.size()));
}

ModelView ClothModel::view() const {
  return make_model_view(*this, [](const auto& array) { return array.data(); });
}

float ClothModel::min_mass() const {
  float m = INFINITY;
  for (size_t i = 0; i < mass.size(); ++i)
    if (inv_mass[i] > 0) m = std::min(m, mass[i]);
  return m;
}

float ClothModel::max_stiffness() const {
  float k = 0;
  for (const auto& s : springs) k = std::max(k, s.k + std::max(s.k_stiff, 0.0f));
  for (float a : attach_k) k = std::max(k, a);
  return k;
}

double ClothModel::natural_period() const {
  const double k = max_stiffness();
  return k > 0 ? M_PI * std::sqrt(double(min_mass()) / k) : INFINITY;
}

double ClothModel::stability_limit(uint32_t* vertex) const {
  double best = INFINITY;
  for (uint32_t i = 0; i < num_vertices(); ++i) {
    if (inv_mass[i] == 0.0f) continue;
    const double k = stiffness_sum(i);
    if (k <= 0) continue;
    const double limit = 2.0 * std::sqrt(double(mass[i]) / k);
    if (limit < best) {
      best = limit;
      if (vertex) *vertex = i;
    }
  }
  return best;
}

double ClothModel::stiffness_sum(uint32_t i) const {
  double k = 0;
  for (uint32_t e = adj_offset[i]; e < adj_offset[i + 1]; ++e) k += double(adj_k[e]);
  if (!adj_k_stiff.empty())  // a stiffening spring at its stiffest, or twice that tangent at 1/6
    for (uint32_t e = adj_offset[i]; e < adj_offset[i + 1]; ++e) k += std::max(2.0 * double(adj_k_stiff[e]), 0.0);
  if (!attach_slot.empty() && attach_slot[i] != kNoAttachment) k += double(attach_k[attach_slot[i]]);
  // A membrane triangle's (sim/membrane.h): A |g_c| sum_j |g_j| times its law's stiffest tangent,
  // and half again for the stretch it may reach (the stress grows as F S).
  if (!membrane_offset.empty())
    for (uint32_t e = membrane_offset[i]; e < membrane_offset[i + 1]; ++e) {
      const uint32_t t = membrane_entry[e] / 3, c = membrane_entry[e] % 3;
      const float* d = &membrane_shape[4 * t];
      const double gs[3] = {-d[0] - d[2], d[0], d[2]}, gt[3] = {-d[1] - d[3], d[1], d[3]};
      double row = 0;
      for (int j = 0; j < 3; ++j) row += std::hypot(gs[j], gt[j]);
      const float* law = &membrane_law[kMembraneLaw * membrane_fabric[t]];
      const double kmax = std::max({double(law[0] + 2 * std::max(law[1], 0.0f)), double(law[2] + 2 * std::max(law[3], 0.0f)),
                                    double(law[4]), double(law[5] + 2 * std::max(law[6], 0.0f))});
      k += 1.5 * double(membrane_area[t]) * std::hypot(gs[c], gt[c]) * row * kmax;
    }
  // A hinge's row of the stiffness matrix (w_r w_j, Gershgorin): |w_r| sum_j |w_j|.
  if (!hinge_offset.empty())
    for (uint32_t e = hinge_offset[i]; e < hinge_offset[i + 1]; ++e) {
      const uint32_t h = hinge_entry[e] / 4, r = hinge_entry[e] % 4;
      double row = 0;
      for (uint32_t j = 0; j < 4; ++j) row += std::fabs(double(hinge_weight[4 * h + j]));
      k += std::fabs(double(hinge_weight[4 * h + r])) * row;
    }
  return k;
}

const Piece& ClothModel::piece_of(uint32_t i) const {
  for (const Piece& p : pieces)
    if (i >= p.first_vertex && i < p.first_vertex + p.num_vertices()) return p;
  return pieces.front();
}

// Per-vertex adjacency (CSR) so that forces are gathered, never scattered.
void build_adjacency(ClothModel& model) {
  model.spring_counts = {};
  const uint32_t n = model.num_vertices();
  std::vector<uint32_t> degree(n, 0);
  for (const auto& sp : model.springs) {
    ++degree[sp.a];
    ++degree[sp.b];
    ++model.spring_counts[size_t(sp.type)];
  }
  model.adj_offset.assign(n + 1, 0);
  for (uint32_t i = 0; i < n; ++i) model.adj_offset[i + 1] = model.adj_offset[i] + degree[i];
  const size_t e = model.adj_offset[n];
  model.adj_other.resize(e);
  model.adj_rest.resize(e);
  model.adj_k.resize(e);
  model.adj_kd.resize(e);
  if (model.sew_time > 0) model.adj_rest_start.resize(e);
  else model.adj_rest_start.clear();
  const bool stiffens = std::any_of(model.springs.begin(), model.springs.end(), [](const Spring& sp) { return sp.k_stiff != 0; });
  if (stiffens) model.adj_k_stiff.assign(e, 0.0f);
  else model.adj_k_stiff.clear();
  std::vector<uint32_t> fill(model.adj_offset.begin(), model.adj_offset.end() - 1);
  for (const auto& sp : model.springs) {
    for (int side = 0; side < 2; ++side) {
      const uint32_t self = side ? sp.b : sp.a, other = side ? sp.a : sp.b;
      const uint32_t slot = fill[self]++;
      model.adj_other[slot] = other;
      model.adj_rest[slot] = sp.rest;
      model.adj_k[slot] = sp.k;
      model.adj_kd[slot] = sp.damping;
      if (stiffens) model.adj_k_stiff[slot] = sp.k_stiff;
      if (model.sew_time > 0) model.adj_rest_start[slot] = sp.rest_start;
    }
  }
  // Hinges and membranes: each corner's entry (its index in the flat corner list) under its vertex
  // (corners welded onto one vertex each keep theirs).
  model.hinge_vertex.clear(), model.hinge_weight.clear();
  for (const Hinge& h : model.hinges)
    for (uint32_t r = 0; r < 4; ++r) {
      model.hinge_vertex.push_back(h.v[r]);
      model.hinge_weight.push_back(h.w[r]);
    }
  corners_by_vertex(n, model.hinge_vertex, model.hinge_offset, model.hinge_entry);
  corners_by_vertex(n, model.membrane_vertex, model.membrane_offset, model.membrane_entry);
  color_vertices(model);
}

}  // namespace raycloth
