#include "render/renderer.h"

#include <embree3/rtcore.h>
#include <spdlog/spdlog.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "raycloth/simulator.h"
#include "sim/model.h"

namespace raycloth {

namespace {

constexpr float kPi = 3.14159265358979f;
constexpr uint64_t kSeed = 0x5EED0F0C1074ull;  // fixed: the same scene gives the same image
constexpr unsigned kClothGeom = 0, kObstacleGeom = 1;

// Light and materials, linear RGB.
constexpr LinearRgb kKeyLight{1.55f, 1.49f, 1.40f};
constexpr LinearRgb kAmbient{0.42f, 0.45f, 0.50f};
constexpr LinearRgb kGround{0.46f, 0.44f, 0.41f};
constexpr LinearRgb kSkyHorizon{0.68f, 0.76f, 0.90f};
constexpr LinearRgb kSkyZenith{0.30f, 0.46f, 0.74f};
constexpr float kExposure = 0.65f;

// Warm and cool fabric colours that stay apart from each other, the grey obstacles and the sky.
constexpr std::array<LinearRgb, 8> kPalette{{{0.78f, 0.22f, 0.18f},
                                             {0.13f, 0.45f, 0.62f},
                                             {0.90f, 0.62f, 0.14f},
                                             {0.25f, 0.55f, 0.30f},
                                             {0.55f, 0.30f, 0.60f},
                                             {0.85f, 0.45f, 0.55f},
                                             {0.20f, 0.60f, 0.60f},
                                             {0.60f, 0.42f, 0.25f}}};

LinearRgb operator*(const LinearRgb& a, const LinearRgb& b) { return {a[0] * b[0], a[1] * b[1], a[2] * b[2]}; }
LinearRgb operator*(const LinearRgb& a, float s) { return {a[0] * s, a[1] * s, a[2] * s}; }
LinearRgb operator+(const LinearRgb& a, const LinearRgb& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
LinearRgb mix(const LinearRgb& a, const LinearRgb& b, float t) { return a * (1 - t) + b * t; }

// splitmix64 per pixel: each pixel's samples depend only on its position and the fixed seed.
struct Rng {
  uint64_t s;
  float next() {
    uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return float(z >> 40) * (1.0f / 16777216.0f);
  }
};

// Jittered stratification of the unit square into n cells (a cols x rows grid, the last row
// possibly short): sample i lies at a random point of cell i.
struct Strata {
  int cols, rows, n;
  explicit Strata(int count) : cols(int(std::ceil(std::sqrt(double(count))))), rows((count + cols - 1) / cols), n(count) {}
  void sample(int i, Rng& rng, float& a, float& b) const {
    const int row = i / cols, in_row = row + 1 < rows ? cols : n - row * cols;
    a = (float(i - row * cols) + rng.next()) / float(in_row);
    b = (float(row) + rng.next()) / float(rows);
  }
};

void on_embree_error(void*, RTCError code, const char* str) {
  spdlog::error("Embree error {}: {}", int(code), str ? str : "");
}

std::vector<Vec3> vertex_normals(const std::vector<Vec3>& x, const std::vector<uint32_t>& idx) {
  std::vector<Vec3> n(x.size(), make_vec3(0, 0, 0));
  for (size_t t = 0; t + 2 < idx.size(); t += 3) {
    const Vec3 fn = cross(x[idx[t + 1]] - x[idx[t]], x[idx[t + 2]] - x[idx[t]]);
    for (int k = 0; k < 3; ++k) n[idx[t + k]] += fn;
  }
  for (auto& v : n) v = normalize_or_zero(v);
  return n;
}

// Obstacle triangles whose vertex normals stray far from the face (box edges) are shaded flat.
std::vector<uint8_t> smooth_triangles(const std::vector<Vec3>& x, const std::vector<uint32_t>& idx,
                                      const std::vector<Vec3>& n) {
  std::vector<uint8_t> smooth(idx.size() / 3, 1);
  for (size_t t = 0; t < smooth.size(); ++t) {
    const Vec3 fn = normalize_or_zero(cross(x[idx[3 * t + 1]] - x[idx[3 * t]], x[idx[3 * t + 2]] - x[idx[3 * t]]));
    for (int k = 0; k < 3; ++k)
      if (dot(n[idx[3 * t + k]], fn) < 0.85f) smooth[t] = 0;
  }
  return smooth;
}

void add_geometry(RTCDevice device, RTCScene scene, unsigned id, const std::vector<Vec3>& vertices,
                  const std::vector<uint32_t>& indices) {
  RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* v = static_cast<Vec3*>(
      rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, sizeof(Vec3), vertices.size()));
  std::memcpy(v, vertices.data(), vertices.size() * sizeof(Vec3));
  auto* i = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                           3 * sizeof(uint32_t), indices.size() / 3));
  std::memcpy(i, indices.data(), indices.size() * sizeof(uint32_t));
  rtcCommitGeometry(g);
  rtcAttachGeometryByID(scene, g, id);
  rtcReleaseGeometry(g);
}

// Exposure, the ACES filmic curve (Narkowicz's fit) applied to luminance so that colours keep
// their saturation, then the sRGB transfer function.
std::array<uint8_t, 3> to_srgb8(const LinearRgb& linear) {
  const LinearRgb c = linear * kExposure;
  const float lum = 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2];
  const float mapped = (lum * (2.51f * lum + 0.03f)) / (lum * (2.43f * lum + 0.59f) + 0.14f);
  const float k = lum > 0 ? mapped / lum : 0.0f;
  std::array<uint8_t, 3> out;
  for (int i = 0; i < 3; ++i) {
    const float a = std::clamp(c[i] * k, 0.0f, 1.0f);
    const float s = a <= 0.0031308f ? 12.92f * a : 1.055f * std::pow(a, 1.0f / 2.4f) - 0.055f;
    out[i] = uint8_t(std::lround(s * 255.0f));
  }
  return out;
}

// An orthonormal basis around n, for hemisphere samples.
void basis(Vec3 n, Vec3& t, Vec3& b) {
  const Vec3 a = std::fabs(n.x) > 0.9f ? make_vec3(0, 1, 0) : make_vec3(1, 0, 0);
  t = normalize_or_zero(cross(a, n));
  b = cross(n, t);
}

}  // namespace

Bounds RenderScene::bounds() const {
  Bounds b;
  for (const Vec3& p : cloth_vertices) b.add(p);
  for (const Vec3& p : obstacle_vertices) b.add(p);
  return b;
}

RenderScene make_render_scene(Simulator& sim) {
  RenderScene s;
  const ClothModel& m = sim.model();
  s.cloth_vertices = sim.positions();
  s.cloth_indices = m.triangles;
  s.cloth_panel.resize(m.num_triangles());
  for (uint32_t p = 0; p < m.pieces.size(); ++p)
    std::fill_n(s.cloth_panel.begin() + m.pieces[p].first_triangle, m.pieces[p].num_triangles, p);
  s.obstacle_vertices = sim.obstacle_vertices();
  s.obstacle_indices = sim.obstacles().world.indices;
  return s;
}

LinearRgb panel_colour(size_t panel) { return kPalette[panel % kPalette.size()]; }

View make_view(const Bounds& b, const CameraDef& def) {
  View v;
  v.camera = make_camera(def, b);
  v.scale = std::max(b.empty() ? 1.0f : b.radius(), 1e-3f);
  v.ground_y = (b.empty() ? 0.0f : b.lo.y) - 2e-3f * v.scale;
  // Key light above, to the camera's left and a little in front of the scene, 6 radii away.
  const Vec3 toward_eye = normalize_or_zero(make_vec3(v.camera.eye.x - v.camera.target.x, 0,
                                                      v.camera.eye.z - v.camera.target.z));
  const Vec3 dir = normalize_or_zero(v.camera.right * -0.55f + make_vec3(0, 1, 0) + toward_eye * 0.35f);
  const Vec3 centre = b.empty() ? v.camera.target : b.centre();
  v.light_centre = centre + dir * (6.0f * v.scale);
  Vec3 u, w;
  basis(dir, u, w);
  v.light_u = u * (0.9f * v.scale);
  v.light_v = w * (0.9f * v.scale);
  return v;
}

struct Renderer::Impl {
  RTCDevice device = nullptr;
};

Renderer::Renderer() : impl_(std::make_unique<Impl>()) {
  impl_->device = rtcNewDevice(nullptr);
  if (!impl_->device)
    throw std::runtime_error("Embree: could not create a device (error " +
                             std::to_string(int(rtcGetDeviceError(nullptr))) + ")");
  rtcSetDeviceErrorFunction(impl_->device, on_embree_error, nullptr);
}

Renderer::~Renderer() { rtcReleaseDevice(impl_->device); }

RgbImage Renderer::render(const RenderScene& s, const View& view) {
  RTCScene scene = rtcNewScene(impl_->device);
  if (!s.cloth_indices.empty()) add_geometry(impl_->device, scene, kClothGeom, s.cloth_vertices, s.cloth_indices);
  if (!s.obstacle_indices.empty())
    add_geometry(impl_->device, scene, kObstacleGeom, s.obstacle_vertices, s.obstacle_indices);
  rtcCommitScene(scene);

  const std::vector<Vec3> cloth_n = vertex_normals(s.cloth_vertices, s.cloth_indices);
  const std::vector<Vec3> obstacle_n = vertex_normals(s.obstacle_vertices, s.obstacle_indices);
  const std::vector<uint8_t> obstacle_smooth = smooth_triangles(s.obstacle_vertices, s.obstacle_indices, obstacle_n);

  const Camera& cam = view.camera;
  const float eps = 1e-4f * view.scale;
  const float ao_reach = 0.35f * view.scale;
  const int spp = cam.samples;
  // Secondary rays per camera sample: at least 16 of each per pixel, at least 2 per sample.
  const int shadow_rays = std::max(2, 16 / spp), ao_rays = std::max(2, 16 / spp);
  const Strata pixel_strata(spp), light_strata(spp * shadow_rays), ao_strata(spp * ao_rays);

  auto occluded = [&](RTCIntersectContext& ctx, Vec3 org, Vec3 dir, float tfar) {
    RTCRay r;
    r.org_x = org.x, r.org_y = org.y, r.org_z = org.z;
    r.dir_x = dir.x, r.dir_y = dir.y, r.dir_z = dir.z;
    r.tnear = 0.0f;
    r.tfar = tfar;
    r.time = 0.0f;
    r.mask = 0xFFFFFFFFu;
    r.id = 0;
    r.flags = 0;
    rtcOccluded1(scene, &ctx, &r);
    return r.tfar < 0.0f;
  };

  // Sample k of a pixel: its secondary rays take cells k * rays .. (k + 1) * rays - 1 of the
  // pixel's light and hemisphere strata.
  auto shade = [&](RTCIntersectContext& ctx, Rng& rng, int k_sample, Vec3 org, Vec3 dir) -> LinearRgb {
    RTCRayHit rh;
    rh.ray.org_x = org.x, rh.ray.org_y = org.y, rh.ray.org_z = org.z;
    rh.ray.dir_x = dir.x, rh.ray.dir_y = dir.y, rh.ray.dir_z = dir.z;
    rh.ray.tnear = 0.0f;
    rh.ray.tfar = std::numeric_limits<float>::infinity();
    rh.ray.time = 0.0f;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, &ctx, &rh);

    const float t_ground = dir.y < 0 ? (view.ground_y - org.y) / dir.y : std::numeric_limits<float>::infinity();
    const bool hit_mesh = rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
    const LinearRgb sky = mix(kSkyHorizon, kSkyZenith, std::sqrt(std::clamp(dir.y, 0.0f, 1.0f)));
    if (!hit_mesh && !(t_ground < std::numeric_limits<float>::infinity())) return sky;

    Vec3 p, n, ng;
    LinearRgb albedo;
    float fog = 0;
    if (hit_mesh && rh.ray.tfar <= t_ground) {
      p = org + dir * rh.ray.tfar;
      ng = normalize_or_zero(make_vec3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z));
      const uint32_t t = rh.hit.primID;
      const float u = rh.hit.u, v = rh.hit.v;
      if (rh.hit.geomID == kClothGeom) {
        const uint32_t* i = &s.cloth_indices[3 * t];
        n = normalize_or_zero(cloth_n[i[0]] * (1 - u - v) + cloth_n[i[1]] * u + cloth_n[i[2]] * v);
        albedo = panel_colour(s.cloth_panel[t]);
      } else {
        const uint32_t* i = &s.obstacle_indices[3 * t];
        n = obstacle_smooth[t] ? normalize_or_zero(obstacle_n[i[0]] * (1 - u - v) + obstacle_n[i[1]] * u +
                                                   obstacle_n[i[2]] * v)
                               : ng;
        albedo = kObstacleColour;
      }
      // Both sides of a surface are lit: the normals face the viewer.
      if (dot(ng, dir) > 0) ng = -ng;
      if (dot(n, ng) < 0) n = -n;
      if (length_sq(n) == 0) n = ng;
    } else {
      p = org + dir * t_ground;
      p.y = view.ground_y;
      n = ng = make_vec3(0, 1, 0);
      albedo = kGround;
      // The ground fades into the horizon far from the scene.
      const float far = std::max(0.0f, length(p - cam.target) - 3.0f * view.scale) / (10.0f * view.scale);
      fog = 1.0f - std::exp(-far * far);
    }
    const Vec3 q = p + ng * eps;

    float direct = 0;
    for (int k = 0; k < shadow_rays; ++k) {
      float a, b;
      light_strata.sample(k_sample * shadow_rays + k, rng, a, b);
      const Vec3 lp = view.light_centre + view.light_u * (2 * a - 1) + view.light_v * (2 * b - 1);
      const Vec3 to = lp - q;
      const float dist = length(to);
      const Vec3 l = to / dist;
      const float cos_n = dot(n, l);
      if (cos_n <= 0 || dot(ng, l) <= 0) continue;
      if (!occluded(ctx, q, l, dist)) direct += cos_n;
    }
    direct /= float(shadow_rays);

    float ambient = 0;
    Vec3 tx, bx;
    basis(n, tx, bx);
    for (int k = 0; k < ao_rays; ++k) {
      // Cosine-weighted direction about the shading normal.
      float r1, r2;
      ao_strata.sample(k_sample * ao_rays + k, rng, r1, r2);
      const float r = std::sqrt(r1), phi = 2 * kPi * r2;
      const Vec3 d = normalize_or_zero(tx * (r * std::cos(phi)) + bx * (r * std::sin(phi)) + n * std::sqrt(1 - r1));
      if (dot(d, ng) <= 0) continue;
      if (d.y < 0 && (view.ground_y - q.y) / d.y < ao_reach) continue;
      if (!occluded(ctx, q, d, ao_reach)) ambient += 1;
    }
    ambient /= float(ao_rays);

    const LinearRgb lit = albedo * (kKeyLight * direct + kAmbient * ambient);
    return fog > 0 ? mix(lit, kSkyHorizon, fog) : lit;
  };

  RgbImage img(cam.width, cam.height);
  tbb::parallel_for(tbb::blocked_range<int>(0, img.height), [&](const tbb::blocked_range<int>& rows) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    for (int y = rows.begin(); y != rows.end(); ++y) {
      for (int x = 0; x < img.width; ++x) {
        Rng rng{kSeed ^ (uint64_t(uint32_t(y)) << 32 | uint32_t(x)) * 0xD6E8FEB86659FD93ull};
        LinearRgb sum{0, 0, 0};
        for (int k = 0; k < spp; ++k) {
          float sx, sy;
          pixel_strata.sample(k, rng, sx, sy);
          sum = sum + shade(ctx, rng, k, cam.eye, cam.direction(float(x) + sx, float(y) + sy));
        }
        const std::array<uint8_t, 3> px = to_srgb8(sum * (1.0f / float(spp)));
        std::copy(px.begin(), px.end(), img.pixels.begin() + (size_t(y) * img.width + x) * 3);
      }
    }
  });
  rtcReleaseScene(scene);
  return img;
}

}  // namespace raycloth
