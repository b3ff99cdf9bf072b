// The exec-tracer protocol (docs/spec/tracer.md): a command is sent a mesh line, then one line
// per ray (numbers as hex-float strings, "inf" for an infinite tmax), and answers one line per
// ray, in order. A scene owns one running command for its lifetime; the command goes back to the
// pool when the scene is released after answering well.
#include <atomic>
#include <cctype>
#include <cmath>
#include <deque>
#include <mutex>

#include "rayproof/core/json_fields.h"
#include "rayproof/peers/exec_process.h"
#include "rayproof/peers/process_pool.h"
#include "rayproof/peers/tracers.h"
#include "rayproof/peers/loaded_code.h"

namespace rayproof::peers {

namespace {

std::string hex_string(double x) { return "\"" + hex_double(x) + "\""; }

std::string mesh_line(const TriangleMesh& m) {
  std::string line = "{\"mesh\":{\"vertices\":[";
  for (std::size_t i = 0; i < m.vertex_count(); ++i)
    line += (i ? ",[" : "[") + hex_string(m.vertices[3 * i]) + "," + hex_string(m.vertices[3 * i + 1]) + "," +
            hex_string(m.vertices[3 * i + 2]) + "]";
  line += "],\"triangles\":[";
  for (std::size_t i = 0; i < m.triangle_count(); ++i) {
    const auto c = m.corners(i);
    line += (i ? ",[" : "[") + std::to_string(c[0]) + "," + std::to_string(c[1]) + "," + std::to_string(c[2]) + "]";
  }
  return line + "]}}\n";
}

std::string ray_line(const TracerRay& r, const std::string& id, bool all) {
  auto vec = [](const Vec3& v) {
    return "[" + hex_string(v.x()) + "," + hex_string(v.y()) + "," + hex_string(v.z()) + "]";
  };
  return "{\"id\":" + json(id).dump() + ",\"origin\":" + vec(r.ray.origin) + ",\"direction\":" + vec(r.ray.direction) +
         ",\"tmin\":" + hex_string(r.tmin) + ",\"tmax\":" + hex_string(r.tmax) + (all ? ",\"all\":true" : "") + "}\n";
}

// A triangle index or null.
std::uint32_t read_triangle(const json& j, const std::string& field) {
  if (j.is_null()) return kNoTriangle;
  if (!j.is_number_unsigned() || j.get<std::uint64_t>() >= kNoTriangle)
    throw FieldError(field, "must be a triangle index or null");
  return static_cast<std::uint32_t>(j.get<std::uint64_t>());
}

// A hit's t: a number, or the text "nan" (any case, signed: JSON cannot hold a NaN), which is
// judged as the tracer's error it is. Any other text ("banana") is an unreadable line.
double read_hit_t(const json& t) {
  if (t.is_string()) {
    std::string text = t.get<std::string>();
    if (!text.empty() && (text[0] == '-' || text[0] == '+')) text.erase(0, 1);
    for (char& c : text) c = char(std::tolower(static_cast<unsigned char>(c)));
    if (text == "nan") return NAN;
  }
  return read_number(t, "t");
}

}  // namespace

json read_tracer_answer_line(const std::string& line, const std::string& id, bool all) {
  json a = parse_json_text(line);
  if (!a.is_object()) throw FieldError("", "an answer line is a JSON object");
  if (a.contains("error") && !a.contains("id")) return a;  // the command could not read the mesh
  if (!a.contains("id") || !a.at("id").is_string() || a.at("id").get<std::string>() != id)
    throw FieldError("id", "answered " + (a.contains("id") ? a.at("id").dump() : std::string("no id")) + " where \"" +
                               id + "\" was due (answers keep the order)");
  if (a.contains("error") && !(all && a.at("error") == "unsupported"))
    throw FieldError("error", printable(a.at("error").dump()));
  if (a.contains("error")) return a;
  if (all) {
    check_keys(a, "", {"id", "triangles"}, {"id", "triangles"});
    if (!a.at("triangles").is_array()) throw FieldError("triangles", "must be an array");
    for (const json& t : a.at("triangles")) read_triangle(t, "triangles");
  } else {
    check_keys(a, "", {"id", "triangle", "t"}, {"id", "triangle"});
    read_triangle(a.at("triangle"), "triangle");
    if (!a.at("triangle").is_null()) {
      if (!a.contains("t")) throw FieldError("t", "missing for a hit");
      read_hit_t(a.at("t"));
    }
  }
  return a;
}

namespace {

struct ExecTracerState : StopReason {
  std::string command;
  ExternalOptions options;
  ProcessPool<ExecProcess> processes;
  std::atomic<std::uint64_t> next_id{0};
};

class ExecTracerScene final : public TracerScene {
 public:
  ExecTracerScene(ExecTracerState& state, const TriangleMesh& mesh) : state_(state), mesh_line_(mesh_line(mesh)) {}
  ~ExecTracerScene() override {
    if (process_ && healthy_) state_.processes.give_back(std::move(process_));
  }

  void nearest(std::span<const TracerRay> rays, std::span<TraceAnswer> out) override {
    std::vector<json> answers;
    const AnswerFailure f = exchange(rays, false, answers);
    for (std::size_t i = 0; i < rays.size(); ++i) {
      if (i >= answers.size()) {
        const bool blamed = i == answers.size() || f == AnswerFailure::build_refused;
        out[i] = {kNoTriangle, NAN, blamed ? f : AnswerFailure::stopped};
        continue;
      }
      const json& a = answers[i];
      out[i] = {read_triangle(a.at("triangle"), "triangle"), NAN};
      if (out[i].hit()) {
        if (!a.contains("t")) throw FieldError("t", "missing for a hit");
        const json& t = a.at("t");
        out[i].t = read_hit_t(t);
      }
    }
  }

  void all_hits(std::span<const TracerRay> rays, std::span<AllHitsAnswer> out) override {
    std::vector<json> answers;
    const AnswerFailure f = exchange(rays, true, answers);
    for (std::size_t i = 0; i < rays.size(); ++i) {
      out[i] = {};
      if (i >= answers.size()) {
        out[i].failure = i == answers.size() || f == AnswerFailure::build_refused ? f : AnswerFailure::stopped;
        continue;
      }
      const json& a = answers[i];
      if (a.contains("error")) {
        out[i].unsupported = true;
        continue;
      }
      for (const json& t : a.at("triangles")) out[i].triangles.push_back(read_triangle(t, "triangles"));
    }
  }

 private:
  // Sends the mesh (once) and the rays, reads and checks the answer lines. Answers that came
  // before a failure are kept; the failure is returned for the ray it is blamed on.
  AnswerFailure exchange(std::span<const TracerRay> rays, bool all, std::vector<json>& answers) {
    std::lock_guard lock(mutex_);
    if (refused_) return AnswerFailure::build_refused;
    if (state_.stopped || !healthy_) return AnswerFailure::stopped;
    std::string payload;
    if (!process_) {
      process_ = state_.processes.take([&] { return std::make_unique<ExecProcess>(state_.command); });
      payload = mesh_line_;
    }
    std::vector<std::string> ids;
    for (const TracerRay& r : rays) {
      ids.push_back("r" + std::to_string(state_.next_id++));
      payload += ray_line(r, ids.back(), all);
    }
    std::vector<std::string> lines;
    AnswerFailure kind = AnswerFailure::none;
    // An all-hits answer lists at most every triangle, each shorter than in the mesh line.
    const std::size_t max_line = ExecProcess::kMaxLineBytes + mesh_line_.size();
    const std::string ended =
        process_->exchange(payload, rays.size(), state_.options.case_timeout_seconds, lines, kind, max_line);
    std::string why;
    for (std::size_t i = 0; i < lines.size() && why.empty(); ++i) {
      try {
        json a = read_tracer_answer_line(lines[i], ids[i], all);
        if (a.contains("error") && !a.contains("id")) {
          why = "could not read the mesh: " + printable(a.at("error").dump());
          kind = AnswerFailure::build_refused;  // every ray of this mesh, as a build() returning NULL
          break;
        }
        answers.push_back(std::move(a));
      } catch (const std::exception& e) {
        const auto* f = dynamic_cast<const FieldError*>(&e);
        why = "unreadable answer line '" + printable_prefix(lines[i], 200) + "'" +
              (f && !f->field.empty() ? ": " + f->field : std::string()) + ": " + printable(e.what());
        kind = AnswerFailure::protocol;
      }
    }
    if (why.empty()) why = ended;
    if (why.empty()) return AnswerFailure::none;
    healthy_ = false;  // never handed back
    if (kind == AnswerFailure::build_refused) {
      refused_ = true, answers.clear();
      state_.note(why);
      return kind;
    }
    state_.stop(why);
    return kind;
  }

  ExecTracerState& state_;
  std::string mesh_line_;
  std::unique_ptr<ExecProcess> process_;
  bool healthy_ = true;
  bool refused_ = false;  // the command could not read the mesh: every ray is build_refused
  std::mutex mutex_;
};

}  // namespace

const Tracer& add_exec_tracer(const std::string& name, const std::string& command, const ExternalOptions& options) {
  if (!valid_variant_name(name))
    throw std::runtime_error("--tracer-exec " + name + "=...: the name must match [a-z0-9-]+");
  ExecTracerState& state = loaded_code().make<ExecTracerState>();
  state.command = command, state.options = options;
  Tracer t;
  t.name = name;
  t.precision = options.exec_precision;
  t.source = "exec: " + command;
  t.origin = "exec: " + command;
  t.always_judged = true;
  t.build = [&state](const TriangleMesh& mesh) -> BuiltScene {
    if (state.stopped) return {nullptr, AnswerFailure::stopped, "stopped earlier"};
    return {std::make_unique<ExecTracerScene>(state, mesh)};
  };
  t.stop_reason = [&state] { return state.reason(); };
  try {
    return register_tracer(std::move(t));
  } catch (const std::exception& e) {
    throw std::runtime_error("--tracer-exec " + name + "=...: " + e.what());
  }
}

}  // namespace rayproof::peers
