// A small multithreaded renderer on top of the variants, so their errors can be seen.
#pragma once

#include <limits>
#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "rayproof/core/atomic_file.h"
#include "rayproof/core/hit.h"
#include "rayproof/core/scene.h"
#include "rayproof/core/scene_index.h"
#include "rayproof/core/scene_rays.h"
#include "rayproof/core/variants.h"

namespace rayproof {

struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;  // row-major, 3 bytes a pixel, top row first
  std::array<std::uint8_t, 3> at(int x, int y) const {
    const size_t k = 3 * (static_cast<size_t>(y) * width + x);
    return {rgb[k], rgb[k + 1], rgb[k + 2]};
  }
};

// Which variant intersects each shape kind, and which contacts count.
struct Intersectors {
  std::array<const Variant*, 4> by_shape{};  // indexed by ShapeKind
  HitRule rule = HitRule::nearest_contact;
  // Per kind, how far off each ray its variant is asked (scene_rays.h; calibrate_reach sets it
  // for a scene, kLeafReach: leaf_reach of the variant's precision).
  std::array<double, 4> reach{kLeafReach, kLeafReach, kLeafReach, kLeafReach};
  static Intersectors defaults();
  // Picks `variant` for its own shape; returns false for an unknown name.
  bool use(std::string_view variant);
};

struct RenderOptions {
  Intersectors intersectors = Intersectors::defaults();
  int threads = 0;                                        // 0: one per hardware thread
  std::function<void(int rows_done, int rows)> progress;  // called from worker threads
};

// The nearest hit of a ray among the scene's primitives (object and primitive index, or -1).
struct SceneHit {
  int object = -1;
  int primitive = -1;
  Hit hit;
  // A whole tracer's answer no ray can have (a NaN or non-positive t, a triangle the mesh lacks):
  // the tracer's error, counted apart from holes (audit --tracer).
  bool invalid = false;
};
// The nearest hit among the primitives of one kind, by that kind's variant (`reach`: scene_rays.h).
SceneHit trace_kind(const SceneIndex& index, ShapeKind kind, const Variant& variant, HitRule rule, const Ray& ray,
                    double reach = kLeafReach);
// Sets isect.reach for each kind of the scene (calibrated_reach on a sample of the camera's rays),
// so each variant is drawn as it answers testing every primitive, not clipped by rayproof's boxes.
void calibrate_reach(const SceneIndex& index, Intersectors& isect);
// The nearest over all kinds; on equal t the object listed first.
SceneHit trace(const SceneIndex& index, const Intersectors& isect, const Ray& ray);
// Whether t is nearer than `best` (the scene's order: smaller t, then the object listed first,
// then the lower primitive).
inline bool nearer(double t, int primitive, const SceneHit& best, const SceneIndex& index) {
  if (best.primitive < 0) return true;
  if (t != best.hit.t) return t < best.hit.t;
  return index.listed_before(primitive, best.primitive);
}

// Linear 0..1 colour of each primary ray (scene.md's shading rules). Each kind's variant traces
// all the rays at once (trace_scene_rays), then all their shadow segments.
std::vector<Vec3> shade_all(const SceneIndex& index, const Intersectors& isect, std::span<const Ray> rays);
// The diffuse term of one light at p with unit normal n (facing the viewer): max(−n·w, 0).
double diffuse_cosine(const Vec3& p, const Vec3& n, const PointLight& light);
// The colour of a hit at p on an object of colour `color` (scene.md's shading rules); for
// diffuse shading light_terms[l] is light l's cosine where it reaches p, else 0.
Vec3 shade_point(const Scene& scene, const Vec3& color, const Vec3& p, const Ray& ray,
                 std::span<const double> light_terms);

Image render(const Scene& scene, const RenderOptions& options = {});

// Whether write_image can write this path (.png or .ppm): checked before rendering, so a long
// render is never thrown away for a typo in the output name.
bool is_image_path(const std::string& path);

// Writes PNG or PPM by the extension (.png, .ppm), atomically (temporary file, then rename).
// Throws std::runtime_error on failure.
void write_image(const Image& image, const std::string& path);
// The same into an output opened before the work (PPM for a .ppm path, else PNG); commits it.
void write_image(const Image& image, AtomicFile& file);
// The PNG file's bytes (for pages that inline their images).
std::string encode_png(const Image& image);
// Reads a PNG written by write_image (8-bit RGB); for tests and audits.
Image read_png(const std::string& path);

}  // namespace rayproof
