// The implicit integrator's colouring of the model (vbd_colors.h).
#include "sim/integrate/vbd_colors.h"

#include <algorithm>
#include <string>
#include <vector>

#include "raycloth/error.h"
#include "sim/integrate/vbd.h"

namespace raycloth {

void throw_too_many_colors(uint32_t colors) {
  throw SimulationError("the implicit integrator's colouring of this cloth needs " + std::to_string(colors) +
                        " colours; its sweeps take at most " + std::to_string(kMaxSweepColors) +
                        " (a vertex with that many springs, hinges or membranes to others)");
}

void color_vertices(ClothModel& m) {
  const uint32_t n = m.num_vertices();
  std::vector<uint32_t> color(n, 0xFFFFFFFFu);
  std::vector<uint32_t> used;
  uint32_t colors = 0;
  for (uint32_t i = 0; i < n; ++i) {
    if (!m.alias.empty() && m.alias[i] != i) continue;
    used.assign(colors + 1, 0u);
    for (uint32_t k = m.adj_offset[i]; k < m.adj_offset[i + 1]; ++k) {
      const uint32_t c = color[m.adj_other[k]];
      if (c != 0xFFFFFFFFu) used[c] = 1u;
    }
    // A hinge's corners move each other too: never two of one hinge in a colour.
    if (!m.hinge_offset.empty())
      for (uint32_t k = m.hinge_offset[i]; k < m.hinge_offset[i + 1]; ++k)
        for (uint32_t j = 0; j < 4; ++j) {
          const uint32_t c = color[m.hinge_vertex[4 * (m.hinge_entry[k] / 4) + j]];
          if (c != 0xFFFFFFFFu) used[c] = 1u;
        }
    if (!m.membrane_offset.empty())
      for (uint32_t k = m.membrane_offset[i]; k < m.membrane_offset[i + 1]; ++k)
        for (uint32_t j = 0; j < 3; ++j) {
          const uint32_t c = color[m.membrane_vertex[3 * (m.membrane_entry[k] / 3) + j]];
          if (c != 0xFFFFFFFFu) used[c] = 1u;
        }
    uint32_t c = 0;
    while (used[c]) ++c;
    color[i] = c;
    colors = std::max(colors, c + 1);
  }
  m.color_offset.assign(colors + 1, 0u);
  for (uint32_t i = 0; i < n; ++i)
    if (color[i] != 0xFFFFFFFFu) ++m.color_offset[color[i] + 1];
  for (uint32_t c = 0; c < colors; ++c) m.color_offset[c + 1] += m.color_offset[c];
  m.color_vertices.assign(m.color_offset.back(), 0u);
  std::vector<uint32_t> at(m.color_offset.begin(), m.color_offset.end() - 1);
  for (uint32_t i = 0; i < n; ++i)
    if (color[i] != 0xFFFFFFFFu) m.color_vertices[at[color[i]]++] = i;
}

}  // namespace raycloth
