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
#include "rayproof/core/scene_rays.h"
#include "rayproof/core/timing.h"
#include "rayproof/fuzz/tracer_campaign.h"
#include "rayproof/studies/offsets.h"
#include "rayproof/verify/exact_scene.h"

namespace rayproof::studies {

std::vector<int> headroom_exponents() {
  std::vector<int> k;
  for (int e = 0; e <= 62; e += 2) k.push_back(e);
  return k;
}

Vec3 headroom_offset(int k) { return std::ldexp(1.0, k) * Vec3(1, 0.75, 0.5); }

PixelCounts& PixelCounts::operator+=(const PixelCounts& o) {
  wrong += o.wrong, holes += o.holes, false_hits += o.false_hits, shadow_wrong += o.shadow_wrong, acne += o.acne;
  tracer_errors += o.tracer_errors;
  wrongly_shadowed += o.wrongly_shadowed, wrongly_lit += o.wrongly_lit;
  return *this;
}

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
  std::shared_ptr<const TriangleMesh> mesh;  // the scene's triangles in double, as the mesh cases hold them
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
    this->mesh = std::make_shared<const TriangleMesh>(mesh);
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
      : scene_(scene),
        index_(scene),
        options_(options),
        offsets_box_(offsets_scene_box(index_)),
        threads_(std::clamp(options.threads > 0 ? options.threads : default_threads(), 1, 256)) {}

  const Bounds& offsets_box() const { return offsets_box_; }

  const SceneIndex& index() const { return index_; }

  // The exact render: per pixel the nearest exact contact per kind and overall, and the exact
  // shadow status of each light (kept for the variants' passes), the colours and the counts.
  struct ExactRender {
    Image colours;
    double seconds = 0;
    long primary_rays = 0, shadow_rays = 0, rays_beyond_intervals = 0;
  };
  ExactRender exact_pass() {
    const Camera& cam = scene_.camera;
    exact_.assign(size_t(cam.width) * cam.height, ExactPixel{});
    ExactRender out{Image{cam.width, cam.height, std::vector<std::uint8_t>(3 * exact_.size())}};
    struct State {
      ExactTracer tracer;
      long shadow_rays = 0, beyond = 0;
      ExactRender* totals;  // finish() runs under for_rows's lock
      void finish() {
        totals->shadow_rays += shadow_rays;
        totals->rays_beyond_intervals += beyond;
      }
    };
    const Stopwatch exact_watch;
    for_rows<State>(
        threads_, cam.height,
        [&] {
          return State{ExactTracer(index_), 0, 0, &out};
        },
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
            put(out.colours, px, exact_colour(st, ray, e));
            st.shadow_rays += std::popcount(e.facing);
            if (st.tracer.beyond_intervals() != before) ++st.beyond;
          }
        },
        stage_progress("exact render"));
    out.seconds = exact_watch.seconds();
    out.primary_rays = static_cast<long>(exact_.size());
    exact_image_ = out.colours;  // dimmed under each variant's diff marks
    return out;
  }

  // What one pass of a contender yields: its pixel counts, shadows included; when drawn, its
  // render, the diff image (its wrong pixels over the dimmed exact render) and its wrong pixels
  // as cases (variants only: a tracer's triangles are judged as a mesh).
  enum class Drawn { counts_only, images_and_cases };
  struct PassOutput {
    PixelCounts counts;
    Image render, diff;
    std::vector<WrongPixelCase> cases;
    std::vector<MeshCase> mesh_cases;  // a tracer's
    long cases_left_out = 0, pixels_right_as_mesh_cases = 0;
    std::string stopped;  // a tracer that built nothing: why
  };

  // One contender for its kind, the other kinds exact (exact_pass's per-kind contacts).
  PassOutput variant_pass(const Contender& c, Drawn drawn) {
    const Camera& cam = scene_.camera;
    PassOutput out;
    std::unique_ptr<TracerOnScene> tracer;
    if (c.tracer) {
      tracer = std::make_unique<TracerOnScene>(*c.tracer, index_);
      if (!tracer->failure.empty()) out.stopped = c.tracer->name + ": " + tracer->failure;
    }
    const bool draw = drawn == Drawn::images_and_cases;
    if (draw) {
      out.render = Image{cam.width, cam.height, std::vector<std::uint8_t>(3 * exact_.size())};
      out.diff = out.render;
    }
    std::vector<RowResult> per_row(cam.height);
    const double reach = c.variant ? reach_of(*c.variant, c.kind) : kLeafReach;
    struct State {
      ExactTracer tracer;
      void finish() {}
    };
    for_rows<State>(
        threads_, cam.height, [&] { return State{ExactTracer(index_)}; },
        [&](State& st, int y) {
          // The row's primary rays in one call: a tracer's, or the variant's (a plugin traces them
          // where it runs, in one round trip).
          const std::vector<SceneHit> row = tracer ? trace_row(*tracer, y) : trace_row(*c.variant, c.kind, y);
          ShadowBatch shadows;
          const bool batch_shadows = c.variant && c.variant->external;
          if (batch_shadows) {  // a first pass records the row's shadow segments, asked in one call
            RowResult ignored;
            for (int x = 0; x < cam.width; ++x)
              variant_pixel(st.tracer, {c, nullptr, false, &shadows, reach}, row[x], x, y, ignored);
            shadows.answers.resize(shadows.asked.size());
            trace_scene_rays(*c.variant, index_.of_kind(c.kind), HitRule::nearest_contact, shadows.asked,
                             shadows.answers, nullptr, reach);
            shadows.recording = false;
          }
          for (int x = 0; x < cam.width; ++x) {
            const PixelVerdict v =
                variant_pixel(st.tracer, {c, tracer.get(), draw, batch_shadows ? &shadows : nullptr, reach}, row[x], x,
                              y, per_row[y]);
            if (draw) paint(out, size_t(y) * cam.width + x, v);
          }
        },
        stage_progress((c.tracer ? c.tracer->name : std::string(c.variant->name)) + " (" +
                       std::string(to_string(c.kind)) + ")"));
    for (RowResult& r : per_row) {
      out.counts += r.counts;
      for (WrongPixelCase& w : r.cases)
        if (out.cases.size() < kMaxCasesPerVariant || tracer)  // a tracer's are picked from all of them
          out.cases.push_back(std::move(w));
        else
          ++out.cases_left_out;
    }
    if (tracer && tracer->scene && draw) {
      const std::vector<WrongPixelCase> primary = std::move(out.cases);  // the sink kept primary rays only
      out.cases.clear();
      out.mesh_cases = tracer_mesh_cases(*c.tracer, *tracer, primary, out.pixels_right_as_mesh_cases);
      out.cases_left_out =
          std::max(0L, out.counts.wrong - static_cast<long>(out.mesh_cases.size()) - out.pixels_right_as_mesh_cases);
    }
    return out;
  }

  // A tracer's wrong primary pixels as mesh cases: up to kMaxMeshCasesPerTracer of them, spread
  // evenly over `wrong`, each judged on the scene's triangles as one mesh (the tracer rebuilt for
  // it, as `check` will) and shrunk as `fuzz --tracer` shrinks its findings. A pixel whose mesh
  // case the judge calls right is counted in `right` (the pixel was wrong only among other kinds).
  std::vector<MeshCase> tracer_mesh_cases(const Tracer& t, const TracerOnScene& on,
                                          const std::vector<WrongPixelCase>& wrong, long& right) const {
    std::vector<MeshCase> out;
    const VerdictSettings settings;
    const std::size_t n = std::min(wrong.size(), kMaxMeshCasesPerTracer);
    for (std::size_t i = 0; i < n; ++i) {
      const WrongPixelCase& w = wrong[i * wrong.size() / n];
      MeshCase whole;
      whole.id = t.name + "-" + std::to_string(w.x) + "-" + std::to_string(w.y) + "-" + w.kind;
      whole.mesh = on.mesh;
      whole.ray = TracerRay{w.ray, 0, std::numeric_limits<double>::infinity()};
      const std::optional<MeshCase> seen = as_seen_by(t, whole);
      if (!seen) continue;
      const TracerOutcome found = judge_tracer_on_case(t, *seen, settings);
      if (found.kind == TraceKind::right) {
        ++right;
        continue;
      }
      fuzz::ShrunkFinding kept = fuzz::shrink_finding(t, *seen, found, settings, 300);
      MeshCase& c = kept.c;
      const TracerOutcome& now = kept.now;
      c.found = {{"tracer", t.name},
                 {"kind", std::string(to_string(now.kind))},
                 {"pixel", {w.x, w.y}},
                 {"pixel_verdict", w.kind},
                 {"mode", "nearest"},
                 {"reported", reported_json(now, false)},
                 {"precision", std::string(to_string(t.precision))},
                 {"triangles_found_in", seen->mesh->triangle_count()}};
      add_verdict_fields(c.found, now);
      out.push_back(std::move(c));
    }
    return out;
  }

  // ns per primary ray of the variant against its shape's primitives, on one thread: the
  // fastest of three rounds of whole frames (each at least 0.05 s), so that a busy moment on the
  // machine does not decide a recommendation. External code is timed where it runs: one frame,
  // each leaf test's round trip replaced by the time the worker spent in the code (a plugin's
  // inner_seconds); `round_trip` gets the frame's wall time, pipe included. Code that cannot be
  // timed where it runs (an --exec command) is charged its round trips.
  struct Timing {
    double ns_per_ray = 0, round_trip_ns_per_ray = 0;
    bool in_worker = false;
  };
  Timing time_variant(const Contender& c) const {
    if (c.tracer) return {time_tracer(*c.tracer), 0, false};
    const Variant& v = *c.variant;
    const Camera& cam = scene_.camera;
    const double rays = double(cam.width) * cam.height;
    if (v.external) {
      // Whole frames, a row per call; the fastest of three. A plugin traces each row where it runs
      // (rayproof's traversal with the plugin at the leaves) and is charged the time it spent
      // there; code that cannot (an --exec command) is charged its round trips.
      double own = std::numeric_limits<double>::infinity(), wall = own, checksum = 0;
      bool timed_inside = true;
      for (int round = 0; round < 3; ++round) {
        double inside = 0;
        const Stopwatch frame;
        for (int y = 0; y < cam.height; ++y) {
          AnswerTiming timing;
          for (const SceneHit& h : trace_row(v, c.kind, y, &timing)) checksum += h.primitive;
          if (timing.inner_seconds >= 0)
            inside += timing.inner_seconds;
          else
            timed_inside = false;
        }
        wall = std::min(wall, frame.seconds());
        own = std::min(own, inside);
      }
      keep_alive(checksum);
      if (!timed_inside) own = wall;
      return {own * 1e9 / rays, wall * 1e9 / rays, timed_inside};
    }
    double checksum = 0;
    const double reach = reach_of(v, c.kind);
    const double best = fastest_of(3, [&] {  // ns per ray of whole frames, at least 0.05 s a round
      long traced = 0;
      double seconds = 0;
      const Stopwatch round;
      do {
        for (int y = 0; y < cam.height; ++y)
          for (int x = 0; x < cam.width; ++x) {
            const SceneHit h =
                trace_kind(index_, c.kind, v, HitRule::nearest_contact, cam.ray_through(x + 0.5, y + 0.5), reach);
            checksum += h.primitive;
            ++traced;
          }
        seconds = round.seconds();
      } while (seconds < 0.05);
      return seconds * 1e9 / static_cast<double>(traced);
    });
    keep_alive(checksum);  // keeps the traced answers alive
    return {best, 0, false};
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
        if (auto r = on.seen(cam.ray_through(x + 0.5, y + 0.5), std::numeric_limits<double>::infinity()))
          rays.push_back(*r);
    std::vector<TraceAnswer> answers(rays.size());
    if (rays.empty()) return 0;
    return fastest_of(3, [&] {
      const Stopwatch frame;
      for (std::size_t i = 0; i < rays.size(); i += static_cast<std::size_t>(cam.width)) {
        const std::size_t n = std::min<std::size_t>(cam.width, rays.size() - i);
        on.scene->nearest(std::span(rays).subspan(i, n), std::span(answers).subspan(i, n));
      }
      return frame.seconds() * 1e9 / static_cast<double>(rays.size());
    });
  }

  // A tracer's nearest triangle hit for each primary ray of row y, as scene hits.
  // Row y's primary rays (through the pixel centres) with variant v at the leaves of its kind.
  std::vector<SceneHit> trace_row(const Variant& v, ShapeKind kind, int y, AnswerTiming* timing = nullptr) const {
    const Camera& cam = scene_.camera;
    std::vector<SceneRay> rays(cam.width);
    for (int x = 0; x < cam.width; ++x) rays[x].ray = cam.ray_through(x + 0.5, y + 0.5);
    std::vector<SceneRayAnswer> answers(rays.size());
    trace_scene_rays(v, index_.of_kind(kind), HitRule::nearest_contact, rays, answers, timing, reach_of(v, kind));
    std::vector<SceneHit> out(rays.size());
    for (size_t x = 0; x < rays.size(); ++x)
      if (answers[x].primitive >= 0)
        out[x] = {index_.primitive(answers[x].primitive).object, answers[x].primitive, answers[x].answer};
    return out;
  }

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
    if (!a.hit() || a.failure != AnswerFailure::none) return {};
    if (a.triangle >= on.primitive_of.size() || !(a.t > 0)) {
      SceneHit invalid;
      invalid.invalid = true;
      return invalid;
    }
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

  // What a shadow ray met: whether it is blocked, and the blocker of the contender's kind that
  // decided it (−1: none, or only another kind, which the oracle judges).
  // A row's shadow segments of the variant's kind, traced in one call (external code: one round
  // trip, not one per leaf test): a first pass over the row records the segments variant_pixel
  // asks for, the second reads their answers in the same order. (The acne test's neighbour-only
  // question, asked only where a shadow is wrong, stays leaf by leaf.)
  struct ShadowBatch {
    bool recording = true;
    std::vector<SceneRay> asked;
    std::vector<SceneRayAnswer> answers;
    std::size_t next = 0;
  };
  // What one pass of variant_pixel needs besides the pixel.
  struct PassContext {
    const Contender& c;
    const TracerOnScene* on;         // a tracer's scene, or null for a variant
    bool keep_cases;                 // write wrong pixels as cases
    ShadowBatch* shadows = nullptr;  // null: shadow segments asked one by one
    double reach = kLeafReach;       // how far off each segment the variant is asked (reach_of)
  };
  struct Blocker {
    bool blocked = false;
    std::int32_t primitive = -1;
  };

  // The variant, for its kind, and the oracle, for the others, on the segment (0 < t < 1),
  // `self` passed over. With `adjacent_only`, only a blocker of the variant's kind that is `self`'s
  // neighbour counts (the acne test; asked only when it matters).
  // While pass.shadows records, the segment is only noted (and the answer means nothing).
  Blocker variant_blocked(ExactTracer& tracer, const PassContext& pass, const Ray& segment, std::int32_t self,
                          bool adjacent_only = false) const {
    const Contender& c = pass.c;
    if (pass.on) return tracer_blocked(tracer, *c.tracer, *pass.on, segment, self, adjacent_only);
    Blocker b;
    if (pass.shadows && !adjacent_only) {
      ShadowBatch& batch = *pass.shadows;
      if (batch.recording) {
        batch.asked.push_back({segment, self, true});
        return b;
      }
      const SceneRayAnswer& a = batch.answers.at(batch.next++);
      if (a.primitive >= 0) b = {true, a.primitive};
    } else {
      const Variant& v = *c.variant;
      double t_limit = 1;
      index_.of_kind(c.kind).traverse(
          segment, t_limit,
          [&](std::int32_t id, const Shape& shape) {
            if (id == self || (adjacent_only && !index_.same_or_adjacent(self, id))) return false;
            const Hit h = v.intersect(segment, shape, HitRule::nearest_contact);
            if (h.cls == HitClass::miss || !h.has_t() || !(h.t < 1)) return false;
            b = {true, id};
            return true;
          },
          BaselineLanes{}, pass.reach);
    }
    if (b.blocked || adjacent_only) return b;
    for (ShapeKind other : index_.shapes_used())
      if (other != c.kind && tracer.blocks(other, segment, self)) return {true, -1};
    return b;
  }

  // A tracer's shadow test on the segment (0 < t < 1): its any-hit list where it has one (so the
  // primitive the ray leaves is passed over, as for variants), else its nearest hit.
  Blocker tracer_blocked(ExactTracer& tracer, const Tracer& t, const TracerOnScene& on, const Ray& segment,
                         std::int32_t self, bool adjacent_only) const {
    if (const auto r = on.scene ? on.seen(segment, 1) : std::nullopt) {
      std::vector<std::uint32_t> hits;
      if (t.has_all_hits) {
        AllHitsAnswer a;
        on.scene->all_hits(std::span(&*r, 1), std::span(&a, 1));
        if (a.failure == AnswerFailure::none && !a.unsupported) hits = a.triangles;
      } else {
        TraceAnswer a;
        on.scene->nearest(std::span(&*r, 1), std::span(&a, 1));
        if (a.failure == AnswerFailure::none && a.hit()) hits.push_back(a.triangle);
      }
      for (std::uint32_t h : hits) {
        if (h >= on.primitive_of.size() || on.primitive_of[h] == self) continue;
        if (adjacent_only && !index_.same_or_adjacent(self, on.primitive_of[h])) continue;
        return {true, on.primitive_of[h]};
      }
    }
    if (adjacent_only) return {};
    for (ShapeKind other : index_.shapes_used())
      if (other != ShapeKind::triangle && tracer.blocks(other, segment, self)) return {true, -1};
    return {};
  }

  struct RowResult {
    PixelCounts counts;
    std::vector<WrongPixelCase> cases;
  };

  // Where a pixel's wrong answer is written as a case (variant_pixel's helpers add to it). A
  // tracer's are primary rays only: they become mesh cases (tracer_mesh_cases), and a shadow
  // error is counted, not written.
  struct CaseSink {
    bool keep;
    bool primary_only;
    int x, y;
    std::vector<WrongPixelCase>& cases;
    const SceneIndex& index;
    void add(const char* what, int light, bool shadow_ray, const Ray& r, std::int32_t primitive) {
      if (keep && primitive >= 0 && !(primary_only && shadow_ray) && cases.size() < kMaxCasesPerVariant)
        cases.push_back({x, y, what, light, shadow_ray, r, primitive, index.primitive(primitive).shape});
    }
  };

  // The primary ray's verdict: what is visible (the contender's nearest among its kind, or the
  // exact nearest among the other kinds), and whether that is the wrong object.
  struct Primary {
    SceneHit visible;
    bool visible_is_variant = false;
    ExactContact others;  // the exact nearest among the other kinds
    bool wrong = false, hole = false, false_hit = false;
  };
  Primary judge_primary(ExactTracer& tracer, ShapeKind kind, const Ray& ray, const ExactPixel& e, const SceneHit& mine,
                        CaseSink& sink) const {
    Primary v;
    for (ShapeKind k : index_.shapes_used())
      if (k != kind && tracer.before(ray, e.by_kind[static_cast<int>(k)], v.others))
        v.others = e.by_kind[static_cast<int>(k)];
    v.visible = mine;
    v.visible_is_variant = mine.primitive >= 0;
    if (v.others.found() && (mine.primitive < 0 || nearer(v.others.t, v.others.primitive, mine, index_))) {
      v.visible = {index_.primitive(v.others.primitive).object, v.others.primitive, Hit{HitClass::enter, v.others.t}};
      v.visible_is_variant = false;
    }
    const int exact_object = object_of(index_, e.visible);
    v.wrong = v.visible.object != exact_object && !mine.invalid;
    if (!v.wrong) return v;
    v.false_hit = exact_object < 0 || (v.visible.object >= 0 && v.visible.hit.t < e.visible.t);
    v.hole = !v.false_hit;
    // The primitive of the contender's kind that decided it: the one it missed, or the one it hit.
    if (v.hole && kind_of(index_.primitive(e.visible.primitive).shape) == kind)
      sink.add("hole", -1, false, ray, e.visible.primitive);
    if (v.false_hit && v.visible_is_variant) sink.add("false_hit", -1, false, ray, v.visible.primitive);
    return v;
  }

  // The shadow rays from the visible point, against the exact shadow status of each light the
  // exact hit point faces (on pixels whose object is right), and the pixel's colour.
  struct ShadowVerdict {
    Vec3 colour;
    bool shadow_wrong = false, acne = false, wrongly_shadowed = false, wrongly_lit = false;
  };
  ShadowVerdict judge_shadows(ExactTracer& tracer, const PassContext& pass, const Ray& ray, const ExactPixel& e,
                              const Primary& v, CaseSink& sink) const {
    ShadowVerdict out{scene_.background};
    if (v.visible.object < 0) return out;
    const Contender& c = pass.c;
    const Primitive& prim = index_.primitive(v.visible.primitive);
    // The contender's own hit point and spawn for its kind; the exact point rounded, as in the
    // exact render, where another kind is visible. Its spawn: pbrt's error bound for double code,
    // Wächter & Binder's float offset from the float hit point for float code (core/offset.h),
    // or its proved offset (--offset proved).
    const Vec3 p = v.visible_is_variant ? ray.at(v.visible.hit.t) : tracer.hit_point(ray, v.others);
    const Vec3 n = facing_normal(prim.shape, p, ray);
    const Precision own = c.tracer ? c.tracer->precision : c.variant->precision;
    Vec3 start = v.visible_is_variant ? spawn_origin(ray, v.visible.hit.t, p, n, own) : p;
    if (v.visible_is_variant && c.variant && options_.spawn_proved)
      start = proved_spawn_origin(*c.variant, prim.shape, offsets_box_, ray, v.visible.hit.t, n).value_or(start);
    std::vector<double> cosines(scene_.lights.size(), 0);
    std::uint64_t lit = 0;
    for (size_t l = 0; scene_.shading == Shading::diffuse && l < scene_.lights.size(); ++l) {
      cosines[l] = diffuse_cosine(p, n, scene_.lights[l]);
      const std::uint64_t bit = std::uint64_t{1} << l;
      const bool compared = !v.wrong && (e.facing & bit);
      if (!(cosines[l] > 0) && !compared) continue;
      const Ray segment{start, scene_.lights[l].position - start};
      const Blocker blocker = variant_blocked(tracer, pass, segment, v.visible.primitive);
      if (pass.shadows && pass.shadows->recording) continue;
      if (cosines[l] > 0 && !blocker.blocked) lit |= bit;
      if (!compared || blocker.blocked != bool(e.lit & bit)) continue;  // agrees with the exact status
      out.shadow_wrong = true;
      if (blocker.blocked) {
        out.wrongly_shadowed = true;
        const Blocker neighbour =
            v.visible_is_variant ? variant_blocked(tracer, pass, segment, v.visible.primitive, true) : Blocker{};
        out.acne = out.acne || neighbour.blocked;
        if (neighbour.blocked)
          sink.add("acne", int(l), true, segment, neighbour.primitive);
        else if (blocker.primitive >= 0)
          sink.add("wrongly_shadowed", int(l), true, segment, blocker.primitive);
        else if (v.visible_is_variant)
          sink.add("wrongly_shadowed", int(l), false, ray, v.visible.primitive);
      } else {
        out.wrongly_lit = true;
        // The exact blocker of the contender's kind on its own segment, if one is; else the
        // segment started elsewhere than the exact one: the primary hit's t moved it.
        const ExactContact should = tracer.nearest(c.kind, segment);
        if (should.found() && should.primitive != v.visible.primitive && should.t < 1)
          sink.add("wrongly_lit", int(l), true, segment, should.primitive);
        else if (v.visible_is_variant)
          sink.add("wrongly_lit", int(l), false, ray, v.visible.primitive);
      }
    }
    out.colour = shade_point(scene_, scene_.objects[prim.object].color, p, ray, light_terms(cosines, lit));
    return out;
  }

  // One pixel of a contender's pass: counted into `row`; what to paint returned.
  struct PixelVerdict {
    Vec3 colour;
    std::optional<std::array<std::uint8_t, 3>> mark;  // the diff image's colour; none: the exact render dimmed
  };
  PixelVerdict variant_pixel(ExactTracer& tracer, const PassContext& pass, const SceneHit& mine, int x, int y,
                             RowResult& row) {
    const Camera& cam = scene_.camera;
    const Ray ray = cam.ray_through(x + 0.5, y + 0.5);
    const ExactPixel& e = exact_[size_t(y) * cam.width + x];
    CaseSink sink{pass.keep_cases, pass.on != nullptr, x, y, row.cases, index_};
    const Primary v = judge_primary(tracer, pass.c.kind, ray, e, mine, sink);
    const ShadowVerdict s = judge_shadows(tracer, pass, ray, e, v, sink);
    PixelCounts& counts = row.counts;
    if (mine.invalid) ++counts.tracer_errors;  // not a hole: an answer no ray can have
    counts.wrong += v.wrong, counts.holes += v.hole, counts.false_hits += v.false_hit;
    counts.shadow_wrong += s.shadow_wrong;
    counts.acne += s.acne;
    counts.wrongly_shadowed += s.wrongly_shadowed;
    counts.wrongly_lit += s.wrongly_lit;
    if (v.hole) return {s.colour, kHoleColour};
    if (v.false_hit) return {s.colour, kFalseHitColour};
    if (s.acne) return {s.colour, kAcneColour};
    if (s.shadow_wrong) return {s.colour, kShadowColour};
    return {s.colour, std::nullopt};
  }

  void paint(PassOutput& out, size_t px, const PixelVerdict& v) const {
    put(out.render, px, v.colour);
    if (v.mark) return put(out.diff, px, *v.mark);
    for (int k = 0; k < 3; ++k)
      out.diff.rgb[3 * px + k] = static_cast<std::uint8_t>(std::lround(kDiffDimming * exact_image_.rgb[3 * px + k]));
  }

 private:
  const Scene& scene_;
  SceneIndex index_;
  const SceneAuditOptions& options_;
  Bounds offsets_box_;  // the domain of the proved offsets (offsets.md): the scene's box
  int threads_;
  std::vector<ExactPixel> exact_;
  Image exact_image_;  // exact_pass's colours
  // Per variant and kind, the reach it is traced with in this scene (calibrated_reach on the
  // camera's sample), found on first use.
  mutable std::mutex reach_mutex_;
  mutable std::map<std::pair<const Variant*, ShapeKind>, double> reach_;

  double reach_of(const Variant& v, ShapeKind kind) const {
    const std::lock_guard lock(reach_mutex_);
    auto [at, inserted] = reach_.try_emplace({&v, kind}, 0.0);
    if (inserted)
      at->second = calibrated_reach(v, index_.of_kind(kind), HitRule::nearest_contact, primary_sample(scene_.camera));
    return at->second;
  }
};

}  // namespace

std::vector<SceneAudit::Recommendation> recommend(const std::vector<VariantAudit>& rows,
                                                  const std::vector<ShapeKind>& shapes) {
  std::vector<SceneAudit::Recommendation> out;
  for (ShapeKind kind : shapes) {
    SceneAudit::Recommendation r{kind};
    for (const VariantAudit& va : rows) {
      if (va.shape != kind) continue;
      r.audited = true;
      if (va.exact_for_scene() && (!r.best || va.ns_per_ray < r.best->ns_per_ray)) r.best = &va;
    }
    for (const VariantAudit& va : rows)
      if (r.best && &va != r.best && va.shape == kind && va.exact_for_scene() &&
          va.ns_per_ray <= 1.1 * r.best->ns_per_ray)
        r.close.push_back(&va);
    out.push_back(r);
  }
  return out;
}

namespace {

// Headroom: the scene translated by each 2^k·(1, 0.75, 0.5) in turn (added to its own
// coordinates), each variant still clean re-audited, shadows included (what exact_for_scene
// counts), until every variant has failed or translating drops triangles as degenerate.
void audit_headroom(const Scene& scene, const SceneAuditOptions& options, const std::vector<Contender>& chosen,
                    const std::vector<int>& original_objects, SceneAudit& audit) {
  audit.headroom = true;
  const std::vector<int> ks = headroom_exponents();
  for (VariantAudit& va : audit.variants) va.headroom_wrong.assign(ks.size(), -1);
  for (size_t i = 0; i < ks.size(); ++i) {
    bool any_clean = false;
    for (const VariantAudit& va : audit.variants) any_clean |= !va.first_wrong_log2_translate.has_value();
    if (!any_clean) break;
    const Scene moved = translated(scene, headroom_offset(ks[i]));
    if (!moved.warnings.empty()) {
      audit.headroom_collapsed_at = ks[i];
      for (const std::string& w : moved.warnings)
        audit.warnings.push_back("headroom k=" + std::to_string(ks[i]) + ": " + w +
                                 "; the scene is no longer itself, so no k from here on is rendered");
      break;
    }
    SceneAuditOptions quiet = options;
    if (options.progress)
      quiet.progress = [&, k = ks[i]](const std::string& stage, long done, long total) {
        options.progress("headroom k=" + std::to_string(k) + " " + stage, done, total);
      };
    Auditor moved_auditor(moved, quiet);
    moved_auditor.exact_pass();
    const std::vector<int> moved_objects = moved_auditor.exact_objects();
    long changed = 0;
    for (size_t p = 0; p < moved_objects.size(); ++p) changed += moved_objects[p] != original_objects[p];
    audit.headroom_scene_changed.push_back(changed);
    for (size_t j = 0; j < chosen.size(); ++j) {
      VariantAudit& va = audit.variants[j];
      if (va.first_wrong_log2_translate) continue;
      const long wrong = moved_auditor.variant_pass(chosen[j], Auditor::Drawn::counts_only).counts.any_wrong();
      va.headroom_wrong[i] = wrong;
      if (wrong > 0) va.first_wrong_log2_translate = ks[i];
    }
  }
  // The last clean exponent, for a variant exact on the scene itself: before its first wrong k,
  // before the collapse, or the last k.
  for (VariantAudit& va : audit.variants) {
    if (!va.exact_for_scene()) continue;
    const int end = va.first_wrong_log2_translate.value_or(audit.headroom_collapsed_at.value_or(ks.back() + 1));
    if (const auto it = std::lower_bound(ks.begin(), ks.end(), end); it != ks.begin())
      va.exact_up_to_log2_translate = *std::prev(it);
  }
}

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
  const bool has_triangles =
      std::find(audit.shapes.begin(), audit.shapes.end(), ShapeKind::triangle) != audit.shapes.end();
  for (const Tracer* t : options.tracers)
    if (has_triangles)
      chosen.push_back({nullptr, t, ShapeKind::triangle});
    else
      audit.warnings.push_back("tracer " + t->name + " not audited: the scene has no triangles");

  Auditor::ExactRender exact = auditor.exact_pass();
  audit.exact = std::move(exact.colours);
  audit.exact_seconds = exact.seconds;
  audit.primary_rays = exact.primary_rays;
  audit.shadow_rays = exact.shadow_rays;
  audit.rays_beyond_intervals = exact.rays_beyond_intervals;
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
    Auditor::PassOutput pass = auditor.variant_pass(c, Auditor::Drawn::images_and_cases);
    va.counts = pass.counts;
    va.render = std::move(pass.render), va.diff = std::move(pass.diff);
    va.cases = std::move(pass.cases), va.cases_left_out = pass.cases_left_out;
    va.mesh_cases = std::move(pass.mesh_cases), va.pixels_right_as_mesh_cases = pass.pixels_right_as_mesh_cases;
    va.stopped = std::move(pass.stopped);
    if (c.variant) va.proved_offset_ulps = scene_needs_ulps(auditor.index(), *c.variant, auditor.offsets_box());
    const auto timing = auditor.time_variant(c);
    va.ns_per_ray = timing.ns_per_ray;
    va.round_trip_ns_per_ray = timing.round_trip_ns_per_ray;
    va.timed_in_worker = timing.in_worker;
    if (c.variant && c.variant->external) va.stopped = c.variant->external->stop_reason();
    if (c.tracer && va.stopped.empty()) va.stopped = c.tracer->stop_reason();
    if (!va.stopped.empty())  // it answered "stopped" at no cost: a time would be one it never had
      va.ns_per_ray = va.round_trip_ns_per_ray = std::numeric_limits<double>::quiet_NaN();
    audit.variants.push_back(std::move(va));
  }
  audit.recommendation = recommend(audit.variants, audit.shapes);
  if (options.headroom) audit_headroom(scene, options, chosen, auditor.exact_objects(), audit);
  return audit;
}

}  // namespace rayproof::studies
