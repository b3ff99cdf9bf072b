// The Python module's C++ half, `rayproof._rayproof` (pybind11): the oracle over NumPy arrays,
// variant campaigns, and whole tracers written in Python judged in this process. The Python half
// (python/rayproof/__init__.py) adds defaults, temporary files and the findings as dicts.
//
// Threads: every entry point releases the GIL while C++ works; a Python tracer's build, nearest and
// all_hits take it back for the call alone, so the oracle judges in parallel with the tracer.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "rayproof/core/casefile.h"
#include "rayproof/core/mesh_case.h"
#include "rayproof/core/parallel.h"
#include "rayproof/core/tracer.h"
#include "rayproof/core/variants.h"
#include "rayproof/fuzz/campaign.h"
#include "rayproof/fuzz/tracer_campaign.h"
#include "rayproof/verify/backward_error.h"
#include "rayproof/verify/compare.h"
#include "rayproof/verify/oracle.h"

namespace py = pybind11;
using namespace rayproof;

namespace {

// ---- JSON across the boundary: through text (numbers in findings are hex strings, so exact).
py::object to_python(const json& j) { return py::module_::import("json").attr("loads")(j.dump()); }
json from_python(py::handle o, const std::string& what) {
  try {
    return parse_json_text(py::module_::import("json").attr("dumps")(o).cast<std::string>());
  } catch (const py::error_already_set& e) {
    throw py::value_error(what + ": not JSON: " + e.what());
  }
}

template <class T>
T named(const std::string& text, std::optional<T> (*parse)(std::string_view), const std::string& what,
        const std::string& known) {
  if (auto v = parse(text)) return *v;
  throw py::value_error("unknown " + what + " '" + text + "' (" + known + ")");
}
Precision precision_of(const std::string& s) {
  if (s == "double" || s == "f64") return Precision::f64;
  if (s == "float" || s == "f32") return Precision::f32;
  throw py::value_error("precision must be 'double' or 'float', got '" + s + "'");
}
RangeRule range_of(const std::string& s) {
  return named<RangeRule>(s, range_rule_from_string, "range", "open or closed");
}
HitRule rule_of(const std::string& s) {
  return named<HitRule>(s, hit_rule_from_string, "rule", "nearest or enter-only");
}

// A float64 array of shape (n, columns) (columns 0: shape (n,)), C-contiguous: NumPy converts
// other dtypes and layouts, and refuses what it cannot (a string, a ragged list).
using Doubles = py::array_t<double, py::array::c_style | py::array::forcecast>;
Doubles doubles(py::handle o, const char* name, py::ssize_t columns, py::ssize_t rows = -1) {
  Doubles a;
  try {
    a = Doubles::ensure(o);
  } catch (const py::error_already_set&) {}
  if (!a) throw py::type_error(std::string(name) + ": expected an array of numbers");
  const bool shaped = columns == 0 ? a.ndim() == 1 : a.ndim() == 2 && a.shape(1) == columns;
  if (!shaped || (rows >= 0 && a.shape(0) != rows)) {
    std::string want = columns == 0 ? "(n,)" : "(n, " + std::to_string(columns) + ")";
    if (rows >= 0)
      want = columns == 0 ? "(" + std::to_string(rows) + ",)"
                          : "(" + std::to_string(rows) + ", " + std::to_string(columns) + ")";
    std::string got = "(";
    for (py::ssize_t i = 0; i < a.ndim(); ++i) got += (i ? ", " : "") + std::to_string(a.shape(i));
    throw py::value_error(std::string(name) + ": expected shape " + want + ", got " + got + ")");
  }
  return a;
}

// ---- the oracle
ShapeKind shape_kind_of(const std::string& s) {
  return named<ShapeKind>(s, shape_kind_from_string, "shape", "sphere, plane, triangle or box");
}

// What `check` says of an answer to query q (as the case gives it) from code of precision p and
// range `range`: agreement and ulps against the verdict on what the code saw (float code: q
// rounded to float), and for a disagreement or a t not correctly rounded the level and β
// (verify/backward_error.h, outcome_verdict). nullopt: float code cannot be given q.
struct JudgedAnswer {
  VariantOutcome outcome;
  std::optional<OutcomeVerdict> verdict;
};
std::optional<JudgedAnswer> judge_answer_to(Oracle& oracle, const Query& q, const Verdict& exact, const Answer& answer,
                                            Precision p, HitRule rule, RangeRule range, double tolerance_ulps) {
  const std::optional<Query> seen = p == Precision::f32 ? rounded_to_float(q) : std::optional<Query>(q);
  if (!seen) return std::nullopt;
  static thread_local Variant code{.name = "python"};  // outcome_verdict reads precision and range from it
  code.shape = kind_of(q.shape), code.precision = p, code.range = range;
  const Verdict own = p == Precision::f32 ? oracle.judge(seen->ray, seen->shape, rule) : exact;
  JudgedAnswer out{judge_answer(own, answer), std::nullopt};
  out.outcome.variant = &code;
  if (p == Precision::f32 && own.t && answer.has_t())
    out.outcome.ulp_own = ulp_distance_f32(static_cast<float>(answer.t), exact_t_as_float(*seen, rule, *own.t));
  out.verdict = outcome_verdict(q, out.outcome, rule, tolerance_ulps, true);  // as check judges it
  out.outcome.variant = nullptr;
  return out;
}

// judge(case, answer, precision, rule, range, tolerance): the oracle's verdict on one case
// (cases.md), and with an answer {"class", "t"} what check says of it: agreement, ulp, β.
py::dict judge(py::handle case_object, py::handle answer_object, const std::string& precision, const std::string& rule,
               const std::string& range, double tolerance_ulps) {
  json j = from_python(case_object, "case");
  if (j.is_object() && !j.contains("id")) j["id"] = "python";
  Case c;
  try {
    c = parse_case(j.dump());
  } catch (const FieldError& e) {
    throw py::value_error("case: " + e.field + ": " + e.what());
  }
  const HitRule r = rule_of(rule);
  const Precision p = precision_of(precision);
  const RangeRule declared = range_of(range);
  std::optional<Answer> answer;
  if (!answer_object.is_none()) {
    const json a = from_python(answer_object, "answer");
    if (!a.is_object() || !a.contains("class") || !a["class"].is_string())
      throw py::value_error("answer: expected {\"class\": ..., \"t\": ...}");
    const auto cls = answer_class_from_string(a["class"].get<std::string>());
    if (!cls) throw py::value_error("answer.class: unknown class '" + a["class"].get<std::string>() + "'");
    Hit h{*cls};
    if (a.contains("t") && !a["t"].is_null()) {
      const auto t = a["t"].is_number() ? std::optional<double>(a["t"].get<double>())
                                        : parse_hex_double(a["t"].is_string() ? a["t"].get<std::string>() : "");
      if (!t) throw py::value_error("answer.t: expected a number or a hex-float string");
      h.t = *t;
    }
    answer = Answer(h);
  }
  json result;
  {
    py::gil_scoped_release unlocked;
    Oracle oracle;
    const Verdict exact = oracle.judge(c.ray, c.shape, r);
    result = {{"class", std::string(to_string(exact.cls))}, {"t", exact.t ? json(hex_double(*exact.t)) : json()}};
    if (answer) {
      const auto judged = judge_answer_to(oracle, c, exact, *answer, p, r, declared, tolerance_ulps);
      if (!judged) {
        result["answer"] = {{"skipped", "not_representable"}};
      } else {
        const VariantOutcome& o = judged->outcome;
        json entry{{"class", std::string(to_string(answer->cls))},
                   {"agrees", o.agreement == Agreement::agrees},
                   {"cannot_tell", o.agreement == Agreement::cannot_tell}};
        if (o.ulp) entry["ulp"] = *o.ulp;
        if (o.ulp_own) entry["ulp_own"] = *o.ulp_own;
        if (judged->verdict) add_verdict_fields(entry, *judged->verdict, range);
        result["answer"] = entry;
      }
    }
  }
  return to_python(result);
}

// judge_many(shape, origins (n,3), directions (n,3), numbers (n,k)[, classes (n,), t (n,)]):
// class codes (index into CLASSES) and t (NaN where there is none), in parallel over `threads`.
// With answers (class codes and t): per row `agrees` (0 wrong, 1 cannot tell, 2 agrees), `ulp`
// (-1 where either t is absent), `beta` (ulps; NaN where the answer is right and its t correctly
// rounded, inf for "none", -inf for "unproved") and `level` (0 none, 1 rounding, 2 bug), as
// `check` decides them (witnesses checked as check checks them; not returned).
py::dict judge_many(const std::string& shape, py::handle origins_in, py::handle directions_in, py::handle numbers_in,
                    py::handle classes_in, py::handle t_in, const std::string& rule, const std::string& precision,
                    const std::string& range, double tolerance_ulps, int threads) {
  const ShapeKind kind = shape_kind_of(shape);
  const Doubles origins = doubles(origins_in, "origins", 3);
  const py::ssize_t n = origins.shape(0);
  const Doubles directions = doubles(directions_in, "directions", 3, n);
  const Doubles numbers = doubles(numbers_in, "shapes", shape_number_count(kind), n);
  const HitRule r = rule_of(rule);
  const Precision p = precision_of(precision);
  const RangeRule declared = range_of(range);
  const bool answered = !classes_in.is_none();
  py::array_t<std::int64_t, py::array::c_style | py::array::forcecast> answer_classes;
  Doubles answer_t;
  if (answered) {
    answer_classes = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(classes_in);
    if (!answer_classes || answer_classes.ndim() != 1 || answer_classes.shape(0) != n)
      throw py::value_error("classes: expected " + std::to_string(n) + " class codes (indices into CLASSES)");
    answer_t = doubles(t_in.is_none() ? py::handle(py::none()) : t_in, "t", 0, n);
    for (py::ssize_t i = 0; i < n; ++i)
      if (answer_classes.at(i) < 0 || answer_classes.at(i) > static_cast<std::int64_t>(HitClass::hit))
        throw py::value_error("classes: row " + std::to_string(i) + ": " + std::to_string(answer_classes.at(i)) +
                              " is not a class code (0.." + std::to_string(static_cast<int>(HitClass::hit)) + ")");
  }
  py::array_t<std::int8_t> classes(n), agrees(answered ? n : 0), level(answered ? n : 0);
  py::array_t<double> ts(n), beta(answered ? n : 0);
  py::array_t<std::int64_t> ulp(answered ? n : 0);
  std::vector<std::string> errors(static_cast<std::size_t>(n));
  {
    const double *o = origins.data(), *d = directions.data(), *s = numbers.data();
    const std::int64_t* ac = answered ? answer_classes.data() : nullptr;
    const double* at = answered ? answer_t.data() : nullptr;
    std::int8_t *cls = classes.mutable_data(), *agree = agrees.mutable_data(), *lvl = level.mutable_data();
    double *t = ts.mutable_data(), *b = beta.mutable_data();
    std::int64_t* u = ulp.mutable_data();
    const int k = shape_number_count(kind);
    py::gil_scoped_release unlocked;
    std::atomic<py::ssize_t> next{0};
    run_workers(std::max(1, threads), [&](int) {
      Oracle oracle;
      for (py::ssize_t i; (i = next.fetch_add(1)) < n;) {
        const Query q{Ray(Vec3(o[3 * i], o[3 * i + 1], o[3 * i + 2]), Vec3(d[3 * i], d[3 * i + 1], d[3 * i + 2])),
                      shape_from_numbers(kind, s + k * i)};
        cls[i] = -1, t[i] = std::nan("");
        if (!is_valid_query(q.ray, q.shape)) {
          const char* why = degenerate_reason(q.shape);
          errors[i] = why ? why : "a non-finite number or a zero direction";
          continue;
        }
        const Verdict v = oracle.judge(q.ray, q.shape, r);
        cls[i] = static_cast<std::int8_t>(v.cls);
        if (v.t) t[i] = *v.t;
        if (!ac) continue;
        Hit h{static_cast<HitClass>(ac[i])};
        h.t = at[i];
        agree[i] = -1, u[i] = -1, b[i] = std::nan(""), lvl[i] = 0;
        const auto judged = judge_answer_to(oracle, q, v, Answer(h), p, r, declared, tolerance_ulps);
        if (!judged) continue;  // float code cannot be given this row: agrees stays -1
        const VariantOutcome& out = judged->outcome;
        agree[i] = out.agreement == Agreement::agrees ? 2 : out.agreement == Agreement::cannot_tell ? 1 : 0;
        if (const auto off = p == Precision::f32 ? out.ulp_own : out.ulp) u[i] = static_cast<std::int64_t>(*off);
        if (const auto& verdict = judged->verdict) {
          const BackwardError& e = verdict->beta;  // as beta_json reads it: none, unproved, or ε
          const bool unproved = e.refused && !e.checked;
          b[i] = e.beta && !unproved ? *e.beta : unproved ? -INFINITY : INFINITY;
          lvl[i] = verdict->level == Level::rounding ? 1 : 2;
        }
      }
    });
  }
  for (py::ssize_t i = 0; i < n; ++i)
    if (!errors[i].empty()) throw py::value_error("row " + std::to_string(i) + ": not a valid query: " + errors[i]);
  py::dict out;
  out["class"] = classes, out["t"] = ts;
  if (answered) out["agrees"] = agrees, out["ulp"] = ulp, out["beta"] = beta, out["level"] = level;
  return out;
}

py::list variants() {
  py::list out;
  for (const Variant& v : all_variants()) {
    py::dict d;
    d["name"] = std::string(v.name), d["shape"] = shapes_answered(v),
    d["precision"] = std::string(to_string(v.precision));
    d["source"] = std::string(v.source);
    out.append(d);
  }
  for (const Tracer* t : all_tracers()) {
    py::dict d;
    d["name"] = t->name, d["shape"] = "mesh", d["precision"] = std::string(to_string(t->precision));
    d["source"] = t->source;
    out.append(d);
  }
  return out;
}

// ---- variant campaigns (fuzz/campaign.h), findings written to `output`
py::dict fuzz_variants(const std::vector<std::string>& variant_names, const std::vector<std::string>& family_names,
                       const std::vector<std::string>& shape_names, std::uint64_t count, std::uint64_t seed,
                       int threads, const std::string& output, const std::string& rule, double tolerance_ulps,
                       bool shrink, std::uint64_t max_findings) {
  fuzz::CampaignOptions o;
  for (const std::string& f : family_names)
    o.families.push_back(named<fuzz::Family>(f, fuzz::family_from_string, "family",
                                             "random, tangent, grazing, near-origin, exit-entry, extremes"));
  for (const std::string& s : shape_names) o.shapes.push_back(shape_kind_of(s));
  for (const std::string& name : variant_names) {
    const Variant* v = find_variant(name);
    if (!v) throw py::value_error("unknown variant '" + name + "' (rayproof.variants() lists them)");
    o.variants.push_back(v);
  }
  o.count = count, o.seed = seed, o.threads = std::max(1, threads), o.output = output, o.rule = rule_of(rule);
  o.tolerance_ulps = tolerance_ulps, o.shrink = shrink, o.max_findings = max_findings;
  json report;
  std::string table;
  {
    py::gil_scoped_release unlocked;
    const fuzz::CampaignReport r = fuzz::run_campaign(o);
    report = r.to_json();
    std::ostringstream text;
    fuzz::print_report(r, o.threads, TableFormat::table, text);
    table = text.str();
  }
  py::dict out = to_python(report);
  out["table"] = table;
  return out;
}

// ---- whole tracers written in Python
// Why the last call of this thread's tracer failed: the campaign asks (Tracer::stop_reason) on
// the thread that made the call, right after it.
thread_local std::string last_error;

std::string python_error_text(py::error_already_set& e) {
  try {
    py::list lines = py::module_::import("traceback").attr("format_exception")(e.type(), e.value(), e.trace());
    std::string text;
    for (py::handle l : lines) text += l.cast<std::string>();
    while (!text.empty() && text.back() == '\n') text.pop_back();
    return text;
  } catch (...) {
    return e.what();
  }
}

// The user's object and what guards it. A build that returns the tracer itself (a tracer that
// keeps its mesh in self) makes one scene at a time: `one_scene` is held from that build until
// the scene is released, so threads never trace one mesh with another's structure.
struct PythonTracer {
  py::object tracer;
  std::mutex one_scene;
  ~PythonTracer() {
    py::gil_scoped_acquire locked;
    tracer = py::object();
  }
};

// What nearest returned, checked: (triangles, t), each of n numbers. Triangles: integers, a
// negative one or 0xffffffff for no hit. Anything else is a tracer error for the batch.
std::string rays_text(std::size_t n) { return std::to_string(n) + (n == 1 ? " ray" : " rays"); }

std::optional<std::string> read_nearest(py::handle result, std::span<TraceAnswer> out) {
  const std::size_t n = out.size();
  if (!py::isinstance<py::sequence>(result) || py::isinstance<py::str>(result) || py::len(result) != 2)
    return "nearest must return (triangles, t), got " + py::repr(result).cast<std::string>().substr(0, 200);
  py::object np = py::module_::import("numpy");
  py::array tri = np.attr("asarray")(result[py::int_(0)]);
  py::array t = np.attr("asarray")(result[py::int_(1)]);
  const char kind = tri.dtype().kind();
  if (tri.ndim() != 1 || static_cast<std::size_t>(tri.shape(0)) != n)
    return "nearest returned " + std::to_string(tri.ndim() == 1 ? tri.shape(0) : tri.size()) + " triangles for " +
           rays_text(n);
  if (kind != 'i' && kind != 'u')
    return "nearest's triangles must be integers, got dtype " + py::str(tri.dtype()).cast<std::string>();
  if (t.ndim() != 1 || static_cast<std::size_t>(t.shape(0)) != n)
    return "nearest returned " + std::to_string(t.ndim() == 1 ? t.shape(0) : t.size()) + " t values for " +
           rays_text(n);
  const auto ids = py::array_t<std::int64_t, py::array::forcecast>::ensure(kind == 'u' ? tri.attr("astype")("int64")
                                                                                       : py::object(tri));
  const auto ts = py::array_t<double, py::array::forcecast>::ensure(t);
  if (!ids || !ts) return "nearest's t must be numbers";
  for (std::size_t i = 0; i < n; ++i) {
    const std::int64_t id = ids.at(i);
    out[i] = TraceAnswer{};
    if (id < 0 || id == kNoTriangle) continue;
    // An index beyond 32 bits is out of range for any mesh: the judge calls it a tracer error.
    out[i].triangle = id > kNoTriangle ? kNoTriangle - 1 : static_cast<std::uint32_t>(id);
    out[i].t = ts.at(i);
  }
  return std::nullopt;
}

std::optional<std::string> read_all_hits(py::handle result, std::span<AllHitsAnswer> out) {
  if (!py::isinstance<py::sequence>(result) || py::isinstance<py::str>(result) || py::len(result) != out.size())
    return "all_hits must return one list of triangles per ray (" + rays_text(out.size()) + "), got " +
           py::repr(result).cast<std::string>().substr(0, 200);
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i] = AllHitsAnswer{};
    py::object hits = result[py::int_(i)];
    if (!py::isinstance<py::iterable>(hits)) return "all_hits: ray " + std::to_string(i) + ": not a list";
    for (py::handle h : hits) {
      const py::object index = py::module_::import("operator").attr("index")(h);  // integers only
      const long long id = index.cast<long long>();
      if (id < 0 || id >= static_cast<long long>(kNoTriangle))
        return "all_hits: ray " + std::to_string(i) + ": triangle " + std::to_string(id) + " out of range";
      out[i].triangles.push_back(static_cast<std::uint32_t>(id));
    }
  }
  return std::nullopt;
}

py::array rays_array(std::span<const TracerRay> rays, int what) {
  const auto n = static_cast<py::ssize_t>(rays.size());
  py::array_t<double> a = what < 2 ? py::array_t<double>({n, py::ssize_t(3)}) : py::array_t<double>(n);
  double* p = a.mutable_data();
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const TracerRay& r = rays[i];
    if (what == 0) p[3 * i] = r.ray.origin.x(), p[3 * i + 1] = r.ray.origin.y(), p[3 * i + 2] = r.ray.origin.z();
    if (what == 1)
      p[3 * i] = r.ray.direction.x(), p[3 * i + 1] = r.ray.direction.y(), p[3 * i + 2] = r.ray.direction.z();
    if (what == 2) p[i] = r.tmin;
    if (what == 3) p[i] = r.tmax;
  }
  a.attr("setflags")(py::arg("write") = false);
  return a;
}

class PythonScene : public TracerScene {
 public:
  PythonScene(std::shared_ptr<PythonTracer> owner, py::object scene, std::unique_lock<std::mutex> hold)
      : owner_(std::move(owner)), scene_(std::move(scene)), hold_(std::move(hold)) {}
  ~PythonScene() override {
    py::gil_scoped_acquire locked;
    scene_ = py::object();
  }
  void nearest(std::span<const TracerRay> rays, std::span<TraceAnswer> out) override {
    call(rays, out, "nearest", read_nearest);
  }
  void all_hits(std::span<const TracerRay> rays, std::span<AllHitsAnswer> out) override {
    py::gil_scoped_acquire locked;
    if (!py::hasattr(scene_, "all_hits")) {
      for (AllHitsAnswer& a : out) a.unsupported = true;
      return;
    }
    call(rays, out, "all_hits", read_all_hits);
  }

 private:
  // A raise is the tracer failing on these rays as a crash (its traceback the reason; the
  // campaign stops the tracer, as a plugin that crashed); a malformed answer is a tracer error.
  template <class Out, class Read>
  void call(std::span<const TracerRay> rays, std::span<Out> out, const char* method, Read read) {
    py::gil_scoped_acquire locked;
    std::optional<std::string> bad;
    try {
      py::object result =
          scene_.attr(method)(rays_array(rays, 0), rays_array(rays, 1), rays_array(rays, 2), rays_array(rays, 3));
      bad = read(result, out);
    } catch (py::error_already_set& e) {
      last_error = python_error_text(e);
      for (Out& o : out) o = Out{}, o.failure = AnswerFailure::crash;
      return;
    }
    if (bad) {
      last_error = *bad;
      for (Out& o : out) o = Out{}, o.failure = AnswerFailure::protocol;
    }
  }
  std::shared_ptr<PythonTracer> owner_;
  py::object scene_;
  std::unique_lock<std::mutex> hold_;
};

BuiltScene build_python_scene(const std::shared_ptr<PythonTracer>& owner, const TriangleMesh& mesh) {
  std::unique_lock<std::mutex> hold(owner->one_scene);  // taken without the GIL: no deadlock with a tracing thread
  py::gil_scoped_acquire locked;
  const auto v = static_cast<py::ssize_t>(mesh.vertex_count()), t = static_cast<py::ssize_t>(mesh.triangle_count());
  py::array_t<double> vertices({v, py::ssize_t(3)});
  std::copy(mesh.vertices.begin(), mesh.vertices.end(), vertices.mutable_data());
  py::array_t<std::uint32_t> triangles({t, py::ssize_t(3)});
  std::copy(mesh.indices.begin(), mesh.indices.end(), triangles.mutable_data());
  vertices.attr("setflags")(py::arg("write") = false), triangles.attr("setflags")(py::arg("write") = false);
  BuiltScene built;
  try {
    py::object scene = owner->tracer.attr("build")(vertices, triangles);
    if (scene.is_none()) {
      built.reason = "build() returned None: return the scene (self, for a tracer that keeps the mesh itself)";
      return built;
    }
    if (!py::hasattr(scene, "nearest")) {
      built.reason =
          "build() returned " + py::repr(scene).cast<std::string>().substr(0, 120) + ", which has no nearest()";
      return built;
    }
    if (!scene.is(owner->tracer)) hold.unlock();
    built.scene = std::make_unique<PythonScene>(owner, std::move(scene), std::move(hold));
  } catch (py::error_already_set& e) {
    last_error = python_error_text(e);
    built.failure = AnswerFailure::crash, built.reason = last_error;
  }
  return built;
}

// The user's object as a Tracer (core/tracer.h), named and declared as the caller says.
std::shared_ptr<Tracer> python_tracer(py::object tracer, const std::string& name, const std::string& precision,
                                      const std::string& range) {
  if (!py::hasattr(tracer, "build")) throw py::type_error("the tracer has no build(vertices, triangles) method");
  if (name.empty() || name.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789-") != std::string::npos)
    throw py::value_error("tracer name '" + name + "': use [a-z0-9-]+");
  auto owner = std::make_shared<PythonTracer>();
  owner->tracer = std::move(tracer);
  auto t = std::make_shared<Tracer>();
  t->name = name, t->precision = precision_of(precision), t->range = range_of(range);
  t->origin = "python: " + py::repr(py::type::of(owner->tracer)).cast<std::string>();
  t->source = t->origin;
  t->has_all_hits = py::hasattr(owner->tracer, "all_hits");
  t->build = [owner](const TriangleMesh& mesh) { return build_python_scene(owner, mesh); };
  t->stop_reason = [] { return last_error; };
  return t;
}

std::vector<fuzz::TracerFamily> tracer_families(const std::vector<std::string>& names) {
  std::vector<fuzz::TracerFamily> out;
  for (const std::string& f : names)
    out.push_back(named<fuzz::TracerFamily>(f, fuzz::tracer_family_from_string, "tracer family",
                                            "shared-edges, fans, axis-planes, needles, spawned, shells, far, random"));
  return out;
}

py::dict fuzz_tracer(py::object tracer, const std::vector<std::string>& family_names, std::uint64_t count,
                     std::uint64_t seed, int threads, const std::string& output, const std::string& name,
                     const std::string& precision, const std::string& range, double tolerance_ulps, bool shrink,
                     std::uint64_t max_findings) {
  const std::shared_ptr<Tracer> t = python_tracer(std::move(tracer), name, precision, range);
  fuzz::TracerCampaignOptions o;
  o.families = tracer_families(family_names);
  o.tracers = {t.get()};
  o.count = count, o.seed = seed, o.threads = std::max(1, threads), o.output = output;
  o.verdicts.tolerance_ulps = tolerance_ulps, o.shrink = shrink, o.max_findings = max_findings;
  json report;
  std::string table, one_hit;
  std::vector<std::string> diagnosis;
  {
    py::gil_scoped_release unlocked;
    const fuzz::TracerCampaignReport r = fuzz::run_tracer_campaign(o);
    report = r.to_json();
    std::ostringstream text;
    fuzz::print_tracer_report(r, TableFormat::table, text);
    table = text.str(), one_hit = fuzz::one_hit_rule_line(r, t->name), diagnosis = fuzz::tracer_diagnosis(r, t->name);
  }
  py::dict out = to_python(report);
  out["table"] = table, out["one_hit_rule"] = one_hit, out["diagnosis"] = diagnosis;
  return out;
}

// check(tracer, lines): each mesh case (a dict, as a findings file holds it) replayed on the
// tracer, one `check` line each (tracer.md, Outputs) — what `rayproof check` writes for it.
py::list check_tracer(py::object tracer, const py::list& cases, const std::string& name, const std::string& precision,
                      const std::string& range, double tolerance_ulps) {
  const std::shared_ptr<Tracer> t = python_tracer(std::move(tracer), name, precision, range);
  std::vector<MeshCase> read;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const json j = from_python(cases[i], "case " + std::to_string(i));
    if (!is_mesh_case(j)) throw py::value_error("case " + std::to_string(i) + ": not a mesh case (no \"mesh\")");
    try {
      read.push_back(read_mesh_case(j));
    } catch (const FieldError& e) {
      throw py::value_error("case " + std::to_string(i) + ": " + e.field + ": " + e.what());
    }
  }
  std::vector<nlohmann::ordered_json> lines;
  {
    py::gil_scoped_release unlocked;
    for (const MeshCase& c : read) {
      MeshOracle oracle(c.mesh);
      nlohmann::ordered_json line;
      line["id"] = c.id;
      line["expect"] = expect_json(oracle, c.ray);
      if (c.all) line["all"] = true;
      const auto seen = as_seen_by(*t, c);
      VerdictSettings settings{tolerance_ulps, std::nullopt};
      if (c.found.is_object() && c.found.contains("range") && c.found["range"].is_string())
        settings.range = range_rule_from_string(c.found["range"].get<std::string>());
      line["tracers"][t->name] = seen ? check_entry(judge_tracer_on_case(*t, *seen, settings), c.all)
                                      : nlohmann::ordered_json{{"skipped", "not_representable"}};
      lines.push_back(std::move(line));
    }
  }
  py::list out;
  for (const auto& l : lines) out.append(py::module_::import("json").attr("loads")(l.dump()));
  return out;
}

}  // namespace

PYBIND11_MODULE(_rayproof, m) {
  m.doc() = "rayproof's C++ half: the exact oracle, campaigns and tracer judging (see rayproof/__init__.py)";
  py::list classes;
  for (HitClass c :
       {HitClass::miss, HitClass::enter, HitClass::exit, HitClass::tangent, HitClass::boundary, HitClass::hit})
    classes.append(std::string(to_string(c)));
  m.attr("CLASSES") = py::tuple(classes);
  m.attr("NO_TRIANGLE") = kNoTriangle;
  m.def("judge", &judge);
  m.def("judge_many", &judge_many);
  m.def("variants", &variants);
  m.def("fuzz", &fuzz_variants);
  m.def("fuzz_tracer", &fuzz_tracer);
  m.def("check_tracer", &check_tracer);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const py::builtin_exception&) {
      throw;  // pybind11's own (type_error, value_error): its translator maps them
    } catch (const FieldError& e) {
      PyErr_SetString(PyExc_ValueError, (e.field + ": " + e.what()).c_str());
    } catch (const std::invalid_argument& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const std::runtime_error& e) {
      PyErr_SetString(PyExc_RuntimeError, e.what());
    }
  });
}
