// The cloth model: topology, rest lengths, masses and stiffness, built once from the scene and
// never changed while stepping (the state, positions and velocities, lives apart).
#pragma once
#include <memory>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "raycloth/scene.h"
#include "raycloth/vec3.h"
#include "scene/mesh.h"
#include "scene/skinned_mesh.h"

namespace raycloth {

enum class SpringType : uint8_t { Stretch = 0, Shear = 1, Bend = 2, Seam = 3 };

struct Spring {
  uint32_t a, b;
  float rest, k, damping;
  SpringType type;
  float rest_start = 0;  // length in the placed start state (used while seams close)
  float k_stiff = 0;     // a measured fabric's stretch spring: stiffness added at strain 1/6 (fabric/stiffening.h)
};

// A bending element across an interior edge (v[0], v[1]) of a panel's triangles, v[2] and v[3] the
// corners opposite it: the isometric quadratic bending of Bergou, Wardetzky, Harmon, Zorin and
// Grinspun ("A quadratic bending model for inextensible surfaces", SGP 2006). Its energy is
//   E = 1/2 |sum_j w_j x_j|^2,   w_j = sqrt(B / (A0 + A1)) K_j,
// K the cotangent weights of the rest triangles (K . x = 0 for every flat placement, stretched or
// not: the element pushes nowhere along the sheet), A0 + A1 their rest areas and B the sheet's
// bending rigidity (N m) across the edge. Summed over a mesh, sum |K x|^2 / (A0 + A1) is the
// integral of the squared curvature of a rolled sheet (checked on grids and meshes in
// tests/test_hinge.cpp), so the moment is B kappa at any curvature: a bending force of its own,
// independent of the stretch springs (bend springs pull along the row).
struct Hinge {
  std::array<uint32_t, 4> v{};
  std::array<float, 4> w{};
};

// The floats of one measured fabric's membrane law (sim/membrane.h, fabric::membrane_law): a0 b0
// (warp), a2 b2 (weft), k1 (coupling), a3 b3 (shear), G1 (the Green strain of a pull to 1/6).
inline constexpr uint32_t kMembraneLaw = 8;

struct Piece {
  std::string name;
  uint32_t first_vertex = 0, vertex_count = 0;
  uint32_t resolution_u = 0, resolution_v = 0;  // rectangles (grids) only; 0 for mesh and pattern panels
  uint32_t first_triangle = 0, num_triangles = 0;
  uint32_t num_vertices() const { return vertex_count; }
};

// The model's arrays that the step reads, declared once: ModelView's pointers, make_model_view (the
// CPU's view of a ClothModel and the CUDA backend's copies) come from this list.
// X(type, name in ModelView, ClothModel member)
#define RAYCLOTH_MODEL_ARRAYS(X)                                                                             \
  X(float, inv_mass, inv_mass)               /* 0 for pinned vertices */                                     \
  X(float, damping, damping)                 /* 1/s, per vertex */                                           \
  X(uint32_t, adj_offset, adj_offset)        /* CSR: springs of vertex i are [adj_offset[i], adj_offset[i+1]) */ \
  X(uint32_t, adj_other, adj_other)                                                                          \
  X(float, adj_rest, adj_rest)                                                                               \
  X(float, adj_k, adj_k)                                                                                     \
  X(float, adj_kd, adj_kd)                                                                                   \
  X(float, adj_k_stiff, adj_k_stiff)         /* null unless a measured fabric's springs stiffen (Spring::k_stiff) */ \
  X(float, adj_rest_start, adj_rest_start)   /* null unless seams close over time: rest lengths at the start */ \
  X(uint32_t, alias, alias)                  /* vertices joined by a seam share one alias */                 \
  X(uint32_t, triangles, collision_triangles) /* 3 per collision triangle (corners welded across seams) */   \
  X(uint32_t, tri_alias, tri_alias)          /* alias of each collision-triangle corner */                   \
  X(uint32_t, edges, edges)                  /* 2 per edge of the cloth surface */                           \
  /* Hinge bending (null unless a material bends by hinges): CSR per vertex of its hinge entries */          \
  /* (4 h + the vertex's corner in hinge h); per hinge its 4 corners and their weights (Hinge). */            \
  X(uint32_t, hinge_offset, hinge_offset)                                                                    \
  X(uint32_t, hinge_entry, hinge_entry)                                                                      \
  X(uint32_t, hinge_vertex, hinge_vertex)                                                                    \
  X(float, hinge_weight, hinge_weight)                                                                       \
  /* Membranes (null unless a measured fabric's triangle mesh has them: sim/membrane.h): CSR per */          \
  /* vertex of its entries (3 t + its corner in membrane triangle t); per triangle its 3 corners, */         \
  /* Dm^-1 in the warp and weft frame (4, row-major), rest area and fabric (into membrane_law, */           \
  /* kMembraneLaw floats per fabric). */                                                                     \
  X(uint32_t, membrane_offset, membrane_offset)                                                              \
  X(uint32_t, membrane_entry, membrane_entry)                                                                \
  X(uint32_t, membrane_vertex, membrane_vertex)                                                              \
  X(float, membrane_shape, membrane_shape)                                                                   \
  X(float, membrane_area, membrane_area)                                                                     \
  X(uint32_t, membrane_fabric, membrane_fabric)                                                              \
  X(float, membrane_law, membrane_law)                                                                     \
  /* Per triangle: bit k set when it is the lowest-numbered triangle holding its edge k (corners k, */       \
  /* k+1); bit 3 + k when it is the lowest-numbered one holding corner k. */                                 \
  X(uint8_t, tri_edge_owner, tri_edge_owner)                                                                 \
  /* Per vertex: a collision triangle that does not hold it but holds a vertex it shares an edge with */     \
  /* (the nearest such in the panels' own shapes), or kNoWitness: the bound's look-ahead need look */     \
  /* no farther (sim/bound.h, witness_radius). */                                                            \
  X(uint32_t, bound_witness, bound_witness)                                                                  \
  /* Attachments: per vertex the attachment slot or kNoAttachment (null when there are none); per */         \
  /* slot the obstacle triangle (world numbering), barycentric weights, the start position minus the */     \
  /* body point at t = 0 (eased out while seams close), lift, stiffness, damping. */                         \
  X(uint32_t, attach_slot, attach_slot)                                                                      \
  X(uint32_t, attach_tri, attach_tri)                                                                        \
  X(Vec3, attach_bary, attach_bary)                                                                          \
  X(Vec3, attach_offset, attach_offset)                                                                      \
  X(float, attach_lift, attach_lift)                                                                         \
  X(float, attach_k, attach_k)                                                                               \
  X(float, attach_kd, attach_kd)                                                                             \
  /* The implicit integrator's colouring: the free representative vertices, colour by colour (no two */     \
  /* of a colour share a spring), colour c being color_vertices[color_offset[c], color_offset[c+1]). */      \
  X(uint32_t, color_vertices, color_vertices)

// Plain pointers into a model's arrays (null for an empty one): what the per-vertex functions read,
// on host or device.
struct ModelView {
  uint32_t num_vertices = 0;
  uint32_t num_edges = 0;
  uint32_t num_triangles = 0;              // collision triangles
#define RAYCLOTH_MODEL_POINTER(type, name, member) const type* name = nullptr;
  RAYCLOTH_MODEL_ARRAYS(RAYCLOTH_MODEL_POINTER)
#undef RAYCLOTH_MODEL_POINTER
  const uint32_t* color_offset = nullptr;  // host memory on every backend: the loops' bounds
  uint32_t num_colors = 0;
};

inline constexpr uint32_t kNoAttachment = 0xFFFFFFFFu;
inline constexpr uint32_t kNoWitness = 0xFFFFFFFFu;


struct ClothModel {
  std::vector<Piece> pieces;
  std::vector<Vec3> initial_positions;
  std::vector<float> mass, inv_mass, damping;
  std::vector<Spring> springs;
  std::array<size_t, 4> spring_counts{};  // by SpringType
  std::vector<uint32_t> adj_offset, adj_other;
  std::vector<float> adj_rest, adj_k, adj_kd, adj_rest_start;
  std::vector<float> adj_k_stiff;  // empty unless some spring stiffens
  std::vector<uint32_t> alias;
  // Hinge bending (Hinge), and its per-vertex CSR and flat arrays for the step (build_adjacency).
  std::vector<Hinge> hinges;
  std::vector<uint32_t> hinge_offset, hinge_entry, hinge_vertex;
  std::vector<float> hinge_weight;
  // Membrane triangles (sim/membrane.h): 3 corners, Dm^-1 (4), rest area and fabric each; the fabrics'
  // laws; the per-vertex CSR (build_adjacency).
  std::vector<uint32_t> membrane_vertex, membrane_fabric;
  std::vector<float> membrane_shape, membrane_area, membrane_law;
  std::vector<uint32_t> membrane_offset, membrane_entry;
  uint32_t num_membranes() const { return uint32_t(membrane_area.size()); }
  // Seams sewn from apart: 2 vertices per stitch (each also a Seam spring of rest length 0), and the
  // scene seam each belongs to. Welded seams have none (their pairs share an alias).
  std::vector<uint32_t> stitches, stitch_seam;
  std::vector<Vec3> rest_positions;  // each panel's own shape (a pattern's plane, a mesh's OBJ coordinates)
  float sew_time = 0;                // seconds over which rest lengths go from adj_rest_start to adj_rest
  bool ease_gravity = false;         // gravity eased in (gravity_ease, sim/backend.h; SewingDef::ease_gravity)
  bool gravity_waits = false;        // ... after sew_time, not over it (SewingDef::gravity_waits)
  // Cloth vertices of each scene attachment (before welding), and the resolved attachments.
  std::vector<std::vector<uint32_t>> attachment_vertices;
  std::vector<uint32_t> attach_slot, attach_tri;
  std::vector<Vec3> attach_bary, attach_offset;
  std::vector<float> attach_lift, attach_k, attach_kd;
  std::vector<uint32_t> triangles;            // the cloth surface, 3 per triangle, panel by panel
  // What the rays and the bound see: `triangles` with every corner replaced by its seam
  // representative (welded seams), and those corners' aliases.
  std::vector<uint32_t> collision_triangles, tri_alias;
  // The edges of the welded surface (`collision_triangles`), each once, smaller vertex first.
  std::vector<uint32_t> edges;
  float mean_edge = 0;  // mean length of `edges` at the start (metres): the bound's look-ahead scale
  std::vector<uint8_t> tri_edge_owner;  // see RAYCLOTH_MODEL_ARRAYS
  std::vector<uint32_t> bound_witness;  // see RAYCLOTH_MODEL_ARRAYS
  // The implicit integrator's colouring (see RAYCLOTH_MODEL_ARRAYS; greedy, in vertex order).
  std::vector<uint32_t> color_offset, color_vertices;

  uint32_t num_vertices() const { return uint32_t(initial_positions.size()); }
  uint32_t num_triangles() const { return uint32_t(triangles.size() / 3); }
  uint32_t num_collision_triangles() const { return uint32_t(collision_triangles.size() / 3); }
  uint32_t num_edges() const { return uint32_t(edges.size() / 2); }
  ModelView view() const;
  // Smallest free-vertex mass and largest spring stiffness: the paper's T0 = pi sqrt(m/K).
  float min_mass() const;
  float max_stiffness() const;
  double natural_period() const;
  // The largest stable time step of the explicit (symplectic) Euler step over the whole mesh:
  // omega dt < 2 for its highest frequency, estimated per vertex as omega^2 = K / m with K the sum
  // of the vertex's spring (and attachment) stiffnesses, so dt < 2 sqrt(m / K). Where many springs
  // meet a light vertex (mesh boundaries, small cloths) this is stricter than the paper's T0.
  // Sets *vertex to the vertex that sets it.
  double stability_limit(uint32_t* vertex = nullptr) const;
  // Sum of the stiffnesses of vertex i's springs and attachment: the K of stability_limit.
  double stiffness_sum(uint32_t i) const;
  // The panel that holds vertex i.
  const Piece& piece_of(uint32_t i) const;
};

// The view of m wherever its arrays are: place(array) gives the address of the array's copy in the
// backend's memory (on the CPU the array itself: ClothModel::view), for every array of
// RAYCLOTH_MODEL_ARRAYS that is not empty.
template <class Place>
ModelView make_model_view(const ClothModel& m, Place&& place) {
  ModelView v;
  v.num_vertices = m.num_vertices();
  v.num_edges = m.num_edges();
  v.num_triangles = m.num_collision_triangles();
#define RAYCLOTH_MODEL_PLACE(type, name, member) v.name = m.member.empty() ? nullptr : place(m.member);
  RAYCLOTH_MODEL_ARRAYS(RAYCLOTH_MODEL_PLACE)
#undef RAYCLOTH_MODEL_PLACE
  v.color_offset = m.color_offset.data();
  v.num_colors = m.color_offset.empty() ? 0u : uint32_t(m.color_offset.size() - 1);
  return v;
}

// Obstacles merged into one world-space mesh; moving ones keep their local mesh and motion.
struct ObstacleSet {
  TriMesh world;                       // all obstacles, world space at t = 0
  std::vector<std::string> names;
  std::vector<uint32_t> first_vertex;  // per obstacle, into world.vertices
  std::vector<uint32_t> first_triangle;
  std::vector<TriMesh> local;          // per obstacle, before its transform
  std::vector<ObstacleDef> defs;
  std::vector<std::shared_ptr<const SkinnedMesh>> skinned;  // per obstacle; null unless skinned
  bool any_moving = false;
  // What the step collides with: world.indices, then the caps that close the openings of mesh and
  // skinned obstacles (collide/holes.h; over world.vertices, so they move with the body). Outputs and
  // the exact check use world.indices alone.
  std::vector<uint32_t> collision_indices;
  uint32_t holes_found = 0, holes_capped = 0, cap_triangles = 0;
  // Obstacles moved by hand between steps (Simulator::move_obstacle): per obstacle (empty `to`:
  // none), its vertices go from `from` at t0 to `to` at t1 in a straight line, then stay at `to`.
  struct Scripted {
    double t0 = 0, t1 = 0;
    std::vector<Vec3> from, to;
  };
  std::vector<Scripted> scripted;
  uint32_t num_collision_triangles() const { return uint32_t(collision_indices.size() / 3); }
  // Obstacle oi's triangles in `world`: [first_triangle[oi], end_triangle(oi)).
  uint32_t end_triangle(size_t oi) const {
    return oi + 1 < names.size() ? first_triangle[oi + 1] : uint32_t(world.num_triangles());
  }
  // World-space vertices and per-vertex velocities at simulated time t.
  void pose_at(double t, std::vector<Vec3>& vertices, std::vector<Vec3>& velocities) const;
  // A skinned obstacle's joint matrices at simulated time t with its transform applied (`pose`), and
  // their rate of change per second (`rate`: from the poses 0.5 ms either side, one-sided at t = 0).
  // skin_obstacle_vertex turns them into a vertex's world position and surface velocity.
  void skinned_joints(size_t oi, double t, std::vector<Affine>& pose, std::vector<Affine>& rate) const;
};

// Makes each seam group (vertices sharing model.alias) one simulated vertex: the group meets at the
// centroid of its members' initial_positions, its representative carries the group's mass (pinned if
// any member is) and every spring, and the other members follow it (inv_mass 0, mass 0, copied at
// the end of each step). Collision triangles, their aliases and the edges use representatives. Run
// again after more pairs share an alias (stitches welded once closed, Simulator).
void weld_seams(ClothModel& model);
// Every vertex at the centre of its group's positions in x (the groups: vertices sharing `alias`),
// where weld_seams puts them.
std::vector<Vec3> welded_positions(const std::vector<uint32_t>& alias, const std::vector<Vec3>& x);
// Fills the per-vertex CSR adjacency and the spring counts from model.springs.
void build_adjacency(ClothModel& model);
// Builds the model; throws InputError for seams or pins that do not fit the panels.
ClothModel build_cloth_model(const SceneDef& scene);
ObstacleSet build_obstacles(const SceneDef& scene);
// Binds the scene's attachments to obstacle surface points (the given obstacle vertices, or the
// nearest surface points at t = 0); throws InputError for an unknown obstacle, a bad vertex list or
// a damping the explicit step cannot take (2 m / dt or more on an attached vertex).
void resolve_attachments(ClothModel& model, const ObstacleSet& obstacles, const SceneDef& scene);

}  // namespace raycloth
