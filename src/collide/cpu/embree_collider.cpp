// Obstacles and cloth live in two Embree scenes: the obstacles are committed once (or refit when
// they move), the cloth scene is RTC_SCENE_FLAG_DYNAMIC with low build quality and a REFIT
// geometry, so that its per-step commit is a refit, not a rebuild.
#include "collide/cpu/embree_collider.h"

#include <embree3/rtcore.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <string>

#include "collide/rules.h"
#include "raycloth/error.h"

namespace raycloth {

namespace {

const char* embree_error_name(RTCError code) {
  switch (code) {
    case RTC_ERROR_NONE: return "RTC_ERROR_NONE";
    case RTC_ERROR_UNKNOWN: return "RTC_ERROR_UNKNOWN";
    case RTC_ERROR_INVALID_ARGUMENT: return "RTC_ERROR_INVALID_ARGUMENT";
    case RTC_ERROR_INVALID_OPERATION: return "RTC_ERROR_INVALID_OPERATION";
    case RTC_ERROR_OUT_OF_MEMORY: return "RTC_ERROR_OUT_OF_MEMORY";
    case RTC_ERROR_UNSUPPORTED_CPU: return "RTC_ERROR_UNSUPPORTED_CPU";
    case RTC_ERROR_CANCELLED: return "RTC_ERROR_CANCELLED";
  }
  return "unknown Embree error";
}

// The first error Embree reports on a device; the collider turns it into a SimulationError after
// the call that caused it, so a run never goes on with a half-built scene.
struct EmbreeErrors {
  std::mutex lock;
  std::atomic<bool> any{false};
  std::string first;
};

void on_embree_error(void* user, RTCError code, const char* str) {
  auto* e = static_cast<EmbreeErrors*>(user);
  std::lock_guard<std::mutex> guard(e->lock);
  if (e->any.load()) return;
  e->first = std::string(embree_error_name(code)) + (str && *str ? std::string(": ") + str : std::string());
  e->any.store(true);
}

struct ClothFilterData {
  const uint32_t* tri_alias = nullptr;
};

// rtcIntersect1's context, carrying the ray's second alias (edge rays; kNoAlias otherwise).
struct CastContext {
  RTCIntersectContext base;
  uint32_t alias2 = kNoAlias;
};

// Skips the ray's own triangles (shared rule); the ray id carries its vertex alias.
void cloth_filter(const RTCFilterFunctionNArguments* args) {
  const auto* data = static_cast<const ClothFilterData*>(args->geometryUserPtr);
  const uint32_t alias2 = reinterpret_cast<const CastContext*>(args->context)->alias2;
  for (unsigned k = 0; k < args->N; ++k) {
    if (args->valid[k] != -1) continue;
    const uint32_t prim = RTCHitN_primID(args->hit, args->N, k);
    const uint32_t alias = RTCRayN_id(args->ray, args->N, k);
    if (is_own_triangle(data->tri_alias, prim, alias) || is_own_triangle(data->tri_alias, prim, alias2))
      args->valid[k] = 0;
  }
}

class EmbreeCollider final : public Collider {
 public:
  EmbreeCollider() {
    device_ = rtcNewDevice(nullptr);
    if (!device_) throw std::runtime_error("Embree: could not create a device (error " +
                                           std::to_string(int(rtcGetDeviceError(nullptr))) + ")");
    rtcSetDeviceErrorFunction(device_, on_embree_error, &errors_);
  }
  ~EmbreeCollider() override {
    if (obstacles_) rtcReleaseScene(obstacles_);
    if (cloth_) rtcReleaseScene(cloth_);
    rtcReleaseDevice(device_);
  }

  void set_obstacles(const Vec3* vertices, size_t num_vertices, const uint32_t* indices, size_t num_triangles,
                     bool dynamic) override {
    if (obstacles_) rtcReleaseScene(obstacles_);
    obstacles_ = nullptr;
    obstacle_vertices_ = nullptr;
    if (num_triangles == 0) return;
    obstacles_ = rtcNewScene(device_);
    if (dynamic) {
      rtcSetSceneFlags(obstacles_, RTC_SCENE_FLAG_DYNAMIC);
      rtcSetSceneBuildQuality(obstacles_, RTC_BUILD_QUALITY_LOW);
    }
    obstacle_geom_ = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    unattached_ = obstacle_geom_;
    if (dynamic) rtcSetGeometryBuildQuality(obstacle_geom_, RTC_BUILD_QUALITY_REFIT);
    obstacle_vertices_ = static_cast<float*>(rtcSetNewGeometryBuffer(
        obstacle_geom_, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, sizeof(Vec3), num_vertices));
    check("building the obstacles' scene");
    std::memcpy(obstacle_vertices_, vertices, num_vertices * sizeof(Vec3));
    num_obstacle_vertices_ = num_vertices;
    auto* idx = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(obstacle_geom_, RTC_BUFFER_TYPE_INDEX, 0,
                                                               RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), num_triangles));
    check("building the obstacles' scene");
    std::memcpy(idx, indices, num_triangles * 3 * sizeof(uint32_t));
    rtcCommitGeometry(obstacle_geom_);
    rtcAttachGeometry(obstacles_, obstacle_geom_);
    rtcReleaseGeometry(obstacle_geom_);
    unattached_ = nullptr;
    rtcCommitScene(obstacles_);
    check("building the obstacles' scene");
  }

  void update_obstacles(const Vec3* vertices) override {
    if (!obstacles_) return;
    std::memcpy(obstacle_vertices_, vertices, num_obstacle_vertices_ * sizeof(Vec3));
    rtcUpdateGeometryBuffer(obstacle_geom_, RTC_BUFFER_TYPE_VERTEX, 0);
    rtcCommitGeometry(obstacle_geom_);
    rtcCommitScene(obstacles_);
    check("updating the obstacles' scene");
  }

  void set_cloth(size_t num_vertices, const uint32_t* indices, const uint32_t* tri_alias, size_t num_triangles,
                 bool cast_against_cloth) override {
    if (cloth_) rtcReleaseScene(cloth_);
    cloth_ = nullptr;
    cloth_vertices_ = nullptr;
    num_cloth_vertices_ = num_vertices;
    if (!cast_against_cloth || num_triangles == 0) return;
    filter_.tri_alias = tri_alias;
    cloth_ = rtcNewScene(device_);
    rtcSetSceneFlags(cloth_, RTC_SCENE_FLAG_DYNAMIC);
    rtcSetSceneBuildQuality(cloth_, RTC_BUILD_QUALITY_LOW);
    cloth_geom_ = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    unattached_ = cloth_geom_;
    rtcSetGeometryBuildQuality(cloth_geom_, RTC_BUILD_QUALITY_REFIT);
    cloth_vertices_ = static_cast<float*>(rtcSetNewGeometryBuffer(cloth_geom_, RTC_BUFFER_TYPE_VERTEX, 0,
                                                                  RTC_FORMAT_FLOAT3, sizeof(Vec3), num_vertices));
    check("building the cloth's scene");
    std::memset(cloth_vertices_, 0, num_vertices * sizeof(Vec3));
    auto* idx = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(cloth_geom_, RTC_BUFFER_TYPE_INDEX, 0,
                                                               RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), num_triangles));
    check("building the cloth's scene");
    std::memcpy(idx, indices, num_triangles * 3 * sizeof(uint32_t));
    rtcSetGeometryUserData(cloth_geom_, &filter_);
    rtcSetGeometryIntersectFilterFunction(cloth_geom_, cloth_filter);
    rtcCommitGeometry(cloth_geom_);
    rtcAttachGeometry(cloth_, cloth_geom_);
    rtcReleaseGeometry(cloth_geom_);
    unattached_ = nullptr;
    check("building the cloth's scene");
    built_ = false;
  }

  void update_cloth(const Vec3* positions) override {
    if (!cloth_) return;
    std::memcpy(cloth_vertices_, positions, num_cloth_vertices_ * sizeof(Vec3));
    rtcUpdateGeometryBuffer(cloth_geom_, RTC_BUFFER_TYPE_VERTEX, 0);
    rtcCommitGeometry(cloth_geom_);
    rtcCommitScene(cloth_);
    check("updating the cloth's scene");
    built_ = true;
  }

  void cast(const Ray* rays, size_t count, RawHit* hits) override {
    cast_into(rays, count, hits, obstacles_);
    check("casting rays");
  }

 private:
  void check(const char* during) {
    if (!errors_.any.load()) return;
    if (unattached_) rtcReleaseGeometry(unattached_);  // a geometry left half-built by the failure
    unattached_ = nullptr;
    std::lock_guard<std::mutex> guard(errors_.lock);
    throw SimulationError("Embree failed while " + std::string(during) + ": " + errors_.first);
  }

  void cast_into(const Ray* rays, size_t count, RawHit* hits, RTCScene obstacles) {
    RTCScene cloth = built_ ? cloth_ : nullptr;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 256), [&](const tbb::blocked_range<size_t>& range) {
      CastContext ctx;
      rtcInitIntersectContext(&ctx.base);
      RTCIntersectContext& context = ctx.base;
      for (size_t i = range.begin(); i != range.end(); ++i) {
        const Ray& r = rays[i];
        RawHit h;
        if (r.tmax > 0.0f) {
          RTCRayHit rh;
          rh.ray.org_x = r.org.x, rh.ray.org_y = r.org.y, rh.ray.org_z = r.org.z;
          rh.ray.dir_x = r.dir.x, rh.ray.dir_y = r.dir.y, rh.ray.dir_z = r.dir.z;
          rh.ray.tnear = 0.0f;
          rh.ray.tfar = r.tmax;
          rh.ray.time = 0.0f;
          rh.ray.mask = 0xFFFFFFFFu;
          rh.ray.id = r.vertex;
          ctx.alias2 = r.vertex2;
          rh.ray.flags = 0;
          rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
          if (obstacles) {
            rtcIntersect1(obstacles, &context, &rh);
            if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) h = RawHit{rh.ray.tfar, rh.hit.primID, kHitObstacle};
          }
          if (cloth) {
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(cloth, &context, &rh);
            if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) h = RawHit{rh.ray.tfar, rh.hit.primID, kHitCloth};
          }
        }
        hits[i] = h;
      }
    });
  }

  EmbreeErrors errors_;
  RTCDevice device_ = nullptr;
  RTCScene obstacles_ = nullptr, cloth_ = nullptr;
  RTCGeometry obstacle_geom_ = nullptr, cloth_geom_ = nullptr;
  RTCGeometry unattached_ = nullptr;  // created, not yet attached to its scene
  float* obstacle_vertices_ = nullptr;
  float* cloth_vertices_ = nullptr;
  size_t num_obstacle_vertices_ = 0, num_cloth_vertices_ = 0;
  ClothFilterData filter_;
  bool built_ = false;
};

}  // namespace

std::unique_ptr<Collider> make_embree_collider() { return std::make_unique<EmbreeCollider>(); }

}  // namespace raycloth
