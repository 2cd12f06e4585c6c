#include "sim/seams.h"

#include <algorithm>
#include <map>

#include "sim/model.h"

namespace raycloth {

float seam_close_tolerance(const SceneDef& scene) {
  return scene.sewing.close_tolerance.value_or(2.0f * scene.collision.thickness);
}

std::vector<SeamGap> seam_gaps(const ClothModel& model, const std::vector<Vec3>& x, float tolerance) {
  std::map<uint32_t, SeamGap> by_seam;
  for (size_t k = 0; k < model.stitch_seam.size(); ++k) {
    SeamGap& g = by_seam[model.stitch_seam[k]];
    g.seam = model.stitch_seam[k];
    ++g.stitches;
    const Vec3 a = x[model.stitches[2 * k]], b = x[model.stitches[2 * k + 1]];
    const float gap = length(a - b);
    g.open += gap > tolerance;
    if (gap > g.largest) g.largest = gap, g.a = a, g.b = b;
  }
  std::vector<SeamGap> out;
  for (const auto& [seam, g] : by_seam) out.push_back(g);
  return out;
}

float largest_stitch_gap(const ClothModel& model, const std::vector<Vec3>& x) {
  float largest = 0;
  for (size_t k = 0; k + 1 < model.stitches.size(); k += 2)
    largest = std::max(largest, length(x[model.stitches[k]] - x[model.stitches[k + 1]]));
  return largest;
}

}  // namespace raycloth
