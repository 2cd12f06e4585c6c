// Seams sewn from apart (scene seams without weld_at_start): how far each one's stitches still are
// from closing. A stitch is a pair of cloth vertices pulled together by a spring of rest length 0
// (ClothModel::stitches); the contact keeps the two sides about one thickness apart, so a stitch
// counts as closed within SewingDef::close_tolerance (default twice the thickness).
#pragma once
#include <cstdint>
#include <vector>

#include "raycloth/scene.h"
#include "raycloth/vec3.h"

namespace raycloth {

struct ClothModel;

struct SeamGap {
  uint32_t seam = 0;     // index into SceneDef::seams
  uint32_t stitches = 0; // of this seam
  float largest = 0;     // metres, the widest of its stitches
  uint32_t open = 0;     // stitches wider than the tolerance given to seam_gaps
  Vec3 a{}, b{};         // the widest stitch's two ends
};

// Metres within which a stitch counts as closed.
float seam_close_tolerance(const SceneDef& scene);
// Every sewn seam's widest stitch in state x, in seam order (welded seams are not listed), and how
// many of its stitches are wider than `tolerance`.
std::vector<SeamGap> seam_gaps(const ClothModel& model, const std::vector<Vec3>& x, float tolerance = 0);
// The widest stitch of all (0 when there are none).
float largest_stitch_gap(const ClothModel& model, const std::vector<Vec3>& x);

}  // namespace raycloth
