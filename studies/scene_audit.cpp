#include "rayproof/studies/scene_audit.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <stdexcept>

#include "rayproof/core/offset.h"
#include "rayproof/core/parallel.h"
#include "rayproof/verify/exact_scene.h"

namespace rayproof::studies {

std::vector<int> headroom_exponents() {
  std::vector<int> k;
  for (int e = 0; e <= 62; e += 2) k.push_back(e);
  return k;
}

Vec3 headroom_offset(int k) { return std::ldexp(1.0, k) * Vec3(1, 0.75, 0.5); }

namespace {

constexpr int kMaxLights = 64;

// What the exact render knows of one pixel.
struct ExactPixel {
  std::array<ExactContact, 4> by_kind;  // the nearest exact contact among each kind's primitives
  ExactContact visible;                 // the nearest of those
  std::uint64_t facing = 0;             // lights the exact hit point faces (cosine > 0)
  std::uint64_t lit = 0;                // ... of those, the ones whose segment is not blocked
};

int object_of(const SceneIndex& index, const ExactContact& c) {
  return c.found() ? index.primitive(c.primitive).object : -1;
}

std::uint8_t to_byte(double c) { return static_cast<std::uint8_t>(std::lround(std::clamp(c, 0.0, 1.0) * 255)); }
void put(Image& img, size_t px, const Vec3& c) {
  for (int k = 0; k < 3; ++k) img.rgb[3 * px + k] = to_byte(c[k]);
}
void put(Image& img, size_t px, const std::array<std::uint8_t, 3>& c) {
  for (int k = 0; k < 3; ++k) img.rgb[3 * px + k] = c[k];
}

// The normal at p facing the ray's side (scene.md's diffuse rule).
Vec3 facing_normal(const Shape& shape, const Vec3& p, const Ray& ray) {
  Vec3 n = outward_normal(shape, p);
  return dot(n, ray.direction) > 0 ? Vec3(-n) : n;
}

// Rows in parallel, each worker with its own state (an ExactTracer owns counting oracles).
template <class State, class Row>
void for_rows(int threads, int height, const std::function<State()>& make_state, Row&& row,
              const std::function<void(long, long)>& progress) {
  std::atomic<int> next{0}, done{0};
  std::mutex mutex;
  run_workers(threads, [&](int worker) {
    State state = make_state();
    for (int y; (y = next.fetch_add(1)) < height;) {
      row(state, y);
      const int d = ++done;
      if (worker == 0 && progress) progress(d, height);
    }
    std::lock_guard lock(mutex);
    state.finish();
  });
}

// What an audit row draws: a variant (for one kind) or a whole tracer (the triangles).
struct Contender {
  const Variant* variant = nullptr;
  const Tracer* tracer = nullptr;
  ShapeKind kind = ShapeKind::triangle;
};

// A tracer built over the scene's triangles: each mesh with its vertices shared as its file
// shares them (so a tracer's watertightness is judged on the mesh it was given), each lone
// triangle on its own; float tracers get them rounded to float.
struct TracerOnScene {
  std::unique_ptr<TracerScene> scene;
  std::vector<std::int32_t> primitive_of;  // the built mesh's triangle index → the scene's primitive
  Precision precision = Precision::f64;
  std::string failure;  // why it could not be built (then it draws nothing)

  TracerOnScene(const Tracer& t, const SceneIndex& index) : precision(t.precision) {
    TriangleMesh mesh;
    std::map<std::pair<std::int32_t, std::uint32_t>, std::uint32_t> shared;  // (object, file vertex) → index
    for (std::int32_t id = 0; id < static_cast<std::int32_t>(index.primitives().size()); ++id) {
      const Primitive& p = index.primitive(id);
      const auto* tri = std::get_if<Triangle>(&p.shape);
      if (!tri) continue;
      const SceneObject& object = index.scene().objects[p.object];
      for (int k = 0; k < 3; ++k) {
        auto add = [&] {
          mesh.vertices.insert(mesh.vertices.end(), {tri->v[k].x(), tri->v[k].y(), tri->v[k].z()});
          return static_cast<std::uint32_t>(mesh.vertex_count() - 1);
        };
        if (!object.mesh) {
          mesh.indices.push_back(add());
          continue;
        }
        const auto [it, fresh] = shared.try_emplace({p.object, object.mesh->corners[p.element][k]}, 0);
        if (fresh) it->second = add();
        mesh.indices.push_back(it->second);
      }
      primitive_of.push_back(id);
    }
    if (primitive_of.empty()) return;
    if (precision == Precision::f32) {
      auto rounded = mesh_rounded_to_float(mesh);
      if (!rounded) {
        failure = "the scene's triangles overflow float";
        return;
      }
      mesh = std::move(*rounded);
    }
    BuiltScene built = t.build(mesh);
    if (!built.scene) failure = built.reason.empty() ? std::string(to_string(built.failure)) : built.reason;
    scene = std::move(built.scene);
  }
  // The ray as the tracer is given it (float: rounded), or nullopt.
  std::optional<TracerRay> seen(const Ray& ray, double tmax) const {
    const TracerRay r{ray, 0, tmax};
    return precision == Precision::f32 ? ray_rounded_to_float(r) : std::optional(r);
  }
};

class Auditor {
 public:
  Auditor(const Scene& scene, const SceneAuditOptions& options)
      : scene_(scene), index_(scene), options_(options),
        threads_(std::clamp(options.threads > 0 ? options.threads : default_threads(), 1, 256)) {}

  const SceneIndex& index() const { return index_; }

  // The exact render: per pixel the nearest exact contact per kind and overall, and (shaded)
  // the exact shadow status of each light and the colour.
  void exact_pass(bool shaded, SceneAudit* out) {
    const Camera& cam = scene_.camera;
    exact_.assign(size_t(cam.width) * cam.height, ExactPixel{});
    if (shaded) out->exact = Image{cam.width, cam.height, std::vector<std::uint8_t>(3 * exact_.size())};
    struct State {
      ExactTracer tracer;
      long shadow_rays = 0, beyond = 0;
      long* shadow_total;  // finish() runs under for_rows's lock
      long* beyond_total;
      void finish() {
        *shadow_total += shadow_rays;
        *beyond_total += beyond;
      }
    };
    long shadow_total = 0, beyond_total = 0;
    const auto start = std::chrono::steady_clock::now();
    for_rows<State>(
        threads_, cam.height, [&] { return State{ExactTracer(index_), 0, 0, &shadow_total, &beyond_total}; },
        [&](State& st, int y) {
          for (int x = 0; x < cam.width; ++x) {
            const size_t px = size_t(y) * cam.width + x;
            const Ray ray = cam.ray_through(x + 0.5, y + 0.5);
            const std::uint64_t before = st.tracer.beyond_intervals();
            ExactPixel& e = exact_[px];
            for (ShapeKind kind : index_.shapes_used()) {
              ExactContact& c = e.by_kind[static_cast<int>(kind)];
              c = st.tracer.nearest(kind, ray);
              if (st.tracer.before(ray, c, e.visible)) e.visible = c;
            }
            if (shaded) put(out->exact, px, exact_colour(st, ray, e));
            if (shaded) st.shadow_rays += std::popcount(e.facing);
            if (st.tracer.beyond_intervals() != before) ++st.beyond;
          }
        },
        stage_progress("exact render"));
    if (out) {
      out->exact_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      out->primary_rays = static_cast<long>(exact_.size());
      out->shadow_rays = shadow_total;
      out->rays_beyond_intervals = beyond_total;
    }
  }

  // One variant of one kind, the other kinds exact (from exact_pass's per-kind contacts).
  // Shaded: colours, shadows and the diff image too.
  // `exact_image`: the exact render the diff image dims (shaded passes).
  PixelCounts variant_pass(const Contender& c, bool shaded, VariantAudit* out, const Image* exact_image = nullptr) {
    const Camera& cam = scene_.camera;
    std::unique_ptr<TracerOnScene> tracer;
    if (c.tracer) {
      tracer = std::make_unique<TracerOnScene>(*c.tracer, index_);
      if (!tracer->failure.empty() && out) out->stopped = c.tracer->name + ": " + tracer->failure;
    }
    if (shaded) {
      out->render = Image{cam.width, cam.height, std::vector<std::uint8_t>(3 * exact_.size())};
      out->diff = out->render;
    }
    std::vector<PixelCounts> per_row(cam.height);
    struct State {
      ExactTracer tracer;
      void finish() {}
    };
    for_rows<State>(
        threads_, cam.height, [&] { return State{ExactTracer(index_)}; },
        [&](State& st, int y) {
          std::vector<SceneHit> row;  // a tracer answers the row's primary rays in one call
          if (tracer) row = trace_row(*tracer, y);
          for (int x = 0; x < cam.width; ++x)
            variant_pixel(st.tracer, c, tracer.get(), tracer ? &row[x] : nullptr, shaded, x, y, per_row[y], out, exact_image);
        },
        stage_progress((c.tracer ? c.tracer->name : std::string(c.variant->name)) + " (" + std::string(to_string(c.kind)) + ")"));
    PixelCounts total;
    for (const PixelCounts& c : per_row) {
      total.wrong += c.wrong;
      total.holes += c.holes;
      total.false_hits += c.false_hits;
      total.shadow_wrong += c.shadow_wrong;
      total.acne += c.acne;
    }
    return total;
  }

  // ns per primary ray of the variant against its shape's primitives, on one thread: the
  // fastest of three rounds of whole frames (each at least 0.05 s), so that a busy moment on the
  // machine does not decide a recommendation.
  double time_variant(const Contender& c) const {
    if (c.tracer) return time_tracer(*c.tracer);
    const Variant& v = *c.variant;
    const ShapeKind kind = c.kind;
    const Camera& cam = scene_.camera;
    double best = std::numeric_limits<double>::infinity(), checksum = 0;
    for (int round = 0; round < 3; ++round) {
      long rays = 0;
      double seconds = 0;
      const auto start = std::chrono::steady_clock::now();
      do {
        for (int y = 0; y < cam.height; ++y)
          for (int x = 0; x < cam.width; ++x) {
            const SceneHit h = trace_kind(index_, kind, v, HitRule::nearest_contact, cam.ray_through(x + 0.5, y + 0.5));
            checksum += h.primitive;
            ++rays;
          }
        seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      } while (seconds < 0.05);
      best = std::min(best, seconds * 1e9 / static_cast<double>(rays));
      if (v.external) break;  // code behind a process boundary: one round (each call is a round trip)
    }
    volatile double sink = checksum;  // keeps the traced answers alive
    (void)sink;
    return best;
  }

  // ns per primary ray of a whole tracer over the scene's triangles (building excluded), one
  // row per call: the best of three frames.
  double time_tracer(const Tracer& t) const {
    const TracerOnScene on(t, index_);
    if (!on.scene) return 0;
    const Camera& cam = scene_.camera;
    std::vector<TracerRay> rays;
    for (int y = 0; y < cam.height; ++y)
      for (int x = 0; x < cam.width; ++x)
        if (auto r = on.seen(cam.ray_through(x + 0.5, y + 0.5), std::numeric_limits<double>::infinity())) rays.push_back(*r);
    std::vector<TraceAnswer> answers(rays.size());
    double best = std::numeric_limits<double>::infinity();
    for (int round = 0; round < 3 && !rays.empty(); ++round) {
      const auto start = std::chrono::steady_clock::now();
      for (std::size_t i = 0; i < rays.size(); i += static_cast<std::size_t>(cam.width)) {
        const std::size_t n = std::min<std::size_t>(cam.width, rays.size() - i);
        on.scene->nearest(std::span(rays).subspan(i, n), std::span(answers).subspan(i, n));
      }
      best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() * 1e9 /
                                static_cast<double>(rays.size()));
    }
    return std::isfinite(best) ? best : 0;
  }

  // A tracer's nearest triangle hit for each primary ray of row y, as scene hits.
  std::vector<SceneHit> trace_row(const TracerOnScene& on, int y) const {
    const Camera& cam = scene_.camera;
    std::vector<SceneHit> out(cam.width);
    if (!on.scene) return out;
    std::vector<TracerRay> rays;
    std::vector<int> at;
    for (int x = 0; x < cam.width; ++x)
      if (auto r = on.seen(cam.ray_through(x + 0.5, y + 0.5), std::numeric_limits<double>::infinity()))
        rays.push_back(*r), at.push_back(x);
    std::vector<TraceAnswer> answers(rays.size());
    on.scene->nearest(rays, answers);
    for (std::size_t i = 0; i < rays.size(); ++i) out[at[i]] = scene_hit(on, answers[i]);
    return out;
  }
  SceneHit scene_hit(const TracerOnScene& on, const TraceAnswer& a) const {
    if (!a.hit() || a.failure != HitFailure::none || a.triangle >= on.primitive_of.size() || !(a.t > 0)) return {};
    const std::int32_t id = on.primitive_of[a.triangle];
    return {index_.primitive(id).object, id, Hit{HitClass::hit, a.t}};
  }

  // The exact visible object of each pixel (after exact_pass).
  std::vector<int> exact_objects() const {
    std::vector<int> out(exact_.size());
    for (size_t i = 0; i < exact_.size(); ++i) out[i] = object_of(index_, exact_[i].visible);
    return out;
  }

 private:
  std::function<void(long, long)> stage_progress(const std::string& stage) const {
    if (!options_.progress) return {};
    return [this, stage](long done, long total) { options_.progress(stage, done, total); };
  }

  // light_terms for shade_point: the cosine of each light whose bit is set in `lit`.
  std::vector<double> light_terms(const std::vector<double>& cosines, std::uint64_t lit) const {
    std::vector<double> terms(cosines.size(), 0);
    for (size_t l = 0; l < cosines.size(); ++l)
      if (lit >> l & 1) terms[l] = cosines[l];
    return terms;
  }

  Vec3 exact_colour(auto& st, const Ray& ray, ExactPixel& e) {
    if (!e.visible.found()) return scene_.background;
    const Primitive& prim = index_.primitive(e.visible.primitive);
    const Vec3 p = st.tracer.hit_point(ray, e.visible);
    std::vector<double> cosines(scene_.lights.size(), 0);
    if (scene_.shading == Shading::diffuse) {
      const Vec3 n = facing_normal(prim.shape, p, ray);
      for (size_t l = 0; l < scene_.lights.size(); ++l) {
        cosines[l] = diffuse_cosine(p, n, scene_.lights[l]);
        if (!(cosines[l] > 0)) continue;
        e.facing |= std::uint64_t{1} << l;
        // The segment from the exact hit point (rounded) to the light: direction L − p in double.
        const Ray segment{p, scene_.lights[l].position - p};
        if (!st.tracer.blocked(segment, e.visible.primitive)) e.lit |= std::uint64_t{1} << l;
      }
    }
    return shade_point(scene_, scene_.objects[prim.object].color, p, ray, light_terms(cosines, e.lit));
  }

  // Whether the variant, for its kind, and the oracle, for the others, see a blocker on the
  // segment (0 < t < 1) other than `self`; `adjacent_blocker` tells whether a blocker of the
  // variant's kind is `self` or its neighbour (the acne test; asked only when it matters).
  bool variant_blocked(ExactTracer& tracer, const Contender& c, const TracerOnScene* on, const Ray& segment,
                       std::int32_t self, bool* adjacent_blocker) const {
    if (on) return tracer_blocked(tracer, *c.tracer, *on, segment, self, adjacent_blocker);
    const Variant& v = *c.variant;
    const ShapeKind kind = c.kind;
    bool blocked = false;
    double t_limit = 1;
    index_.traverse(kind, segment, t_limit, [&](std::int32_t id, const Shape& shape) {
      if (id == self) return false;
      const Hit h = v.intersect(segment, shape, HitRule::nearest_contact);
      if (h.cls == HitClass::miss || !h.has_t() || !(h.t < 1)) return false;
      blocked = true;
      if (adjacent_blocker && index_.same_or_adjacent(self, id)) *adjacent_blocker = true;
      return adjacent_blocker == nullptr || *adjacent_blocker;
    });
    if (blocked) return true;
    for (ShapeKind other : index_.shapes_used())
      if (other != kind && tracer.blocks(other, segment, self)) return true;
    return false;
  }

  // A tracer's shadow test on the segment (0 < t < 1): its any-hit list where it has one (so the
  // primitive the ray leaves is passed over, as for variants), else its nearest hit.
  bool tracer_blocked(ExactTracer& tracer, const Tracer& t, const TracerOnScene& on, const Ray& segment, std::int32_t self,
                      bool* adjacent_blocker) const {
    bool blocked = false;
    if (const auto r = on.scene ? on.seen(segment, 1) : std::nullopt) {
      std::vector<std::uint32_t> hits;
      if (t.has_all_hits) {
        AllHitsAnswer a;
        on.scene->all_hits(std::span(&*r, 1), std::span(&a, 1));
        if (a.failure == HitFailure::none && !a.unsupported) hits = a.triangles;
      } else {
        TraceAnswer a;
        on.scene->nearest(std::span(&*r, 1), std::span(&a, 1));
        if (a.failure == HitFailure::none && a.hit()) hits.push_back(a.triangle);
      }
      for (std::uint32_t h : hits) {
        if (h >= on.primitive_of.size() || on.primitive_of[h] == self) continue;
        blocked = true;
        if (adjacent_blocker && index_.same_or_adjacent(self, on.primitive_of[h])) *adjacent_blocker = true;
      }
    }
    if (blocked) return true;
    for (ShapeKind other : index_.shapes_used())
      if (other != ShapeKind::triangle && tracer.blocks(other, segment, self)) return true;
    return false;
  }

  void variant_pixel(ExactTracer& tracer, const Contender& c, const TracerOnScene* on, const SceneHit* traced, bool shaded,
                     int x, int y, PixelCounts& counts, VariantAudit* out, const Image* exact_image) {
    const ShapeKind kind = c.kind;
    const Camera& cam = scene_.camera;
    const size_t px = size_t(y) * cam.width + x;
    const Ray ray = cam.ray_through(x + 0.5, y + 0.5);
    const ExactPixel& e = exact_[px];
    // The variant's nearest among its kind, against the exact nearest among the other kinds.
    const SceneHit mine = traced ? *traced : trace_kind(index_, kind, *c.variant, HitRule::nearest_contact, ray);
    ExactContact others;
    for (ShapeKind k : index_.shapes_used())
      if (k != kind && tracer.before(ray, e.by_kind[static_cast<int>(k)], others)) others = e.by_kind[static_cast<int>(k)];
    SceneHit visible = mine;
    bool visible_is_variant = mine.primitive >= 0;
    if (others.found()) {
      const SceneHit theirs{index_.primitive(others.primitive).object, others.primitive, Hit{HitClass::enter, others.t}};
      if (mine.primitive < 0 || nearer(others.t, others.primitive, index_.primitive(others.primitive), mine, index_)) {
        visible = theirs;
        visible_is_variant = false;
      }
    }
    const int exact_object = object_of(index_, e.visible);
    const bool wrong = visible.object != exact_object;
    bool hole = false, false_hit = false;
    if (wrong) {
      ++counts.wrong;
      false_hit = exact_object < 0 || (visible.object >= 0 && visible.hit.t < e.visible.t);
      hole = !false_hit;
      ++(hole ? counts.holes : counts.false_hits);
    }
    if (!shaded) return;

    Vec3 colour = scene_.background;
    bool shadow_wrong = false, acne = false;
    if (visible.object >= 0) {
      const Primitive& prim = index_.primitive(visible.primitive);
      // The variant's own hit point and spawn (offset by the error bound) for its kind; the exact
      // point rounded, as in the exact render, where another kind is visible.
      const Vec3 p = visible_is_variant ? ray.at(visible.hit.t) : tracer.hit_point(ray, others);
      const Vec3 n = facing_normal(prim.shape, p, ray);
      // The contender's own spawn: pbrt's error bound for double code, Wächter & Binder's float
      // offset from the float hit point for float code (core/offset.h).
      const Precision own = c.tracer ? c.tracer->precision : c.variant->precision;
      const Vec3 start = visible_is_variant ? spawn_origin(ray, visible.hit.t, p, n, own) : p;
      std::vector<double> cosines(scene_.lights.size(), 0);
      std::uint64_t lit = 0;
      if (scene_.shading == Shading::diffuse) {
        for (size_t l = 0; l < scene_.lights.size(); ++l) {
          cosines[l] = diffuse_cosine(p, n, scene_.lights[l]);
          const std::uint64_t bit = std::uint64_t{1} << l;
          const bool compared = !wrong && (e.facing & bit);
          if (!(cosines[l] > 0) && !compared) continue;
          const Ray segment{start, scene_.lights[l].position - start};
          bool adjacent = false;
          const bool blocked = variant_blocked(tracer, c, on, segment, visible.primitive, nullptr);
          if (cosines[l] > 0 && !blocked) lit |= bit;
          if (compared && blocked == bool(e.lit & bit)) {  // blocked here, lit exactly, or the reverse
            shadow_wrong = true;
            if (blocked && visible_is_variant) {
              variant_blocked(tracer, c, on, segment, visible.primitive, &adjacent);
              acne = acne || adjacent;
            }
          }
        }
      }
      colour = shade_point(scene_, scene_.objects[prim.object].color, p, ray, light_terms(cosines, lit));
    }
    put(out->render, px, colour);
    counts.shadow_wrong += shadow_wrong;
    counts.acne += acne;
    if (hole) put(out->diff, px, kHoleColour);
    else if (false_hit) put(out->diff, px, kFalseHitColour);
    else if (acne) put(out->diff, px, kAcneColour);
    else if (shadow_wrong) put(out->diff, px, kShadowColour);
    else
      for (int k = 0; k < 3; ++k)
        out->diff.rgb[3 * px + k] = static_cast<std::uint8_t>(std::lround(kDiffDimming * exact_image->rgb[3 * px + k]));
  }

 private:
  const Scene& scene_;
  SceneIndex index_;
  const SceneAuditOptions& options_;
  int threads_;
  std::vector<ExactPixel> exact_;
};

}  // namespace

SceneAudit audit_scene(const Scene& scene, const SceneAuditOptions& options) {
  if (scene.lights.size() > kMaxLights)
    throw std::runtime_error("the audit handles up to " + std::to_string(kMaxLights) + " lights; this scene has " +
                             std::to_string(scene.lights.size()));
  SceneAudit audit;
  audit.width = scene.camera.width;
  audit.height = scene.camera.height;
  audit.warnings = scene.warnings;
  Auditor auditor(scene, options);
  audit.shapes = auditor.index().shapes_used();
  std::vector<Contender> chosen;
  for (const Variant* v : options.variants)
    for (ShapeKind k : audit.shapes)
      if (v->handles(k)) chosen.push_back({v, nullptr, k});
  const bool has_triangles = std::find(audit.shapes.begin(), audit.shapes.end(), ShapeKind::triangle) != audit.shapes.end();
  for (const Tracer* t : options.tracers)
    if (has_triangles) chosen.push_back({nullptr, t, ShapeKind::triangle});
    else audit.warnings.push_back("tracer " + t->name + " not audited: the scene has no triangles");

  auditor.exact_pass(true, &audit);
  const std::vector<int> original_objects = auditor.exact_objects();
  audit.variants.reserve(chosen.size());  // recommendation points into it
  for (const Contender& c : chosen) {
    VariantAudit va;
    va.variant = c.variant, va.tracer = c.tracer;
    va.shape = c.kind;
    va.name = c.tracer ? c.tracer->name : std::string(c.variant->name);
    va.precision = std::string(to_string(c.tracer ? c.tracer->precision : c.variant->precision));
    va.origin = c.tracer ? c.tracer->origin : std::string(c.variant->origin);
    va.label = va.name;
    if (c.variant && c.variant->all_shapes &&
        std::count_if(chosen.begin(), chosen.end(), [&](const Contender& o) { return o.variant == c.variant; }) > 1) {
      va.label += '@';
      va.label += to_string(c.kind);
    }
    va.counts = auditor.variant_pass(c, true, &va, &audit.exact);
    va.ns_per_ray = auditor.time_variant(c);
    if (c.variant && c.variant->external) va.stopped = c.variant->external->stop_reason();
    if (c.tracer && va.stopped.empty()) va.stopped = c.tracer->stop_reason();
    audit.variants.push_back(std::move(va));
  }
  for (ShapeKind kind : audit.shapes) {
    SceneAudit::Recommendation r{kind};
    for (const VariantAudit& va : audit.variants) {
      if (va.shape != kind) continue;
      r.audited = true;
      if (!va.exact_for_scene()) continue;
      if (!r.best || va.ns_per_ray < r.best->ns_per_ray) r.best = &va;
    }
    for (const VariantAudit& va : audit.variants)
      if (r.best && &va != r.best && va.shape == kind && va.exact_for_scene() &&
          va.ns_per_ray <= 1.1 * r.best->ns_per_ray)
        r.close.push_back(&va);
    audit.recommendation.push_back(r);
  }

  if (options.headroom) {
    audit.headroom = true;
    const std::vector<int> ks = headroom_exponents();
    for (VariantAudit& va : audit.variants) va.headroom_wrong.assign(ks.size(), -1);
    for (size_t i = 0; i < ks.size(); ++i) {
      bool any_clean = false;
      for (const VariantAudit& va : audit.variants) any_clean |= !va.first_wrong_log2_translate.has_value();
      if (!any_clean) break;
      const Scene moved = translated(scene, headroom_offset(ks[i]));
      for (const std::string& w : moved.warnings) audit.warnings.push_back("headroom k=" + std::to_string(ks[i]) + ": " + w);
      SceneAuditOptions quiet = options;
      if (options.progress)
        quiet.progress = [&, k = ks[i]](const std::string& stage, long done, long total) {
          options.progress("headroom k=" + std::to_string(k) + " " + stage, done, total);
        };
      Auditor moved_auditor(moved, quiet);
      moved_auditor.exact_pass(false, nullptr);
      const std::vector<int> moved_objects = moved_auditor.exact_objects();
      long changed = 0;
      for (size_t p = 0; p < moved_objects.size(); ++p) changed += moved_objects[p] != original_objects[p];
      audit.headroom_scene_changed.push_back(changed);
      for (size_t j = 0; j < chosen.size(); ++j) {
        VariantAudit& va = audit.variants[j];
        if (va.first_wrong_log2_translate) continue;
        const long wrong = moved_auditor.variant_pass(chosen[j], false, nullptr).wrong;
        va.headroom_wrong[i] = wrong;
        if (wrong > 0) {
          va.first_wrong_log2_translate = ks[i];
          if (i > 0) va.exact_up_to_log2_translate = ks[i - 1];
        }
      }
    }
    for (VariantAudit& va : audit.variants)
      if (!va.first_wrong_log2_translate) va.exact_up_to_log2_translate = ks.back();
  }
  return audit;
}

}  // namespace rayproof::studies
