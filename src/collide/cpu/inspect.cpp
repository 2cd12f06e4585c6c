#include "collide/cpu/inspect.h"

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>

#include <cstring>
#include <limits>

#include "collide/rules.h"

namespace raycloth {

namespace {

struct EdgeFilter {
  const uint32_t* tri_alias;
  uint32_t a, b;  // aliases of the edge's end points
};

struct FilterContext {
  RTCIntersectContext base;
  EdgeFilter edge;
};

void skip_adjacent(const RTCFilterFunctionNArguments* args) {
  const auto* ctx = reinterpret_cast<const FilterContext*>(args->context);
  for (unsigned k = 0; k < args->N; ++k) {
    if (args->valid[k] != -1) continue;
    const uint32_t prim = RTCHitN_primID(args->hit, args->N, k);
    if (is_own_triangle(ctx->edge.tri_alias, prim, ctx->edge.a) ||
        is_own_triangle(ctx->edge.tri_alias, prim, ctx->edge.b))
      args->valid[k] = 0;
  }
}

RTCScene make_scene(RTCDevice device, const Vec3* v, size_t nv, const uint32_t* idx, size_t nt) {
  RTCScene scene = rtcNewScene(device);
  RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  std::memcpy(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, sizeof(Vec3), nv), v,
              nv * sizeof(Vec3));
  std::memcpy(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), nt), idx,
              nt * 3 * sizeof(uint32_t));
  rtcCommitGeometry(g);
  rtcAttachGeometry(scene, g);
  rtcReleaseGeometry(g);
  rtcCommitScene(scene);
  return scene;
}

RTCRayHit make_ray(Vec3 o, Vec3 d, float tnear, float tfar) {
  RTCRayHit rh;
  rh.ray.org_x = o.x, rh.ray.org_y = o.y, rh.ray.org_z = o.z;
  rh.ray.dir_x = d.x, rh.ray.dir_y = d.y, rh.ray.dir_z = d.z;
  rh.ray.tnear = tnear;
  rh.ray.tfar = tfar;
  rh.ray.time = 0;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  return rh;
}

}  // namespace

PenetrationReport inspect_penetration(const ClothModel& model, const std::vector<Vec3>& cloth,
                                      const TriMesh& obstacles) {
  PenetrationReport report;
  RTCDevice device = rtcNewDevice(nullptr);

  if (obstacles.num_triangles() > 0) {
    RTCScene scene = make_scene(device, obstacles.vertices.data(), obstacles.vertices.size(),
                                obstacles.indices.data(), obstacles.num_triangles());
    // Parity along a skewed direction: an odd number of crossings means inside.
    const Vec3 dir = normalize_or_zero(make_vec3(0.5773f, 0.5774f, 0.5775f));
    using Pair = std::pair<size_t, long>;
    const Pair r = tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, cloth.size()), Pair{0, -1},
        [&](const tbb::blocked_range<size_t>& range, Pair acc) {
          RTCIntersectContext ctx;
          rtcInitIntersectContext(&ctx);
          for (size_t i = range.begin(); i != range.end(); ++i) {
            int crossings = 0;
            float tnear = 0.0f;
            for (int guard = 0; guard < 1000; ++guard) {
              RTCRayHit rh = make_ray(cloth[i], dir, tnear, std::numeric_limits<float>::infinity());
              rtcIntersect1(scene, &ctx, &rh);
              if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) break;
              ++crossings;
              tnear = rh.ray.tfar * (1.0f + 1e-6f) + 1e-7f;
            }
            if (crossings % 2 == 1) {
              ++acc.first;
              if (acc.second < 0 || long(i) < acc.second) acc.second = long(i);
            }
          }
          return acc;
        },
        [](Pair a, Pair b) {
          return Pair{a.first + b.first, a.second < 0 ? b.second : (b.second < 0 ? a.second : std::min(a.second, b.second))};
        });
    report.vertices_inside_obstacles = r.first;
    report.first_inside_vertex = r.second;
    rtcReleaseScene(scene);
  }

  if (model.num_triangles() > 0) {
    RTCScene scene = make_scene(device, cloth.data(), cloth.size(), model.triangles.data(), model.num_triangles());
    rtcSetGeometryIntersectFilterFunction(rtcGetGeometry(scene, 0), skip_adjacent);
    rtcCommitGeometry(rtcGetGeometry(scene, 0));
    rtcCommitScene(scene);
    std::vector<size_t> edges;
    for (size_t s = 0; s < model.springs.size(); ++s)
      if (model.springs[s].type == SpringType::Stretch) edges.push_back(s);
    using Pair = std::pair<size_t, long>;
    const Pair r = tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, edges.size()), Pair{0, -1},
        [&](const tbb::blocked_range<size_t>& range, Pair acc) {
          for (size_t e = range.begin(); e != range.end(); ++e) {
            const Spring& sp = model.springs[edges[e]];
            FilterContext ctx;
            rtcInitIntersectContext(&ctx.base);
            ctx.edge = EdgeFilter{model.tri_alias.data(), model.alias[sp.a], model.alias[sp.b]};
            const Vec3 d = cloth[sp.b] - cloth[sp.a];
            const float len = length(d);
            if (!(len > 0)) continue;
            RTCRayHit rh = make_ray(cloth[sp.a], d / len, 0.0f, len);
            rtcIntersect1(scene, &ctx.base, &rh);
            if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
              ++acc.first;
              if (acc.second < 0 || long(edges[e]) < acc.second) acc.second = long(edges[e]);
            }
          }
          return acc;
        },
        [](Pair a, Pair b) {
          return Pair{a.first + b.first, a.second < 0 ? b.second : (b.second < 0 ? a.second : std::min(a.second, b.second))};
        });
    report.cloth_edge_crossings = r.first;
    report.first_crossing_edge = r.second;
    if (r.second >= 0) {
      // Find the triangle it crosses, for the message.
      const Spring& sp = model.springs[size_t(r.second)];
      FilterContext ctx;
      rtcInitIntersectContext(&ctx.base);
      ctx.edge = EdgeFilter{model.tri_alias.data(), model.alias[sp.a], model.alias[sp.b]};
      const Vec3 d = cloth[sp.b] - cloth[sp.a];
      RTCRayHit rh = make_ray(cloth[sp.a], d / length(d), 0.0f, length(d));
      rtcIntersect1(scene, &ctx.base, &rh);
      report.first_crossed_triangle = rh.hit.geomID != RTC_INVALID_GEOMETRY_ID ? long(rh.hit.primID) : -1;
    }
    rtcReleaseScene(scene);
  }
  rtcReleaseDevice(device);
  return report;
}

}  // namespace raycloth
