// Tracer plugins (docs/spec/tracer.md) in worker processes: rayproof never loads the library
// itself (a short-lived worker reads its table, so load-time code is the library's to answer
// for); every build, nearest, all_hits and release runs in a worker — this executable
// re-executed with RAYPROOF_TRACER_WORKER set — which holds one scene at a time. Mesh, rays and
// answers travel through one shared memory file (grown as needed); each request costs two pipe
// wake-ups. The worker writes the index of the ray it is on before each call, so when it dies or
// hangs the ray to blame is known and every earlier answer is kept. When the library forks, the
// copy leaves without answering and the worker marks the request, which is then reported.
#include <dlfcn.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <deque>
#include <memory>
#include <mutex>
#include <stdexcept>

#include "rayproof/core/json_fields.h"
#include "rayproof/core/timing.h"
#include "rayproof/peers/child_process.h"
#include "rayproof/peers/library_table.h"
#include "rayproof/peers/process_pool.h"
#include "rayproof/peers/tracers.h"
#include "rayproof/peers/loaded_code.h"
#include "rayproof/peers/worker_channel.h"
#include "rayproof/tracer.h"

namespace rayproof::peers {

namespace {

constexpr const char* kWorkerEnv = "RAYPROOF_TRACER_WORKER";  // "table:PATH" or "serve:PATH"

// A row of the ABI 1 table: ABI 2's without `range` (tracer.md).
struct rayproof_tracer_abi1 {
  const char* name;
  const char* precision;
  const char* source;
  void* (*build)(const struct rayproof_mesh* mesh);
  void (*nearest)(void* scene, const struct rayproof_ray* rays, size_t count, struct rayproof_trace* out);
  size_t (*all_hits)(void* scene, const struct rayproof_ray* ray, uint32_t* triangles, size_t capacity);
  void (*release)(void* scene);
};

enum class Op : std::uint32_t { build = 1, nearest = 2, all_hits = 3, release = 4 };

// The start of the shared file. Build: the vertices (double) then the indices (u32) follow.
// nearest: rays then answers. all_hits: rays, then per ray its count (u64), then the triangles
// of every answered ray back to back (up to hits_capacity; the worker stops at a ray that does
// not fit and rayproof asks again from there).
struct Header {
  ChannelHeader channel;  // progress: the index of the ray the worker is on
  Op op;
  std::uint32_t tracer;
  std::uint32_t built;  // build: 1 when the tracer returned a scene
  std::uint64_t vertex_count, triangle_count, ray_count, hits_capacity, answered;
  double inner_seconds;
};
constexpr std::size_t kData = 256;  // data starts here (the header rounded up)
static_assert(sizeof(Header) <= kData);

std::size_t build_bytes(std::uint64_t v, std::uint64_t t) { return kData + 24 * v + 12 * t; }
std::size_t nearest_bytes(std::uint64_t n) { return kData + n * (sizeof(rayproof_ray) + sizeof(rayproof_trace)); }
std::size_t all_hits_bytes(std::uint64_t n, std::uint64_t cap) {
  return kData + n * (sizeof(rayproof_ray) + 8) + 4 * cap;
}

// ----------------------------------------------------------------- the worker
// Loads the library, then either writes its table as one JSON line and ends (mode "table") or
// serves requests until the request pipe closes (mode "serve").
[[noreturn]] void run_worker(const std::string& setting) {
  const WorkerStart start = start_worker(setting);
  int count = 0;
  std::string error;
  // ABI 2 first, then 1, whose rows lack `range` (a shorter stride): both copied into ABI 2 rows.
  std::vector<rayproof_tracer> rows;
  if (const auto* t2 = load_library_table<rayproof_tracer>(start.path, "rayproof_tracers", 2, "rayproof/tracer.h",
                                                           "tracers", count, error)) {
    rows.assign(t2, t2 + count);
  } else if (is_forked_copy()) {
    ::_exit(0);
  } else if (error.find("returned NULL") != std::string::npos) {
    error.clear();
    if (const auto* t1 = load_library_table<rayproof_tracer_abi1>(start.path, "rayproof_tracers", 1,
                                                                  "rayproof/tracer.h", "tracers", count, error))
      for (int i = 0; i < count; ++i)
        rows.push_back({t1[i].name, t1[i].precision, t1[i].source, t1[i].build, t1[i].nearest, t1[i].all_hits,
                        t1[i].release, nullptr});
    else if (error.find("returned NULL") != std::string::npos)
      error = "rayproof_tracers returned NULL for ABI 2 and for ABI 1 (built for another ABI?)";
  }
  const rayproof_tracer* table = rows.empty() ? nullptr : rows.data();
  report_table_or_go_on(start, table, count, error, "tracers", [](const rayproof_tracer& t) {
    return json{{"name", describe_string(t.name)},     {"precision", describe_string(t.precision)},
                {"source", describe_string(t.source)}, {"build", t.build != nullptr},
                {"nearest", t.nearest != nullptr},     {"all_hits", t.all_hits != nullptr},
                {"range", describe_string(t.range)}};
  });
  void* scene = nullptr;
  const rayproof_tracer* scene_of = nullptr;
  // After every library call: a copy of this worker (the library forked) never answers.
  auto leave_if_copy = [] {
    if (is_forked_copy()) ::_exit(0);
  };
  std::vector<std::uint32_t> buffer(64);
  std::uint64_t built_triangles = 0;  // the built mesh's: bounds an any-hit list (below)
  std::vector<double> kept_vertices;  // the built scene's mesh, alive until its release
  std::vector<std::uint32_t> kept_indices;
  serve_requests([&](char* file) {
    auto* h = reinterpret_cast<Header*>(file);
    char* data = file + kData;
    const rayproof_tracer& t = table[h->tracer];
    const Stopwatch watch;  // the code alone, where it runs
    switch (h->op) {
      case Op::build: {
        if (scene && scene_of && scene_of->release) scene_of->release(scene), leave_if_copy();
        // ABI 2 (tracer.md): the mesh's arrays stay valid and unchanged until release(), so they
        // are copied out of the shared file (unmapped after each request, then reused for rays).
        const auto* v = reinterpret_cast<const double*>(data);
        const auto* ix = reinterpret_cast<const std::uint32_t*>(data + 24 * h->vertex_count);
        kept_vertices.assign(v, v + 3 * h->vertex_count);
        kept_indices.assign(ix, ix + 3 * h->triangle_count);
        const rayproof_mesh mesh{kept_vertices.data(), static_cast<std::uint32_t>(h->vertex_count), kept_indices.data(),
                                 static_cast<std::uint32_t>(h->triangle_count)};
        built_triangles = h->triangle_count;
        scene = t.build(&mesh);
        leave_if_copy();
        scene_of = &t;
        h->built = scene != nullptr;
        break;
      }
      case Op::nearest: {
        const auto* rays = reinterpret_cast<const rayproof_ray*>(data);
        auto* out = reinterpret_cast<rayproof_trace*>(data + h->ray_count * sizeof(rayproof_ray));
        for (std::uint64_t i = 0; i < h->ray_count; ++i) {
          h->channel.progress.store(i, std::memory_order_relaxed);
          out[i] = {RAYPROOF_NO_TRIANGLE, NAN};
          t.nearest(scene, rays + i, 1, out + i);
          leave_if_copy();
        }
        h->answered = h->ray_count;
        break;
      }
      case Op::all_hits: {
        const auto* rays = reinterpret_cast<const rayproof_ray*>(data);
        auto* counts = reinterpret_cast<std::uint64_t*>(data + h->ray_count * sizeof(rayproof_ray));
        auto* flat = reinterpret_cast<std::uint32_t*>(data + h->ray_count * (sizeof(rayproof_ray) + 8));
        std::uint64_t used = 0, i = 0;
        for (; i < h->ray_count; ++i) {
          h->channel.progress.store(i, std::memory_order_relaxed);
          // A list longer than the mesh has triangles repeats one or names one it does not have:
          // a tracer error, judged from its first triangles + 1 entries. Room beyond that is never
          // made (10^6 claimed hits on 15 triangles once cost 517 MB a batch).
          const std::size_t most = static_cast<std::size_t>(built_triangles) + 1;
          std::size_t n = t.all_hits(scene, rays + i, buffer.data(), buffer.size());
          leave_if_copy();
          if (n > buffer.size() && buffer.size() < most) {  // the spec: called again with room for all
            buffer.resize(std::min(n, most));
            n = t.all_hits(scene, rays + i, buffer.data(), buffer.size());
            leave_if_copy();
          }
          n = std::min({n, buffer.size(), most});
          if (used + n > h->hits_capacity) break;
          std::copy(buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(n), flat + used);
          counts[i] = n, used += n;
        }
        h->answered = i;
        break;
      }
      case Op::release:
        if (scene && scene_of && scene_of->release) scene_of->release(scene), leave_if_copy();
        scene = nullptr, scene_of = nullptr;
        break;
    }
    h->inner_seconds = watch.seconds();
  });
}

[[maybe_unused]] const bool kIsWorker = become_worker_if_asked(kWorkerEnv, run_worker);

// ----------------------------------------------------------------- the rayproof side
class TracerWorker {
 public:
  explicit TracerWorker(const std::string& path)
      : channel_(kWorkerEnv, path, "rayproof-tracer-worker", "tracer", kData + 4096) {}
  void ensure(std::size_t bytes) { channel_.ensure(bytes); }  // pointers into the file are invalid after
  Header& header() { return *reinterpret_cast<Header*>(channel_.shared()); }
  char* data() { return channel_.shared() + kData; }
  // Runs the request in shared memory (worker_channel.h says how a stop is blamed).
  WorkerChannel::Outcome run(double timeout) { return channel_.run(timeout); }

 private:
  WorkerChannel channel_;
};

// One loaded library: its workers, shared by its tracers.
struct TracerLibrary {
  std::string path;
  ProcessPool<TracerWorker> workers;
};

// One tracer of a library; stops for good after a crash or a hang.
struct PluginTracerState : StopReason {
  TracerLibrary* library = nullptr;
  std::uint32_t index = 0;
  ExternalOptions options;
};

class PluginTracerScene final : public TracerScene {
 public:
  PluginTracerScene(PluginTracerState& state, std::unique_ptr<TracerWorker> worker, std::uint64_t triangles)
      : state_(state), worker_(std::move(worker)), triangles_(triangles) {}
  ~PluginTracerScene() override {
    if (!worker_) return;
    worker_->header().op = Op::release;
    if (worker_->run(state_.options.case_timeout_seconds).answered())
      state_.library->workers.give_back(std::move(worker_));
  }

  void nearest(std::span<const TracerRay> rays, std::span<TraceAnswer> out) override {
    std::lock_guard lock(mutex_);  // one worker per scene: callers on other threads wait
    if (!worker_ || state_.stopped)
      return std::fill(out.begin(), out.end(), TraceAnswer{kNoTriangle, NAN, AnswerFailure::stopped});
    worker_->ensure(nearest_bytes(rays.size()));
    Header& h = worker_->header();
    h.op = Op::nearest, h.tracer = state_.index, h.ray_count = rays.size();
    auto* wire = reinterpret_cast<rayproof_ray*>(worker_->data());
    for (std::size_t i = 0; i < rays.size(); ++i) wire[i] = to_wire(rays[i]);
    const WorkerChannel::Outcome run = worker_->run(state_.options.case_timeout_seconds);
    const std::size_t answered = run.answered() ? rays.size() : std::min<std::size_t>(run.at, rays.size());
    const auto* answers = reinterpret_cast<const rayproof_trace*>(worker_->data() + rays.size() * sizeof(rayproof_ray));
    for (std::size_t i = 0; i < answered; ++i) {
      out[i] = {answers[i].triangle, answers[i].t};
      if (out[i].triangle == kNoTriangle) out[i].t = NAN;
    }
    if (run.answered()) return;
    fail(run.reason, run.failure(), out.subspan(answered));
  }

  void all_hits(std::span<const TracerRay> rays, std::span<AllHitsAnswer> out) override {
    std::lock_guard lock(mutex_);
    std::size_t done = 0;
    std::uint64_t capacity = 64 * rays.size() + 1024;
    while (done < rays.size()) {
      if (!worker_ || state_.stopped) {
        for (std::size_t i = done; i < rays.size(); ++i) out[i] = {{}, AnswerFailure::stopped};
        return;
      }
      const std::size_t n = rays.size() - done;
      worker_->ensure(all_hits_bytes(n, capacity));
      Header& h = worker_->header();
      h.op = Op::all_hits, h.tracer = state_.index, h.ray_count = n, h.hits_capacity = capacity;
      auto* wire = reinterpret_cast<rayproof_ray*>(worker_->data());
      for (std::size_t i = 0; i < n; ++i) wire[i] = to_wire(rays[done + i]);
      // Everything read back from the worker is untrusted: the tracer's code shares its memory
      // and may have written over the counts (issue 42). A count beyond the mesh + 1, a list
      // past the room given, or more answers than rays asked is the tracer's crash, on that ray.
      const WorkerChannel::Outcome run = worker_->run(state_.options.case_timeout_seconds);
      std::string why = run.reason;
      std::size_t answered = run.answered() ? std::min<std::size_t>(h.answered, n) : std::min<std::size_t>(run.at, n);
      if (why.empty() && h.answered > n) {
        why = "its answer in shared memory is corrupt: " + std::to_string(h.answered) + " answers to " +
              std::to_string(n) + " rays (the tracer wrote outside its buffers)";
        answered = 0;  // nothing it wrote is trusted
      }
      const auto* counts = reinterpret_cast<const std::uint64_t*>(worker_->data() + n * sizeof(rayproof_ray));
      const auto* flat = reinterpret_cast<const std::uint32_t*>(worker_->data() + n * (sizeof(rayproof_ray) + 8));
      std::uint64_t at = 0;
      for (std::size_t i = 0; i < answered; ++i) {
        const std::uint64_t c = counts[i];
        if (c > triangles_ + 1 || c > capacity - at) {
          why = "its answer in shared memory is corrupt: ray " + std::to_string(done + i) + " has " +
                std::to_string(c) + " hits on a mesh of " + std::to_string(triangles_) +
                " triangles (the tracer wrote outside its buffers)";
          answered = i;
          break;
        }
        out[done + i] = {{flat + at, flat + at + c}};
        at += c;
      }
      done += answered;
      if (!why.empty()) {
        std::vector<TraceAnswer> unused(rays.size() - done);
        const AnswerFailure kind = run.failure();
        fail(why, kind, unused);
        out[done] = {{}, kind};
        for (std::size_t i = done + 1; i < rays.size(); ++i) out[i] = {{}, AnswerFailure::stopped};
        return;
      }
      if (answered == 0) capacity *= 4;  // one ray's hits did not fit: room for more
    }
  }

 private:
  static rayproof_ray to_wire(const TracerRay& r) {
    rayproof_ray w;
    for (int k = 0; k < 3; ++k) w.origin[k] = r.ray.origin[k], w.direction[k] = r.ray.direction[k];
    w.tmin = r.tmin, w.tmax = r.tmax;
    return w;
  }
  void fail(const std::string& why, AnswerFailure kind, std::span<TraceAnswer> rest) {
    state_.stop(why);
    worker_.reset();  // dead: never handed back
    if (rest.empty()) return;
    rest[0] = {kNoTriangle, NAN, kind};
    for (std::size_t i = 1; i < rest.size(); ++i) rest[i] = {kNoTriangle, NAN, AnswerFailure::stopped};
  }
  PluginTracerState& state_;
  std::unique_ptr<TracerWorker> worker_;
  std::uint64_t triangles_;  // the mesh's: no any-hit count the worker writes may exceed it + 1
  std::mutex mutex_;
};

BuiltScene build_plugin_scene(PluginTracerState& state, const TriangleMesh& mesh) {
  if (state.stopped) return {nullptr, AnswerFailure::stopped, "stopped earlier"};
  std::unique_ptr<TracerWorker> worker =
      state.library->workers.take([&] { return std::make_unique<TracerWorker>(state.library->path); });
  worker->ensure(build_bytes(mesh.vertex_count(), mesh.triangle_count()));
  Header& h = worker->header();
  h.op = Op::build, h.tracer = state.index, h.vertex_count = mesh.vertex_count(),
  h.triangle_count = mesh.triangle_count();
  std::memcpy(worker->data(), mesh.vertices.data(), 8 * mesh.vertices.size());
  std::memcpy(worker->data() + 24 * mesh.vertex_count(), mesh.indices.data(), 4 * mesh.indices.size());
  if (const WorkerChannel::Outcome run = worker->run(state.options.case_timeout_seconds); !run.answered()) {
    state.stop("build: " + run.reason);
    return {nullptr, run.failure(), "build: " + run.reason};
  }
  if (!h.built) {
    state.library->workers.give_back(std::move(worker));
    return {nullptr, AnswerFailure::none, "build returned NULL"};
  }
  return {std::make_unique<PluginTracerScene>(state, std::move(worker), mesh.triangle_count())};
}

}  // namespace

std::vector<const Tracer*> load_tracer_plugin(const std::string& path, const ExternalOptions& options) {
  auto fail = [&](const std::string& why) { return std::runtime_error("--tracer " + printable(path) + ": " + why); };
  const std::string file = path.find('/') == std::string::npos ? "./" + path : path;
  const json table =
      read_table_in_worker(kWorkerEnv, file, "rayproof-tracer-table", options.case_timeout_seconds, fail);
  TracerLibrary& library = loaded_code().make<TracerLibrary>();
  library.path = file;
  std::vector<const Tracer*> out;
  for (std::size_t i = 0; i < table.at("tracers").size(); ++i) {
    const json& t = table.at("tracers")[i];
    const std::string name = table_string(t, "name");
    const std::string where = checked_row_label(t, "tracer", i, fail);
    const std::string precision = table_string(t, "precision");
    if (precision != "double" && precision != "float")
      throw fail(where + ": precision must be \"double\" or \"float\"");
    if (!t.value("build", false) || !t.value("nearest", false)) throw fail(where + ": build and nearest must be set");
    const bool declared = t.contains("range") && !t.at("range").is_null();
    const std::string range = declared ? table_string(t, "range") : "open";
    if (!range_rule_from_string(range)) throw fail(where + ": range must be \"open\", \"closed\" or NULL");
    PluginTracerState& state = loaded_code().make<PluginTracerState>();
    state.library = &library, state.index = static_cast<std::uint32_t>(i), state.options = options;
    Tracer r;
    r.name = name;
    r.precision = precision == "float" ? Precision::f32 : Precision::f64;
    r.source = table_source(t);
    r.origin = file;
    r.has_all_hits = t.value("all_hits", false);
    r.range = *range_rule_from_string(range);
    r.build = [&state](const TriangleMesh& mesh) { return build_plugin_scene(state, mesh); };
    r.stop_reason = [&state] { return state.reason(); };
    try {
      out.push_back(&register_tracer(std::move(r)));
    } catch (const std::exception& e) {
      throw fail(where + ": " + e.what());
    }
  }
  return out;
}

}  // namespace rayproof::peers
