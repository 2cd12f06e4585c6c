// Sewing patterns in GarmentCode's JSON format (docs/garments.md): every panel becomes a pattern
// panel, every stitch a seam.
//
// The format: `properties.units_in_meter` (100: centimetres), `pattern.panels` by name, each with
// 2D `vertices`, `edges` (`endpoints` [i, j] chained into one closed loop, optional `curvature`) and
// a 3D `translation` and Euler `rotation` (degrees, Rz·Ry·Rx) that place the flat panel (z = 0) in
// GarmentCode's body frame (y up, front +z); `pattern.stitches`, pairs of {panel, edge} with an
// optional third entry "right_wrong". Curvature: {"type": "quadratic", "params": [[u, v]]},
// {"type": "cubic", "params": [[u1, v1], [u2, v2]]}, control points relative to the edge (start +
// u·(end − start) + v·(−dy, dx)), or {"type": "circle", "params": [radius, large_arc, right]}. The
// older files of the same family (Garment-Pattern-Generator templates, units_in_meter 100 or 300)
// write a quadratic edge's curvature as a bare [u, v] list, read as {"type": "quadratic", "params":
// [[u, v]]}. Other fields (parameters, parameter_order, constraints, panel_order, labels) are ignored.
#pragma once
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "raycloth/scene.h"

namespace raycloth {

struct GarmentCodePanelOptions {
  std::optional<std::string> material;
  std::optional<float> edge_length;  // metres
  Float3 offset{0, 0, 0};            // metres, added to the panel's placement in the scene's frame
};

// How a garment enters a scene: every panel is placed by the file's translation and rotation
// (converted to metres and scaled by `scale`), then the whole garment by `rotation` (degrees, X then
// Y then Z) and `position`. Pattern sizes are scaled by `scale` too.
struct GarmentCodeOptions {
  std::string material;
  float edge_length = 0.03f;  // metres
  float scale = 1.0f;
  Float3 position{0, 0, 0};
  Float3 rotation{0, 0, 0};
  std::string prefix;           // put before every panel name
  float seam_stiffness = 200.0f;
  std::map<std::string, GarmentCodePanelOptions> panels;  // by the file's panel name
};

// Panels named prefix + the file's name, in the file's order; segment k of a panel is the file's
// edge k, named "e<k>". Seams pair the stitched edges: by default the first edge's end meets the
// second edge's start (SeamDef::reverse), with "right_wrong" start meets start.
struct GarmentCodeGarment {
  std::vector<PanelDef> panels;
  std::vector<SeamDef> seams;
  std::vector<std::string> file_panel_names;  // the file's names, in the same order
};

// Errors are InputError(file, JSON pointer in the file, reason).
GarmentCodeGarment parse_garmentcode(const std::string& text, const std::string& origin, const GarmentCodeOptions& opt);
GarmentCodeGarment read_garmentcode(const std::string& path, const GarmentCodeOptions& opt);

}  // namespace raycloth
