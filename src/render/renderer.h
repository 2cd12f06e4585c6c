// A CPU ray tracer for cloth frames (Embree 3 + oneTBB): the cloth's triangles with smooth normals
// and one colour per panel, the obstacles in their own material, a ground plane below the scene,
// a soft key light, ambient occlusion, antialiasing with a fixed seed per pixel (the same input
// gives the same bytes), tone mapping and sRGB output.
#pragma once
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "io/image.h"
#include "raycloth/scene.h"
#include "raycloth/vec3.h"
#include "render/camera.h"

namespace raycloth {

class Simulator;

// One frame's geometry in world space.
struct RenderScene {
  std::vector<Vec3> cloth_vertices;
  std::vector<uint32_t> cloth_indices;  // 3 per triangle
  std::vector<uint32_t> cloth_panel;    // panel of each triangle: its colour
  std::vector<Vec3> obstacle_vertices;
  std::vector<uint32_t> obstacle_indices;
  Bounds bounds() const;
};

// The simulator's cloth (one panel per model piece) and obstacles at its current time.
RenderScene make_render_scene(Simulator& sim);

using LinearRgb = std::array<float, 3>;  // linear albedo

// Albedo of panel i (a fixed palette, repeating after its last colour) and of every obstacle.
LinearRgb panel_colour(size_t panel);
inline constexpr LinearRgb kObstacleColour{0.60f, 0.60f, 0.60f};  // neutral grey: apart from every panel

// Camera, light and ground of a frame, set from `seen`: the bounds of everything the scene has
// occupied up to this frame (frame 0 through the current one). The view thus holds still while
// the scene stays within what it covered before and only widens, smoothly, when the cloth moves
// beyond; the ground lies just below the lowest point so far.
struct View {
  Camera camera;
  float ground_y = 0;
  float scale = 1;  // radius of `seen`: sets light distance and size, AO reach, ray offsets
  Vec3 light_centre, light_u, light_v;  // a square area light: centre +- light_u +- light_v
};

View make_view(const Bounds& seen, const CameraDef& camera);

class Renderer {
 public:
  Renderer();
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;
  RgbImage render(const RenderScene& scene, const View& view);  // 8-bit sRGB

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace raycloth
