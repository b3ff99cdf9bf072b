// Plugins (docs/spec/plugin.md) in worker processes. rayproof never loads a plugin itself: a
// short-lived worker reads its variant table (so load-time code that exits, prints, crashes or
// forks is the plugin's, reported), and every call runs in a worker: this same executable
// re-executed (so nothing needs installing beside it), which sees RAYPROOF_PLUGIN_WORKER in its
// environment, loads the plugin and answers batches through shared memory until its request
// pipe closes. When the plugin forks, the copy leaves without answering and the worker marks
// the batch, which rayproof then reports instead of judging it. A batch costs
// two pipe wake-ups; the worker writes the index of the case it is on before each call, so when
// it dies or stops making progress the case to blame is known and every earlier answer is kept.
// Scenes (render, audit) go to the worker once: it builds the same KindIndex from the same
// shapes and traces whole batches of rays there, the plugin at the leaves (trace_all), so a ray
// costs the traversal and the plugin's calls, not one round trip per leaf.
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
#include <cstdlib>
#include <cstring>
#include <deque>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "rayproof/core/json_fields.h"
#include "rayproof/core/scene_index.h"
#include "rayproof/core/scene_rays.h"
#include "rayproof/core/timing.h"
#include "rayproof/peers/child_process.h"
#include "rayproof/peers/crash_budget.h"
#include "rayproof/peers/external.h"
#include "rayproof/peers/library_table.h"
#include "rayproof/peers/process_pool.h"
#include "rayproof/peers/loaded_code.h"
#include "rayproof/peers/worker_channel.h"
#include "rayproof/plugin.h"

namespace rayproof::peers {

namespace {

// ---------------------------------------------------------------- the shared-memory protocol
constexpr std::size_t kBatchCapacity = 4096;
constexpr const char* kWorkerEnv = "RAYPROOF_PLUGIN_WORKER";  // "table:PATH" or "serve:PATH"

struct WireQuery {
  double numbers[6 + kMaxShapeNumbers];  // ray, then the shape's numbers (cases.md order)
};
struct WireAnswer {
  double t;
  HitClass cls;
  AnswerFailure failure;
  std::int32_t primitive;  // trace: the nearest (or blocking) primitive, -1 for none
};
// What a batch holds. cases: queries (ray, shape) answered one by one. scene_shapes: shapes of
// one kind (numbers[0] the primitive id, numbers + 6 the shape), appended from `scene_offset` of
// `scene_total`; the last chunk builds the worker's KindIndex. trace: rays (numbers 0–5, skip in
// numbers[6], any_hit in numbers[7], the reach in numbers[8]) traced through that index
// (core/scene_rays.h).
enum class BatchMode : std::uint32_t { cases, scene_shapes, trace };
struct SharedBatch {
  ChannelHeader channel;  // progress: the index of the case (ray) the worker is on
  BatchMode mode;
  std::uint32_t scene_kind, scene_offset, scene_total;
  std::uint32_t variant, count;
  std::uint32_t repeats;  // `trade`: run the batch this many times on inputs already in cache, for timing
  double inner_seconds;   // the worker's own time for the calls of this batch
  WireQuery queries[kBatchCapacity];
  WireAnswer answers[kBatchCapacity];
};

// A NaN with a payload no arithmetic produces: still there after the call means t was not written.
constexpr std::uint64_t kUnwrittenF64 = 0x7ff8dead0000beefull;
constexpr std::uint32_t kUnwrittenF32 = 0x7fc0beefu;

// One call of the plugin's function, its answer checked as the spec says (never trusted).
template <class Real, class Fn>
WireAnswer call_checked(Fn fn, const double* numbers, int shape_numbers, Real unwritten) {
  Real t = unwritten;
  int answer;
  if constexpr (std::is_same_v<Real, double>) {
    answer = fn(numbers, numbers + 6, &t);  // the shared numbers as they are: ray, then shape
  } else {
    Real ray[6], shape[kMaxShapeNumbers];
    for (int i = 0; i < 6; ++i) ray[i] = static_cast<Real>(numbers[i]);  // exact: the case was rounded before
    for (int i = 0; i < shape_numbers; ++i) shape[i] = static_cast<Real>(numbers[6 + i]);
    answer = fn(ray, shape, &t);
  }
  WireAnswer out{static_cast<double>(t), HitClass::miss, AnswerFailure::none, -1};
  if (answer < RAYPROOF_MISS || answer > RAYPROOF_HIT) return out.failure = AnswerFailure::bad_answer, out;
  out.cls = static_cast<HitClass>(answer);  // the enum orders match: miss … boundary, hit
  if (out.cls == HitClass::miss) return out.t = NAN, out;
  if (std::memcmp(&t, &unwritten, sizeof t) == 0) return out.failure = AnswerFailure::t_unwritten, out;
  if (std::isnan(t)) out.failure = AnswerFailure::nan_t;
  return out;
}

// The worker: loads the plugin, then either writes its table as one JSON line and ends
// (mode "table") or answers batches until the request pipe closes (mode "serve").
[[noreturn]] void run_worker(const std::string& setting) {
  const WorkerStart start = start_worker(setting);
  int count = 0;
  std::string error;
  const rayproof_variant* table = load_library_table<rayproof_variant>(
      start.path, "rayproof_plugin", RAYPROOF_PLUGIN_ABI, "rayproof/plugin.h", "variants", count, error);
  report_table_or_go_on(start, table, count, error, "variants", [](const rayproof_variant& v) {
    return json{{"name", describe_string(v.name)}, {"shape", describe_string(v.shape)},
                {"rule", describe_string(v.rule)}, {"source", describe_string(v.source)},
                {"f64", v.f64 != nullptr},         {"f32", v.f32 != nullptr}};
  });
  double unwritten64;
  float unwritten32;
  std::memcpy(&unwritten64, &kUnwrittenF64, sizeof unwritten64);
  std::memcpy(&unwritten32, &kUnwrittenF32, sizeof unwritten32);
  std::vector<std::int32_t> scene_ids;  // the scene being sent, then its index
  std::vector<Shape> scene_shapes;
  KindIndex scene;
  serve_requests([&](char* file) {
    auto* shared = reinterpret_cast<SharedBatch*>(file);
    const rayproof_variant& v = table[shared->variant];
    const int n = shape_number_count(*shape_kind_from_string(v.shape));
    auto call = [&](const double* numbers) {
      const WireAnswer a = v.f64 ? call_checked<double>(v.f64, numbers, n, unwritten64)
                                 : call_checked<float>(v.f32, numbers, n, unwritten32);
      if (is_forked_copy()) ::_exit(0);  // a copy the plugin forked: never answers
      return a;
    };
    if (shared->mode == BatchMode::scene_shapes) {
      const auto kind = static_cast<ShapeKind>(shared->scene_kind);
      if (shared->scene_offset == 0) scene_ids.clear(), scene_shapes.clear();
      for (std::uint32_t i = 0; i < shared->count; ++i) {
        scene_ids.push_back(static_cast<std::int32_t>(shared->queries[i].numbers[0]));
        scene_shapes.push_back(shape_from_numbers(kind, shared->queries[i].numbers + 6));
      }
      if (scene_shapes.size() == shared->scene_total) {
        scene = KindIndex(kind, scene_ids, scene_shapes);
        scene_ids = {}, scene_shapes = {};
      }
      shared->inner_seconds = 0;
    } else {
      const std::uint32_t repeats = std::max(1u, shared->repeats);  // timing: the batch again, inputs in cache
      const Stopwatch watch;  // the code alone (and, tracing, rayproof's traversal), where it runs
      with_best_box_lanes([&](auto lanes) {
        for (std::uint32_t pass = 0; pass < repeats; ++pass) {
          for (std::uint32_t i = 0; i < shared->count; ++i) {
            shared->channel.progress.store(i, std::memory_order_relaxed);
            const double* x = shared->queries[i].numbers;
            if (shared->mode == BatchMode::cases) {
              shared->answers[i] = call(x);
              continue;
            }
            const SceneRay ray{Ray{Vec3(x[0], x[1], x[2]), Vec3(x[3], x[4], x[5])}, static_cast<std::int32_t>(x[6]),
                               x[7] != 0};
            double numbers[6 + kMaxShapeNumbers];
            std::copy(x, x + 6, numbers);
            const SceneRayAnswer found = trace_scene_ray(
                scene, ray,
                [&](const Shape& shape) {
                  shape_numbers(shape, numbers + 6);
                  const WireAnswer a = call(numbers);  // a plugin error counts as no contact, as it does leaf by leaf
                  return a.failure == AnswerFailure::none ? Hit{a.cls, a.t} : Hit::miss();
                },
                lanes, x[8]);
            shared->answers[i] = {found.answer.t, found.answer.cls, AnswerFailure::none, found.primitive};
          }
        }
      });
      shared->inner_seconds = watch.seconds() / repeats;
    }
  });
}

[[maybe_unused]] const bool kIsWorker = become_worker_if_asked(kWorkerEnv, run_worker);

// ---------------------------------------------------------------- the rayproof side
// One worker process and its shared batch (the channel's file is one SharedBatch).
class WorkerProcess {
 public:
  explicit WorkerProcess(const std::string& plugin_path)
      : channel_(kWorkerEnv, plugin_path, "rayproof-plugin-worker", "plugin", sizeof(SharedBatch)) {}
  SharedBatch& batch() { return *reinterpret_cast<SharedBatch*>(channel_.shared()); }
  // Runs the batch in shared memory (worker_channel.h says how a stop is blamed).
  WorkerChannel::Outcome run(double case_timeout) { return channel_.run(case_timeout); }
  // The KindIndex::serial() of the scene this worker holds (0: none).
  std::uint64_t scene_serial = 0;

 private:
  WorkerChannel channel_;
};

// One loaded plugin: its workers, shared by its variants (one per thread at a time).
class Plugin {
 public:
  explicit Plugin(std::string path) : path_(std::move(path)) {}
  const std::string& path() const { return path_; }
  std::unique_ptr<WorkerProcess> take() {
    return workers_.take([this] { return std::make_unique<WorkerProcess>(path_); });
  }
  void give_back(std::unique_ptr<WorkerProcess> w) { workers_.give_back(std::move(w)); }

 private:
  std::string path_;
  ProcessPool<WorkerProcess> workers_;
};

class PluginVariant final : public ExternalIntersector {
 public:
  PluginVariant(Plugin& plugin, std::uint32_t index, ShapeKind shape, const ExternalOptions& options)
      : plugin_(plugin), index_(index), shape_(shape), options_(options), budget_(options.max_crashes) {}

  void answer_all(std::span<const Query> qs, std::span<Answer> out, AnswerTiming* timing) override {
    in_batches(
        qs.size(), BatchMode::cases, timing,
        [&](WireQuery& w, std::size_t i) {
          put_ray(qs[i].ray, w.numbers);
          shape_numbers(qs[i].shape, w.numbers + 6);
        },
        [&](const WireAnswer& a, std::size_t i) {
          out[i] = Hit{a.cls, a.t};
          out[i].failure = a.failure;
        },
        [&](std::size_t i, AnswerFailure f) { out[i] = Answer::failure_of(f); });
  }
  Answer probe(const Query& q) override {
    WorkerProcess worker(plugin_.path());  // its own: a crash here spends no budget and stops nothing
    SharedBatch& b = worker.batch();
    b.mode = BatchMode::cases, b.variant = index_, b.count = 1, b.repeats = 1;
    put_ray(q.ray, b.queries[0].numbers);
    shape_numbers(q.shape, b.queries[0].numbers + 6);
    if (const auto run = worker.run(options_.case_timeout_seconds); !run.answered())
      return Answer::failure_of(run.failure());
    Answer a = Hit{b.answers[0].cls, b.answers[0].t};
    a.failure = b.answers[0].failure;
    return a;
  }
  bool can_trace() const override { return true; }
  bool trace_all(const KindIndex& scene, HitRule, std::span<const SceneRay> rays, std::span<SceneRayAnswer> out,
                 AnswerTiming* timing, double reach) override {
    if (scene.kind() != shape_) return false;
    in_batches(
        rays.size(), BatchMode::trace, timing,
        [&](WireQuery& w, std::size_t i) {
          put_ray(rays[i].ray, w.numbers);
          w.numbers[6] = rays[i].skip, w.numbers[7] = rays[i].any_hit ? 1 : 0, w.numbers[8] = reach;
        },
        [&](const WireAnswer& a, std::size_t i) {
          out[i] = {a.primitive, Hit{a.cls, a.t}};
        },
        [&](std::size_t i, AnswerFailure f) {
          out[i] = {-1, Answer::failure_of(f)};
        },
        &scene);
    return true;
  }
  std::string stop_reason() const override { return budget_.stop_reason(); }
  std::string last_failure() const override { return budget_.last_failure(); }

 private:
  static void put_ray(const Ray& ray, double* numbers) {
    for (int k = 0; k < 3; ++k) numbers[k] = ray.origin[k], numbers[3 + k] = ray.direction[k];
  }

  // Items 0..count−1 in batches through the pool's workers (a scene first sent to a worker that
  // lacks it): put(slot, i) writes item i, take(answer, i) keeps its answer, fail(i, why) marks
  // an item not answered. A worker that dies or hangs is blamed for the item it was on, keeps
  // what it answered, and a fresh one goes on from the next while the crash budget lasts (a
  // forking plugin stops at once); once stopped, every item left is `stopped`. `timing`: the
  // worker's own time for one pass over all items, or −1 where a batch failed.
  template <class Put, class Take, class Fail>
  void in_batches(std::size_t count, BatchMode mode, AnswerTiming* timing, Put&& put, Take&& take, Fail&& fail,
                  const KindIndex* scene = nullptr) {
    double inside = 0;
    for (std::size_t start = 0; start < count;) {
      const std::size_t n = std::min(kBatchCapacity, count - start);
      if (budget_.stopped()) {
        for (std::size_t i = start; i < count; ++i) fail(i, AnswerFailure::stopped);
        inside = -1;
        break;
      }
      std::unique_ptr<WorkerProcess> worker = plugin_.take();
      WorkerChannel::Outcome run =
          scene && worker->scene_serial != scene->serial() ? send_scene(*worker, *scene) : WorkerChannel::Outcome{};
      std::size_t answered = 0;
      if (run.answered()) {
        SharedBatch& b = worker->batch();
        b.mode = mode, b.variant = index_, b.count = static_cast<std::uint32_t>(n),
        b.repeats = timing ? static_cast<std::uint32_t>(std::max(1, timing->repeats)) : 1;
        for (std::size_t i = 0; i < n; ++i) put(b.queries[i], start + i);
        run = worker->run(options_.case_timeout_seconds);
        answered = run.answered() ? n : std::min<std::size_t>(run.at, n);
        for (std::size_t i = 0; i < answered; ++i) take(b.answers[i], start + i);
        inside += b.inner_seconds;
      }
      if (run.answered()) {
        plugin_.give_back(std::move(worker));
        start += n;
        continue;
      }
      fail(start + answered, run.failure());
      if (run.forked)
        budget_.stop(run.reason);
      else
        budget_.spend(run.reason);
      inside = -1;  // a batch with a crash times nothing
      start += answered + 1;
    }
    if (timing) timing->inner_seconds = inside;
  }

  // Sends the scene's primitives in id order (the worker builds the same KindIndex from them);
  // answered when it holds them, else why the worker died on the way.
  WorkerChannel::Outcome send_scene(WorkerProcess& worker, const KindIndex& scene) {
    std::vector<std::size_t> by_id(scene.size());
    for (std::size_t i = 0; i < by_id.size(); ++i) by_id[i] = i;
    const auto ids = scene.ids_in_leaf_order();
    std::sort(by_id.begin(), by_id.end(), [&](std::size_t a, std::size_t b) { return ids[a] < ids[b]; });
    SharedBatch& b = worker.batch();
    for (std::size_t start = 0; start == 0 || start < by_id.size(); start += kBatchCapacity) {
      const std::size_t n = std::min(kBatchCapacity, by_id.size() - start);
      b.mode = BatchMode::scene_shapes, b.variant = index_, b.count = static_cast<std::uint32_t>(n), b.repeats = 1;
      b.scene_kind = static_cast<std::uint32_t>(scene.kind());
      b.scene_offset = static_cast<std::uint32_t>(start), b.scene_total = static_cast<std::uint32_t>(by_id.size());
      for (std::size_t i = 0; i < n; ++i) {
        double* x = b.queries[i].numbers;
        x[0] = ids[by_id[start + i]];
        shape_numbers(scene.shapes_in_leaf_order()[by_id[start + i]], x + 6);
      }
      if (WorkerChannel::Outcome run = worker.run(options_.case_timeout_seconds); !run.answered()) return run;
    }
    worker.scene_serial = scene.serial();
    return {};
  }

  Plugin& plugin_;
  std::uint32_t index_;
  ShapeKind shape_;
  ExternalOptions options_;
  CrashBudget budget_;
};

}  // namespace

LoadedCode& loaded_code() {
  static LoadedCode all;
  return all;
}

bool valid_variant_name(const std::string& name) {
  return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-';
  });
}

std::pair<std::string, std::string> split_assignment(const std::string& flag, const std::string& text) {
  const std::size_t eq = text.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == text.size())
    throw std::runtime_error(flag + " '" + text + "': expected NAME=VALUE");
  return {text.substr(0, eq), text.substr(eq + 1)};
}

std::vector<const Variant*> load_plugin(const std::string& path, const ExternalOptions& options) {
  auto fail = [&](const std::string& why) { return std::runtime_error("--plugin " + printable(path) + ": " + why); };
  // A path without a slash would make dlopen search the library path; the user means a file.
  const std::string file = path.find('/') == std::string::npos ? "./" + path : path;
  const json table =
      read_table_in_worker(kWorkerEnv, file, "rayproof-plugin-table", options.case_timeout_seconds, fail);
  Plugin& plugin = loaded_code().make<Plugin>(file);
  std::vector<const Variant*> out;
  for (std::size_t i = 0; i < table.at("variants").size(); ++i) {
    const json& v = table.at("variants")[i];
    const std::string name = table_string(v, "name");
    const std::string where = checked_row_label(v, "variant", i, fail);
    const auto shape = shape_kind_from_string(table_string(v, "shape"));
    if (!shape) throw fail(where + ": shape must be sphere, plane, triangle or box");
    const auto rule = hit_rule_from_string(table_string(v, "rule"));
    if (!rule) throw fail(where + ": rule must be nearest or enter-only");
    if (v.value("f64", false) == v.value("f32", false)) throw fail(where + ": exactly one of f64 and f32 must be set");
    if (find_variant(name)) throw fail(where + ": a variant of that name exists already");
    PluginVariant& intersector =
        loaded_code().make<PluginVariant>(plugin, static_cast<std::uint32_t>(i), *shape, options);
    const std::string& stored_name = loaded_code().keep(name);
    Variant registered{stored_name, *shape, loaded_code().keep(table_source(v)), nullptr};
    registered.precision = v.value("f32", false) ? Precision::f32 : Precision::f64;
    registered.fixed_rule = *rule;
    registered.external = &intersector;
    registered.origin = plugin.path();
    out.push_back(&register_variant(registered));
  }
  return out;
}

}  // namespace rayproof::peers
