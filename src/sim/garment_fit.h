// Garments placed on a body (SceneDef::garment_fits, a scene's garments[].body): the panels come in
// the pattern file's own frame and are fitted to the body as the cloth meets it at t = 0, with no
// offsets asked of the user:
// - frame: a garment of the older generator (its top below kOlderFrameTop) is lifted to GarmentCode's;
// - facing: turned about the vertical from the pattern's front (+z) to the obstacle's `front`;
// - height: the garment's anchor meets the body's: the neck line (GarmentCode's body: 1.457 m) for a
//   garment reaching above 1.30 m, else the waist (1.088 m), the body's waist taken as far below its
//   neck line as GarmentCode's, scaled by the two bodies' heights (1.72 m);
// - centre: the middle of the garment's extent in a band of heights around its anchor meets the middle
//   of the body's cross-sections in the same band;
// - stance: a front or back panel across the middle whose sides do not clear the legs' outer sides
//   (a pencil skirt on a body standing with its feet apart) is wrapped, height by height, around the
//   front or back half of the body's hull (hips or both legs, not the arms), stretched where it is
//   too narrow to reach round, so that its sides start beside the other panel's, outside the legs,
//   and the stitches close around them, not between them (flat, they closed between the legs);
//   a garment that the wrap would leave crossed keeps its flat placement;
// - clearance: a panel with a vertex inside the body, within the clearance of its surface, or a body
//   edge through one of its triangles is moved along its normal (whichever way clears first) in
//   steps of a quarter of the clearance, up to kMaxClearMove;
// - parting: panels of the garment that cross each other, or overlap within the thickness (an inner
//   vertex of one near a triangle of the other), are moved apart along their normals, away from
//   the body.
// The body's neck line is the narrowest horizontal cross-section (across its front) between 80 % and
// 92 % of its height.
#pragma once
#include <string>
#include <vector>

#include "raycloth/scene.h"
#include "raycloth/vec3.h"

namespace raycloth {

struct ClothModel;
struct ObstacleSet;

inline constexpr double kGarmentCodeHeight = 1.72, kGarmentCodeNeck = 1.457, kGarmentCodeWaist = 1.088;
inline constexpr double kMaxClearMove = 0.25;  // metres
// A panel is wrapped this far (metres, beyond the clearance) outside the body's hull, stretched by a
// factor of at most kMaxStanceWiden.
inline constexpr double kStanceMargin = 0.01, kMaxStanceWiden = 1.4;
// A panel wrapped around the body's hull ends this far (metres of arc) short of the hull's side; a
// panel is wrapped where its whole rows are narrower than the stance over this much height (metres);
// one placed outside another on the same side is wrapped this much farther out (metres).
inline constexpr double kWrapGap = 0.015, kNarrowHeight = 0.05, kWrapLayer = 0.015;
// Panels are wrapped below the body's waist and this much (metres); a panel that reaches higher (a
// robe's, a dress's from the shoulders) is wrapped in full this much (metres) below that line and eased
// from there to its place at the line.
inline constexpr double kWrapAboveWaist = 0.1, kWrapEase = 0.2;
// Panels on one side sewn to each other along the body's middle (front halves sewn at the centre: every
// stitch between them within this many metres of the middle) are wrapped as one panel across it; a
// panel from above the waist whose rows on the legs come this near the middle (a robe's open half) is
// laid from the middle to its side.
inline constexpr double kMiddleSeam = 0.03;
// A panel that reaches above the waist line is wrapped where its sides, either side of the middle,
// reach less than this many times the length of the hull's front (or back) half on that side.
inline constexpr double kWrapSlack = 1.25;
// A garment whose top is below this (metres, in its file's frame) is in the older generator's frame
// (waist at y = 0, T-pose) and is lifted by kGarmentCodeWaist before the fit.
inline constexpr double kOlderFrameTop = 0.75;

// A body's landmarks, in world space, from its pose at t = 0.
struct BodyFrame {
  double floor = 0, height = 0;  // lowest y, and height above it
  double neck = 0;               // y of the neck line
  Vec3 front{0, 0, 1}, side{1, 0, 0};  // unit, horizontal
};

// Every panel's placement as the fit left it: how far it was moved out of the body.
struct PanelFit {
  std::string panel;
  float moved = 0;     // metres along its normal
  bool wrapped = false;  // laid around the legs' hull (sim/garment_fit.cpp, wrap_for_stance)
  float stretched = 1;   // the largest factor it was stretched by there
};

BodyFrame body_frame(const ObstacleSet& obstacles, size_t obstacle, const std::vector<Vec3>& posed, const Float3& front);

// Fits every garment of scene.garment_fits onto its body: moves the model's start positions, and
// refreshes what depends on them (the stitches' start lengths, seam partners). Throws InputError
// naming the garment, the panel and the obstacle when a panel cannot be cleared.
std::vector<PanelFit> fit_garments(ClothModel& model, const ObstacleSet& obstacles, const SceneDef& scene);

}  // namespace raycloth
