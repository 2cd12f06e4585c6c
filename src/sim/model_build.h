// Building the cloth model from a scene, in pieces (internal to sim/): each panel meshed
// (panel_mesh.cpp), the seams paired point to point along their paths, each panel's vertices,
// masses and springs (panel_springs.cpp), then the seams joined, the pins and the attachments
// (model_build.cpp).
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "raycloth/scene.h"
#include "sim/model.h"

namespace raycloth {

// One panel's mesh while the model is built: its rest shape (what the springs and masses keep),
// its placed start positions, and its triangles, in panel-local vertex numbers. Seams may add
// vertices on its boundary before the springs are made.
struct PanelMesh {
  bool grid = false;
  uint32_t nu = 0, nv = 0;                       // grid only
  std::vector<Vec3> rest, placed;
  std::vector<uint32_t> tris;                    // 3 per triangle, counter-clockwise from the front
  std::vector<std::string> segment_names;        // pattern only
  std::vector<std::vector<uint32_t>> segments;   // pattern only: outline paths, kept up to date
  std::vector<uint32_t> obj_to_local;            // mesh only: OBJ vertex number -> ours (UINT32_MAX: unused)
  uint32_t size() const { return uint32_t(rest.size()); }
};

// The scene's material and panel by name; InputError at `field` when there is none.
const MaterialDef& find_material(const SceneDef& s, const std::string& name, size_t panel);
size_t find_panel(const SceneDef& s, const std::string& name, const std::string& field);

// Every panel's mesh, in the scene's order.
std::vector<PanelMesh> mesh_panels(const SceneDef& s);
// The vertices along an edge reference (a rectangle's edge, a pattern's segment or a mesh's path),
// panel-local.
std::vector<uint32_t> panel_path(const SceneDef& s, const PanelDef& pd, const PanelMesh& pm, const EdgeRef& ref,
                                 const std::string& field);

// The seams' point pairs: for each, (panel, panel-local vertex) on either side, and its seam.
struct SeamPairs {
  std::vector<std::array<std::pair<size_t, uint32_t>, 2>> pairs;
  std::vector<uint32_t> seam;
};
// Pairs each seam's two paths vertex to vertex (by arc length when their counts differ, adding
// vertices to pattern and mesh panels).
SeamPairs pair_seams(const SceneDef& s, std::vector<PanelMesh>& meshes);

// Appends panel pi's vertices, masses, triangles and springs to the model, and its Piece.
void add_panel(ClothModel& m, const SceneDef& s, size_t pi, const PanelMesh& pm);

}  // namespace raycloth
