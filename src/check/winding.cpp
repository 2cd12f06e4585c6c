#include "check/winding.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <unordered_map>

namespace raycloth {

namespace {

constexpr uint32_t kLeafTriangles = 8;

WPoint wpoint(const Vec3& v) { return WPoint{double(v.x), double(v.y), double(v.z)}; }

// The position's bits as a key: vertices at the same position are one vertex of the boundaries.
struct PositionKey {
  uint32_t b[3];
  bool operator==(const PositionKey& o) const { return b[0] == o.b[0] && b[1] == o.b[1] && b[2] == o.b[2]; }
};
struct PositionHash {
  size_t operator()(const PositionKey& k) const {
    return (size_t(k.b[0]) * 73856093u) ^ (size_t(k.b[1]) * 19349663u) ^ (size_t(k.b[2]) * 83492791u);
  }
};
PositionKey key_of(const Vec3& v) {
  PositionKey k;
  std::memcpy(&k.b[0], &v.x, 4);
  std::memcpy(&k.b[1], &v.y, 4);
  std::memcpy(&k.b[2], &v.z, 4);
  // -0 and +0 are one position.
  for (uint32_t& b : k.b)
    if (b == 0x80000000u) b = 0u;
  return k;
}

// Reduces directed edges to the boundary: each undirected edge used n times one way and m times the
// other appears |n - m| times, in the direction used more.
void reduce_edges(std::vector<std::array<uint32_t, 2>>& edges) {
  std::vector<std::pair<uint64_t, int>> signed_edges;
  signed_edges.reserve(edges.size());
  for (const auto& e : edges) {
    if (e[0] == e[1]) continue;  // a degenerate triangle's: no solid angle
    const bool forward = e[0] < e[1];
    const uint64_t key = forward ? (uint64_t(e[0]) << 32 | e[1]) : (uint64_t(e[1]) << 32 | e[0]);
    signed_edges.push_back({key, forward ? 1 : -1});
  }
  std::sort(signed_edges.begin(), signed_edges.end());
  edges.clear();
  for (size_t k = 0; k < signed_edges.size();) {
    const uint64_t key = signed_edges[k].first;
    int count = 0;
    for (; k < signed_edges.size() && signed_edges[k].first == key; ++k) count += signed_edges[k].second;
    const uint32_t lo = uint32_t(key >> 32), hi = uint32_t(key & 0xFFFFFFFFu);
    for (int c = 0; c < std::abs(count); ++c) edges.push_back(count > 0 ? std::array<uint32_t, 2>{lo, hi} : std::array<uint32_t, 2>{hi, lo});
  }
}

}  // namespace

double solid_angle(const WPoint& p, const WPoint& a, const WPoint& b, const WPoint& c) {
  double v[3][3], len[3];
  const WPoint* q[3] = {&a, &b, &c};
  for (int k = 0; k < 3; ++k) {
    for (int d = 0; d < 3; ++d) v[k][d] = (*q[k])[d] - p[d];
    len[k] = std::sqrt(v[k][0] * v[k][0] + v[k][1] * v[k][1] + v[k][2] * v[k][2]);
  }
  auto dot = [&](int i, int j) { return v[i][0] * v[j][0] + v[i][1] * v[j][1] + v[i][2] * v[j][2]; };
  const double det = v[0][0] * (v[1][1] * v[2][2] - v[1][2] * v[2][1]) - v[0][1] * (v[1][0] * v[2][2] - v[1][2] * v[2][0]) +
                     v[0][2] * (v[1][0] * v[2][1] - v[1][1] * v[2][0]);
  const double den = len[0] * len[1] * len[2] + dot(0, 1) * len[2] + dot(1, 2) * len[0] + dot(2, 0) * len[1];
  return 2.0 * std::atan2(det, den);
}

double winding_number_direct(const std::vector<Vec3>& vertices, const std::vector<uint32_t>& triangles, uint32_t first,
                             uint32_t last, const WPoint& p) {
  double sum = 0;
  for (uint32_t t = first; t < last; ++t)
    sum += solid_angle(p, wpoint(vertices[triangles[3 * t]]), wpoint(vertices[triangles[3 * t + 1]]),
                       wpoint(vertices[triangles[3 * t + 2]]));
  return sum / (4.0 * M_PI);
}

WindingTree::WindingTree(const std::vector<Vec3>& vertices, const std::vector<uint32_t>& triangles, uint32_t first,
                         uint32_t last) {
  if (first >= last) return;
  std::unordered_map<PositionKey, uint32_t, PositionHash> merged;
  std::vector<uint32_t> id(size_t(last - first) * 3);
  std::vector<WPoint> centroid(last - first);
  for (uint32_t t = first; t < last; ++t) {
    WPoint c{0, 0, 0};
    for (int k = 0; k < 3; ++k) {
      const Vec3& v = vertices[triangles[3 * t + k]];
      const auto [it, added] = merged.try_emplace(key_of(v), uint32_t(points_.size()));
      if (added) points_.push_back(wpoint(v));
      id[3 * (t - first) + k] = it->second;
      for (int d = 0; d < 3; ++d) c[d] += points_[it->second][d] / 3.0;
    }
    centroid[t - first] = c;
  }
  std::vector<uint32_t> order(last - first);
  for (uint32_t k = 0; k < order.size(); ++k) order[k] = k;
  std::vector<std::array<uint32_t, 3>> tri_ids(order.size());  // merged vertex ids of tris_
  tris_.resize(order.size());
  // The tree over `order`, then the triangles in its order.
  nodes_.reserve(2 * order.size() / kLeafTriangles + 2);
  nodes_.emplace_back();
  struct Task {
    uint32_t node, begin, end;
  };
  std::vector<Task> stack{{0, 0, uint32_t(order.size())}};
  while (!stack.empty()) {
    const Task task = stack.back();
    stack.pop_back();
    Node& node = nodes_[task.node];
    node.tri_begin = task.begin, node.tri_end = task.end;
    WPoint lo{HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    WPoint clo = lo, chi = hi;
    for (uint32_t k = task.begin; k < task.end; ++k) {
      for (int c = 0; c < 3; ++c)
        for (int d = 0; d < 3; ++d) {
          const double x = points_[id[3 * order[k] + c]][d];
          lo[d] = std::min(lo[d], x), hi[d] = std::max(hi[d], x);
        }
      for (int d = 0; d < 3; ++d) clo[d] = std::min(clo[d], centroid[order[k]][d]), chi[d] = std::max(chi[d], centroid[order[k]][d]);
    }
    node.lo = lo, node.hi = hi;
    for (int d = 0; d < 3; ++d) node.centre[d] = 0.5 * (lo[d] + hi[d]);
    if (task.end - task.begin <= kLeafTriangles) continue;
    int axis = 0;
    for (int d = 1; d < 3; ++d)
      if (chi[d] - clo[d] > chi[axis] - clo[axis]) axis = d;
    const uint32_t mid = task.begin + (task.end - task.begin) / 2;
    std::nth_element(order.begin() + task.begin, order.begin() + mid, order.begin() + task.end,
                     [&](uint32_t a, uint32_t b) { return centroid[a][axis] < centroid[b][axis]; });
    const uint32_t child = uint32_t(nodes_.size());
    nodes_[task.node].child = child;
    nodes_.emplace_back();
    nodes_.emplace_back();
    stack.push_back({child, task.begin, mid});
    stack.push_back({child + 1, mid, task.end});
  }
  for (uint32_t k = 0; k < order.size(); ++k) {
    for (int c = 0; c < 3; ++c) {
      tri_ids[k][c] = id[3 * order[k] + c];
      tris_[k][c] = points_[tri_ids[k][c]];
    }
  }
  // The boundaries, children before parents (a child's index is always above its parent's); each
  // node keeps its own where it is shorter than its triangle list.
  std::vector<std::vector<std::array<uint32_t, 2>>> boundary(nodes_.size());
  for (size_t n = nodes_.size(); n-- > 0;) {
    Node& node = nodes_[n];
    std::vector<std::array<uint32_t, 2>>& b = boundary[n];
    if (node.child == 0) {
      for (uint32_t k = node.tri_begin; k < node.tri_end; ++k)
        for (int c = 0; c < 3; ++c) b.push_back({tri_ids[k][c], tri_ids[k][(c + 1) % 3]});
    } else {
      for (uint32_t c = node.child; c < node.child + 2; ++c) {
        b.insert(b.end(), boundary[c].begin(), boundary[c].end());
        std::vector<std::array<uint32_t, 2>>().swap(boundary[c]);
      }
    }
    reduce_edges(b);
    node.closure = b.size() < node.tri_end - node.tri_begin;
    if (!node.closure) continue;
    node.edge_begin = uint32_t(edges_.size());
    edges_.insert(edges_.end(), b.begin(), b.end());
    node.edge_end = uint32_t(edges_.size());
  }
}

// f(a, b, c) for every triangle whose solid angle the winding number around p sums.
template <class F>
void WindingTree::visit(const WPoint& p, F&& f) const {
  if (nodes_.empty()) return;
  uint32_t stack[64];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    const bool outside = p[0] < node.lo[0] || p[0] > node.hi[0] || p[1] < node.lo[1] || p[1] > node.hi[1] ||
                         p[2] < node.lo[2] || p[2] > node.hi[2];
    if (outside && node.closure) {
      for (uint32_t e = node.edge_begin; e < node.edge_end; ++e) f(node.centre, points_[edges_[e][0]], points_[edges_[e][1]]);
    } else if (node.child == 0 || top + 2 > 64) {
      for (uint32_t k = node.tri_begin; k < node.tri_end; ++k) f(tris_[k][0], tris_[k][1], tris_[k][2]);
    } else {
      stack[top++] = node.child;
      stack[top++] = node.child + 1;
    }
  }
}

double WindingTree::operator()(const WPoint& p) const {
  double sum = 0;
  visit(p, [&](const WPoint& a, const WPoint& b, const WPoint& c) { sum += solid_angle(p, a, b, c); });
  return sum / (4.0 * M_PI);
}

size_t WindingTree::terms(const WPoint& p) const {
  size_t n = 0;
  visit(p, [&](const WPoint&, const WPoint&, const WPoint&) { ++n; });
  return n;
}

}  // namespace raycloth
