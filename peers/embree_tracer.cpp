// Embree 3 as a whole tracer (docs/spec/tracer.md): "embree" (default build) and "embree-robust"
// (RTC_SCENE_FLAG_ROBUST), float like every Embree build. Nearest: rtcIntersect1 with
// tnear = tmin, tfar = tmax. Any-hit: the same call with an intersection filter that records
// every hit Embree's traversal offers and rejects it, so traversal goes on — what an any-hit
// shader or occlusion-with-callback user sees.
#include <cmath>

#include "rayproof/peers/embree.h"
#include "rayproof/peers/tracers.h"

namespace rayproof::peers {

namespace {

// Embree asserts that ray components stay within ±FLT_LARGE = 1.844e18 (rtcore_ray.h's valid()).
bool within_embree_range(const TracerRay& r) {
  constexpr double kLargest = 1.844e18;
  for (int k = 0; k < 3; ++k)
    if (!(std::abs(r.ray.origin[k]) <= kLargest) || !(std::abs(r.ray.direction[k]) <= kLargest)) return false;
  return true;
}

// The context an any-hit call passes to the filter (Embree hands it back as args->context).
struct CollectingContext {
  RTCIntersectContext context;
  std::vector<std::uint32_t>* hits;
};

void collect_every_hit(const RTCFilterFunctionNArguments* args) {
  auto* ctx = reinterpret_cast<const CollectingContext*>(args->context);
  if (!ctx->hits) return;  // nearest mode: accept
  ctx->hits->push_back(RTCHitN_primID(args->hit, args->N, 0));
  args->valid[0] = 0;  // reject: traversal continues to the next candidate
}

class EmbreeTracerScene final : public TracerScene {
 public:
  EmbreeTracerScene(const TriangleMesh& mesh, bool robust) {
    RTCDevice dev = embree_device();
    scene_ = rtcNewScene(dev);
    rtcSetSceneFlags(scene_, robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                          3 * sizeof(float), mesh.vertex_count()));
    auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                               3 * sizeof(unsigned), mesh.triangle_count()));
    for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
      v[i] = static_cast<float>(mesh.vertices[i]);  // exact: rounded before
    for (std::size_t i = 0; i < mesh.indices.size(); ++i) idx[i] = mesh.indices[i];
    rtcSetGeometryIntersectFilterFunction(g, collect_every_hit);
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene_, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(scene_);
  }
  ~EmbreeTracerScene() override { rtcReleaseScene(scene_); }

  void nearest(std::span<const TracerRay> rays, std::span<TraceAnswer> out) override {
    for (std::size_t i = 0; i < rays.size(); ++i) {
      out[i] = {};
      if (!within_embree_range(rays[i])) continue;
      RTCRayHit rh = trace(rays[i], nullptr);
      if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) out[i] = {rh.hit.primID, static_cast<double>(rh.ray.tfar)};
    }
  }
  void all_hits(std::span<const TracerRay> rays, std::span<AllHitsAnswer> out) override {
    for (std::size_t i = 0; i < rays.size(); ++i) {
      out[i] = {};
      if (within_embree_range(rays[i])) trace(rays[i], &out[i].triangles);
    }
  }

 private:
  RTCRayHit trace(const TracerRay& r, std::vector<std::uint32_t>* hits) const {
    CollectingContext ctx;
    rtcInitIntersectContext(&ctx.context);
    ctx.hits = hits;
    RTCRayHit rh = embree_ray(r.ray);
    rh.ray.tnear = static_cast<float>(r.tmin), rh.ray.tfar = static_cast<float>(r.tmax);
    rtcIntersect1(scene_, &ctx.context, &rh);
    return rh;
  }
  RTCScene scene_;
};

}  // namespace

void register_embree_tracers() {
  for (bool robust : {false, true}) {
    Tracer t;
    t.range = RangeRule::closed;  // tnear and tfar are inclusive (Embree 3 API: "tnear <= t <= tfar")
    t.name = robust ? "embree-robust" : "embree";
    t.precision = Precision::f32;
    t.source = std::string("Intel Embree ") + RTC_VERSION_STRING +
               (robust ? ", RTC_SCENE_FLAG_ROBUST" : ", default scene flags") +
               "; any-hit through an intersection filter";
    t.origin = "peer: libembree3";
    t.build = [robust](const TriangleMesh& mesh) {
      return BuiltScene{std::make_unique<EmbreeTracerScene>(mesh, robust)};
    };
    register_tracer(std::move(t));
  }
}

}  // namespace rayproof::peers
