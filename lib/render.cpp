#include "rayproof/core/render.h"

#include <png.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "rayproof/core/atomic_file.h"
#include "rayproof/core/offset.h"
#include "rayproof/core/parallel.h"
#include "rayproof/core/scene_rays.h"

namespace rayproof {

Intersectors Intersectors::defaults() {
  Intersectors isect;
  for (ShapeKind k : kAllShapeKinds) isect.by_shape[static_cast<int>(k)] = &default_variant(k);
  return isect;
}

bool Intersectors::use(std::string_view name) {
  const Variant* v = find_variant(name);
  if (!v) return false;
  for (ShapeKind k : kAllShapeKinds)  // an --exec command answers every shape
    if (v->handles(k)) by_shape[static_cast<int>(k)] = v;
  return true;
}

SceneHit trace_kind(const SceneIndex& index, ShapeKind kind, const Variant& variant, HitRule rule, const Ray& ray,
                    double reach) {
  const SceneRay r{ray};
  SceneRayAnswer a;
  trace_scene_rays(variant, index.of_kind(kind), rule, std::span(&r, 1), std::span(&a, 1), nullptr, reach);
  return a.primitive < 0 ? SceneHit{} : SceneHit{index.primitive(a.primitive).object, a.primitive, a.answer};
}

void calibrate_reach(const SceneIndex& index, Intersectors& isect) {
  const std::vector<SceneRay> sample = primary_sample(index.scene().camera);
  for (ShapeKind kind : index.shapes_used()) {
    const int k = static_cast<int>(kind);
    isect.reach[k] = calibrated_reach(*isect.by_shape[k], index.of_kind(kind), isect.rule, sample);
  }
}

SceneHit trace(const SceneIndex& index, const Intersectors& isect, const Ray& ray) {
  SceneHit best;
  for (ShapeKind kind : kAllShapeKinds) {
    if (index.count(kind) == 0) continue;
    const int k = static_cast<int>(kind);
    const SceneHit h = trace_kind(index, kind, *isect.by_shape[k], isect.rule, ray, isect.reach[k]);
    if (h.primitive >= 0 && nearer(h.hit.t, h.primitive, best, index)) best = h;
  }
  return best;
}

double diffuse_cosine(const Vec3& p, const Vec3& n, const PointLight& light) {
  const Vec3 w = normalized(p - light.position);
  return std::max(-dot(n, w), 0.0);
}

Vec3 shade_point(const Scene& scene, const Vec3& color, const Vec3& p, const Ray& ray,
                 std::span<const double> light_terms) {
  switch (scene.shading) {
    case Shading::flat: return color;
    case Shading::depth: {
      const double distance = length(p - ray.origin);
      const double grey = (scene.depth_far - distance) / (scene.depth_far - scene.depth_near);
      return Vec3::Constant(std::clamp(grey, 0.0, 1.0));
    }
    case Shading::diffuse: {
      double light_sum = 0;
      for (size_t l = 0; l < scene.lights.size() && l < light_terms.size(); ++l)
        light_sum += scene.lights[l].intensity * light_terms[l];
      return color * light_sum;
    }
  }
  return scene.background;
}

std::vector<Vec3> shade_all(const SceneIndex& index, const Intersectors& isect, std::span<const Ray> rays) {
  const Scene& scene = index.scene();
  // The nearest hit of each ray: a kind at a time, the kind's variant asked for all rays at once.
  std::vector<SceneHit> nearest(rays.size());
  std::vector<SceneRay> asked(rays.size());
  std::vector<SceneRayAnswer> answers;
  for (size_t i = 0; i < rays.size(); ++i) asked[i].ray = rays[i];
  auto trace_kinds = [&](const std::vector<SceneRay>& what, HitRule rule, auto&& take) {
    answers.resize(what.size());
    for (ShapeKind kind : index.shapes_used()) {
      const int k = static_cast<int>(kind);
      trace_scene_rays(*isect.by_shape[k], index.of_kind(kind), rule, what, answers, nullptr, isect.reach[k]);
      for (size_t i = 0; i < what.size(); ++i)
        if (answers[i].primitive >= 0) take(i, answers[i]);
    }
  };
  trace_kinds(asked, isect.rule, [&](size_t i, const SceneRayAnswer& a) {
    if (nearer(a.answer.t, a.primitive, nearest[i], index))
      nearest[i] = {index.primitive(a.primitive).object, a.primitive, a.answer};
  });
  // Diffuse shading: one shadow segment per lit side of a light, from the hit point moved off the
  // surface by core/offset.h's error bound. The primitive the point lies on is skipped: every
  // primitive is convex or flat, so a point lit from the side its normal faces cannot be
  // shadowed by the primitive it lies on (a mesh's other triangles can shadow it).
  std::vector<std::vector<double>> terms(rays.size());
  std::vector<std::pair<size_t, size_t>> segment_of;  // (ray, light) per shadow segment
  asked.clear();
  for (size_t i = 0; i < rays.size() && scene.shading == Shading::diffuse; ++i) {
    const SceneHit& sh = nearest[i];
    if (sh.object < 0) continue;
    const Vec3 p = rays[i].at(sh.hit.t);
    Vec3 n = outward_normal(index.primitive(sh.primitive).shape, p);
    if (dot(n, rays[i].direction) > 0) n = -n;  // the side the ray arrived from
    const Variant* drew = isect.by_shape[static_cast<int>(kind_of(index.primitive(sh.primitive).shape))];
    const Vec3 start = spawn_origin(rays[i], sh.hit.t, p, n, drew ? drew->precision : Precision::f64);
    terms[i].assign(scene.lights.size(), 0);
    for (size_t l = 0; l < scene.lights.size(); ++l) {
      const double c = diffuse_cosine(p, n, scene.lights[l]);
      if (!(c > 0)) continue;
      terms[i][l] = c;
      asked.push_back({Ray{start, scene.lights[l].position - start}, sh.primitive, true});
      segment_of.emplace_back(i, l);
    }
  }
  trace_kinds(asked, HitRule::nearest_contact, [&](size_t j, const SceneRayAnswer&) {
    terms[segment_of[j].first][segment_of[j].second] = 0;  // blocked
  });
  std::vector<Vec3> colours(rays.size(), scene.background);
  for (size_t i = 0; i < rays.size(); ++i) {
    const SceneHit& sh = nearest[i];
    if (sh.object >= 0)
      colours[i] = shade_point(scene, scene.objects[sh.object].color, rays[i].at(sh.hit.t), rays[i], terms[i]);
  }
  return colours;
}

Image render(const Scene& scene, const RenderOptions& options) {
  const Camera& cam = scene.camera;
  Image image{cam.width, cam.height, std::vector<std::uint8_t>(3 * size_t(cam.width) * cam.height)};
  const SceneIndex index(scene);
  Intersectors isect = options.intersectors;
  calibrate_reach(index, isect);
  const int grid = static_cast<int>(std::lround(std::sqrt(scene.samples)));
  std::atomic<int> next_row{0}, rows_done{0};
  auto worker = [&](int) {
    for (int y; (y = next_row.fetch_add(1)) < cam.height;) {
      // A row at a time, so external code traces the row's rays in one round trip per kind.
      std::vector<Ray> rays;
      for (int x = 0; x < cam.width; ++x)
        for (int sy = 0; sy < grid; ++sy)
          for (int sx = 0; sx < grid; ++sx)
            rays.push_back(cam.ray_through(x + (sx + 0.5) / grid, y + (sy + 0.5) / grid));
      const std::vector<Vec3> colours = shade_all(index, isect, rays);
      for (int x = 0; x < cam.width; ++x) {
        Vec3 sum = Vec3::Zero();
        for (int k = 0; k < grid * grid; ++k) sum += colours[size_t(x) * grid * grid + k];
        const Vec3 c = sum / (grid * grid);
        for (int k = 0; k < 3; ++k)
          image.rgb[3 * (size_t(y) * cam.width + x) + k] =
              static_cast<std::uint8_t>(std::lround(std::clamp(c[k], 0.0, 1.0) * 255));
      }
      const int done = ++rows_done;
      if (options.progress) options.progress(done, cam.height);
    }
  };
  run_workers(std::clamp(options.threads > 0 ? options.threads : default_threads(), 1, 256), worker);
  return image;
}

namespace {

void write_png(const Image& image, std::ostream& out) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) throw std::runtime_error("libpng: out of memory");
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error("libpng: write failed");
  }
  png_set_write_fn(
      png, &out,
      [](png_structp p, png_bytep data, png_size_t n) {
        static_cast<std::ostream*>(png_get_io_ptr(p))->write(reinterpret_cast<const char*>(data), std::streamsize(n));
      },
      [](png_structp p) { static_cast<std::ostream*>(png_get_io_ptr(p))->flush(); });
  png_set_IHDR(png, info, image.width, image.height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int y = 0; y < image.height; ++y)
    png_write_row(png, const_cast<png_bytep>(image.rgb.data() + 3 * size_t(y) * image.width));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
}

}  // namespace

std::string encode_png(const Image& image) {
  std::ostringstream out;
  write_png(image, out);
  return std::move(out).str();
}

bool is_image_path(const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  return ext == ".png" || ext == ".ppm";
}

void write_image(const Image& image, const std::string& path) {
  if (!is_image_path(path))
    throw std::runtime_error(path + ": unknown image type '" + std::filesystem::path(path).extension().string() +
                             "' (use .png or .ppm)");
  AtomicFile file(path);
  write_image(image, file);
}

void write_image(const Image& image, AtomicFile& file) {
  const std::string ext = std::filesystem::path(file.path()).extension().string();
  if (ext != ".ppm") {
    write_png(image, file.stream());
  } else {
    file.stream() << "P6\n" << image.width << " " << image.height << "\n255\n";
    file.stream().write(reinterpret_cast<const char*>(image.rgb.data()), std::streamsize(image.rgb.size()));
  }
  file.commit();
}

Image read_png(const std::string& path) {
  png_image img{};
  img.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&img, path.c_str())) throw std::runtime_error(path + ": " + img.message);
  img.format = PNG_FORMAT_RGB;
  Image out{static_cast<int>(img.width), static_cast<int>(img.height), std::vector<std::uint8_t>(PNG_IMAGE_SIZE(img))};
  if (!png_image_finish_read(&img, nullptr, out.rgb.data(), 0, nullptr))
    throw std::runtime_error(path + ": " + img.message);
  return out;
}

}  // namespace rayproof
