// The exec protocol (docs/spec/plugin.md): a command started with /bin/sh -c is sent one case per
// line and answers one line per case, in order. Writing and reading interleave through poll() on
// non-blocking pipes, so neither side can wedge the other on a full pipe however many cases are
// in flight; the command's standard error is rayproof's.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstring>
#include <deque>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>

#include "rayproof/core/json_fields.h"
#include "rayproof/peers/crash_budget.h"
#include "rayproof/peers/exec_process.h"
#include "rayproof/peers/external.h"
#include "rayproof/peers/process_pool.h"
#include "rayproof/peers/loaded_code.h"

extern char** environ;

namespace rayproof::peers {

namespace {
// x as a C99 hex float ("0x1.8p+1", exact), appended: std::to_chars in hex is several times
// faster than printf's %a, and the exec protocol writes ten of these per case.
void append_hex(std::string& out, double x) {
  char buf[40];
  const bool negative = std::signbit(x);
  char* p = buf;
  if (negative) *p++ = '-';
  *p++ = '0', *p++ = 'x';
  const auto [end, ec] = std::to_chars(p, buf + sizeof buf, std::fabs(x), std::chars_format::hex);
  out.append(buf, ec == std::errc() ? end : p);
}
}  // namespace

std::string exec_case_line(const Query& q, const std::string& id) {
  std::string line = "{\"id\":" + json(id).dump() + ",\"ray\":{\"origin\":[";
  line.reserve(512);
  auto numbers = [&](const double* x, int n) {
    for (int i = 0; i < n; ++i) {
      line += i ? ",\"" : "\"";
      append_hex(line, x[i]);
      line += '"';
    }
  };
  const double origin[3] = {q.ray.origin.x(), q.ray.origin.y(), q.ray.origin.z()};
  const double direction[3] = {q.ray.direction.x(), q.ray.direction.y(), q.ray.direction.z()};
  numbers(origin, 3);
  line += "],\"direction\":[";
  numbers(direction, 3);
  double s[kMaxShapeNumbers];
  shape_numbers(q.shape, s);
  line += "]},\"shape\":{\"type\":\"" + std::string(to_string(kind_of(q.shape))) + "\"";
  const double* next = s;
  for (const ShapeField& f : shape_fields(kind_of(q.shape))) {
    line += ",\"" + std::string(f.name) + "\":";
    if (f.vectors == 0) {
      numbers(next++, 1);
      continue;
    }
    line += f.nested() ? "[[" : "[";
    for (int i = 0; i < f.vectors; ++i, next += 3) {
      if (i) line += "],[";
      numbers(next, 3);
    }
    line += f.nested() ? "]]" : "]";
  }
  return line + "}}\n";
}

namespace {
// A t written as a word (plugin.md, extended compatibly): "inf", "+inf", "-inf", "Infinity",
// "-Infinity" are ±∞ on every path, as a plugin's t is; "nan", "NaN" is a NaN t (a plugin error).
// Python's json module writes Infinity, -Infinity and NaN bare; both forms are read.
std::optional<double> t_word(std::string_view w) {
  const bool minus = !w.empty() && w[0] == '-';
  if (!w.empty() && (w[0] == '-' || w[0] == '+')) w.remove_prefix(1);
  if (w == "inf" || w == "Infinity" || w == "INF" || w == "Inf") return minus ? -INFINITY : INFINITY;
  if (w == "nan" || w == "NaN" || w == "NAN") return NAN;
  return std::nullopt;
}

// The line with Python's bare Infinity, -Infinity and NaN (outside strings) quoted, so that the
// JSON reader takes them and t_word reads them.
std::string with_python_words_quoted(const std::string& text) {
  std::string out;
  bool in_string = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      out += c;
      if (c == '\\' && i + 1 < text.size())
        out += text[++i];
      else if (c == '"')
        in_string = false;
      continue;
    }
    if (c == '"') in_string = true;
    bool quoted = false;
    for (std::string_view word : {"-Infinity", "Infinity", "NaN"})
      if (text.compare(i, word.size(), word) == 0) {
        out += "\"" + std::string(word) + "\"", i += word.size() - 1, quoted = true;
        break;
      }
    if (!quoted) out += c;
  }
  return out;
}

// The common answer line, {"id": "...", "class": "...", "t": ...} with plain strings, read
// without building a JSON tree; nullopt for anything else (escapes, other keys, repeats, bad
// values), which the full reader then reads or rejects with a message naming the field.
std::optional<AnswerLine> parse_answer_fast(std::string_view s) {
  size_t i = 0;
  auto skip = [&] {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t' || s[i] == '\r')) ++i;
  };
  auto expect = [&](char c) {
    skip();
    if (i >= s.size() || s[i] != c) return false;
    return ++i, true;
  };
  auto plain_string = [&](std::string_view& out) {
    if (!expect('"')) return false;
    const size_t end = s.find('"', i);
    if (end == std::string_view::npos) return false;
    out = s.substr(i, end - i);
    if (out.find('\\') != std::string_view::npos) return false;
    for (char c : out)
      if (static_cast<unsigned char>(c) < 0x20) return false;
    i = end + 1;
    return true;
  };
  if (!expect('{')) return std::nullopt;
  std::optional<std::string_view> id, cls, t;
  bool t_null = false, t_quoted = false;
  for (bool first = true;; first = false) {
    skip();
    if (!first && i < s.size() && s[i] == '}') {
      ++i;
      break;
    }
    if (!first && !expect(',')) return std::nullopt;
    std::string_view key, value;
    if (!plain_string(key) || !expect(':')) return std::nullopt;
    skip();
    if (key == "t" && !t && !t_null) {
      if (s.substr(i, 4) == "null") {
        t_null = true, i += 4;
        continue;
      }
      if (i < s.size() && s[i] == '"') {
        if (!plain_string(value)) return std::nullopt;
        t = value, t_quoted = true;
        continue;
      }
      const size_t end = s.find_first_of(",} \t\r", i);
      if (end == std::string_view::npos) return std::nullopt;
      t = s.substr(i, end - i), i = end;
      continue;
    }
    if (!plain_string(value)) return std::nullopt;
    if (key == "id" && !id)
      id = value;
    else if (key == "class" && !cls)
      cls = value;
    else
      return std::nullopt;
  }
  skip();
  if (i != s.size() || !id || !cls) return std::nullopt;
  const auto c = answer_class_from_string(*cls);
  if (!c) return std::nullopt;
  AnswerLine a{std::string(*id), Hit{*c}};
  if (*c == HitClass::miss) return a;
  if (!t) {
    if (*c != HitClass::tangent) a.answer.failure = AnswerFailure::t_unwritten;
    return a;
  }
  std::optional<double> x = t_word(*t);
  if (x) {
    if (std::isnan(*x)) return a.answer.failure = AnswerFailure::nan_t, a;
  } else if (t_quoted) {
    x = parse_hex_double(*t);  // a string is a hex float or nothing (cases.md)
  } else if (!t->empty() && t->find_first_not_of("0123456789+-.eE") == std::string_view::npos) {
    double v;
    const auto [end, ec] = std::from_chars(t->data(), t->data() + t->size(), v);  // nearest double, as strtod
    if (ec == std::errc() && end == t->data() + t->size()) x = v;
  }
  if (!x || std::isnan(*x)) return std::nullopt;  // the full reader names what is wrong
  a.answer.t = *x;
  return a;
}
}  // namespace

AnswerLine parse_answer_line(const std::string& text) {
  if (auto fast = parse_answer_fast(text)) return std::move(*fast);
  const json j = parse_json_text(text.find_first_of("IN") == std::string::npos ? text : with_python_words_quoted(text));
  if (!j.is_object()) throw FieldError("", "an answer line is a JSON object");
  check_keys(j, "", {"id", "class", "t"}, {"id", "class"});
  if (!j.at("id").is_string()) throw FieldError("id", "must be a string");
  if (!j.at("class").is_string()) throw FieldError("class", "must be a string");
  AnswerLine a;
  a.id = j.at("id").get<std::string>();
  const auto cls = answer_class_from_string(j.at("class").get<std::string>());
  if (!cls) throw FieldError("class", "must be miss, enter, exit, tangent, boundary or hit");
  a.answer.cls = *cls;
  const bool has_t = j.contains("t") && !j.at("t").is_null();
  if (*cls == HitClass::miss) return a;  // a miss's t means nothing
  if (has_t) {
    const auto word = j.at("t").is_string() ? t_word(j.at("t").get<std::string>()) : std::nullopt;
    if (word && std::isnan(*word)) return a.answer.failure = AnswerFailure::nan_t, a;
    a.answer.t = word ? *word : read_number(j.at("t"), "t");
  } else if (*cls != HitClass::tangent) {
    a.answer.failure = AnswerFailure::t_unwritten;  // only a tangent may come without t (a ray lying in the surface)
  }
  return a;
}

namespace {

class ExecVariant final : public ExternalIntersector {
 public:
  ExecVariant(std::string command, const ExternalOptions& options)
      : command_(std::move(command)), options_(options), budget_(options.max_crashes) {}

  void answer_all(std::span<const Query> qs, std::span<Answer> out, AnswerTiming*) override {
    for (std::size_t done = 0; done < qs.size();) {
      if (budget_.stopped())
        return std::fill(out.begin() + done, out.end(), Answer::failure_of(AnswerFailure::stopped));
      done += answer_until_failure(qs.subspan(done), out.subspan(done));
    }
  }
  Answer probe(const Query& q) override {
    ExecProcess process(command_);  // its own: a crash here spends no budget and stops nothing
    std::vector<std::string> lines;
    AnswerFailure kind = AnswerFailure::none;
    const std::string ended =
        process.exchange(exec_case_line(q, "probe"), 1, options_.case_timeout_seconds, lines, kind);
    if (lines.empty()) return Answer::failure_of(kind != AnswerFailure::none ? kind : AnswerFailure::crash);
    try {
      const AnswerLine a = parse_answer_line(lines[0]);
      return a.id == "probe" ? a.answer : Answer::failure_of(AnswerFailure::protocol);
    } catch (const std::exception&) {
      return Answer::failure_of(AnswerFailure::protocol);
    }
  }
  std::string stop_reason() const override { return budget_.stop_reason(); }
  std::string last_failure() const override { return budget_.last_failure(); }

 private:
  // One command answers the cases in order; returns how many are settled (all, or up to and
  // including the case it failed on).
  std::size_t answer_until_failure(std::span<const Query> qs, std::span<Answer> out) {
    std::unique_ptr<ExecProcess> process = take();
    std::string payload;
    std::vector<std::string> ids;
    for (const Query& q : qs) {
      ids.push_back(q.id.empty() ? "q" + std::to_string(next_id_++) : q.id);
      payload += exec_case_line(q, ids.back());
    }
    std::vector<std::string> lines;
    AnswerFailure kind = AnswerFailure::none;
    const std::string ended = process->exchange(payload, qs.size(), options_.case_timeout_seconds, lines, kind);
    std::string why;  // the lines that came are judged even when the command then failed
    std::size_t i = 0;
    for (; i < lines.size(); ++i) {
      try {
        AnswerLine a = parse_answer_line(lines[i]);
        if (a.id != ids[i]) {
          why = "answered id '" + printable(a.id) + "' where '" + printable(ids[i]) +
                "' was due (answers must keep the order)";
          break;
        }
        out[i] = a.answer;
      } catch (const std::exception& e) {
        const auto* f = dynamic_cast<const FieldError*>(&e);
        why = "unreadable answer line '" + printable_prefix(lines[i], 200) + "'" +
              (f && !f->field.empty() ? ": " + f->field : std::string()) + ": " + printable(e.what());
        break;
      }
    }
    if (!why.empty())
      kind = AnswerFailure::protocol;
    else
      why = ended;
    if (why.empty()) {
      give_back(std::move(process));
      return qs.size();
    }
    if (i == qs.size()) return i;  // every case answered before it ended: its answers stand, the process goes
    // The command is gone (or spoke wrongly): blame the case it was on; after a crash or a hang a
    // fresh command goes on with the next case while the crash budget lasts. A protocol error
    // stops it now: a fresh command would answer the same way.
    out[i] = Answer::failure_of(kind);
    if (kind == AnswerFailure::protocol)
      budget_.stop(why);
    else
      budget_.spend(why);
    return i + 1;
  }

  std::unique_ptr<ExecProcess> take() {
    return processes_.take([this] { return std::make_unique<ExecProcess>(command_); });
  }
  void give_back(std::unique_ptr<ExecProcess> p) { processes_.give_back(std::move(p)); }
  std::string command_;
  ExternalOptions options_;
  CrashBudget budget_;
  std::atomic<std::uint64_t> next_id_{0};
  ProcessPool<ExecProcess> processes_;
};

}  // namespace

const Variant& add_exec_variant(const std::string& name, const std::string& command, const ExternalOptions& options,
                                const std::vector<ShapeKind>& shapes) {
  if (!valid_variant_name(name)) throw std::runtime_error("--exec " + name + "=...: the name must match [a-z0-9-]+");
  if (find_variant(name)) throw std::runtime_error("--exec " + name + "=...: a variant of that name exists already");
  ExecVariant& intersector = loaded_code().make<ExecVariant>(command, options);
  const std::string& stored_name = loaded_code().keep(name);
  const std::string& origin = loaded_code().keep("exec: " + command);
  Variant v{stored_name, ShapeKind::sphere, origin, nullptr};
  v.precision = options.exec_precision;
  v.external = &intersector;
  v.origin = origin;
  // One declared shape: an ordinary variant of that shape; several (or none): it answers each.
  v.all_shapes = shapes.size() != 1;
  if (shapes.size() == 1) v.shape = shapes[0];
  for (ShapeKind k : shapes) v.shape_mask |= 1u << static_cast<unsigned>(k);
  if (v.all_shapes && !shapes.empty()) v.shape = shapes[0];
  return register_variant(v);
}

}  // namespace rayproof::peers
