// Answers files (docs/spec/plugin.md, `--answers NAME=FILE`): what the user's own program wrote
// for a case file, looked up by case id. Every problem is kept with FILE:LINE (or the case id)
// for `check` to print after the run; every other case is still judged.
#include <algorithm>
#include <deque>
#include <memory>
#include <fstream>
#include <mutex>
#include <stdexcept>
#include <unordered_map>
#include <utility>

#include "rayproof/core/json_fields.h"
#include "rayproof/peers/external.h"
#include "rayproof/peers/loaded_code.h"

namespace rayproof::peers {

namespace {

class AnswersFile final : public ExternalIntersector {
 public:
  explicit AnswersFile(const std::string& path) : path_(path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error("--answers " + path + ": cannot open");
    std::string text;
    bool first = true;  // the first line that is not blank may say the precision (plugin.md)
    for (long line = 1; std::getline(in, text); ++line) {
      if (text.find_first_not_of(" \t\r") == std::string::npos) continue;
      const bool may_say_precision = std::exchange(first, false);
      if (may_say_precision && text.find("\"precision\"") != std::string::npos) {
        read_precision(text);
        continue;
      }
      try {
        AnswerLine a = parse_answer_line(text);
        auto [it, fresh] = by_id_.try_emplace(a.id, Entry{a.answer, line, false});
        if (!fresh)
          problems_.push_back(where(line) + ": id '" + printable(a.id) + "' repeats line " +
                              std::to_string(it->second.line));
      } catch (const FieldError& e) {
        problems_.push_back(where(line) + ": " + (e.field.empty() ? "" : e.field + ": ") + printable(e.what()));
      } catch (const std::exception& e) {
        problems_.push_back(where(line) + ": " + printable(e.what()));  // a parse error quotes the raw bytes
      }
    }
  }

  Precision precision() const { return precision_; }

  void answer_all(std::span<const Query> qs, std::span<Answer> out, AnswerTiming*) override {
    std::lock_guard lock(mutex_);
    for (size_t i = 0; i < qs.size(); ++i) {
      auto it = by_id_.find(qs[i].id);
      if (it == by_id_.end()) {
        problems_.push_back(path_ + ": no answer for case '" + printable(qs[i].id) + "'");
        out[i] = Answer::failure_of(AnswerFailure::stopped);  // not judged, not counted: reported above
        continue;
      }
      it->second.used = true;
      out[i] = it->second.answer;
    }
  }

  // Every problem so far, and the answers no case asked for (call after the run).
  std::vector<std::string> problems() const {
    std::lock_guard lock(mutex_);
    std::vector<std::string> out = problems_;
    std::vector<std::pair<long, std::string>> unused;
    for (const auto& [id, e] : by_id_)
      if (!e.used) unused.push_back({e.line, id});
    std::sort(unused.begin(), unused.end());
    for (const auto& [line, id] : unused) out.push_back(where(line) + ": id '" + printable(id) + "' is not a case");
    return out;
  }

 private:
  struct Entry {
    Answer answer;
    long line;
    bool used;
  };
  std::string where(long line) const { return printable(path_) + ":" + std::to_string(line); }
  void read_precision(const std::string& text) {
    try {
      const json j = parse_json_text(text);
      check_keys(j, "", {"precision"}, {"precision"});
      const std::string p = j.at("precision").is_string() ? j.at("precision").get<std::string>() : "";
      if (p != "float" && p != "double") throw FieldError("precision", "must be \"float\" or \"double\"");
      precision_ = p == "float" ? Precision::f32 : Precision::f64;
    } catch (const FieldError& e) {
      problems_.push_back(where(1) + ": " + (e.field.empty() ? "" : e.field + ": ") + printable(e.what()));
    } catch (const std::exception& e) {
      problems_.push_back(where(1) + ": " + printable(e.what()));
    }
  }
  std::string path_;
  Precision precision_ = Precision::f64;
  mutable std::mutex mutex_;
  std::unordered_map<std::string, Entry> by_id_;
  std::vector<std::string> problems_;
};

}  // namespace

const Variant& add_answers_variant(const std::string& name, const std::string& path) {
  if (!valid_variant_name(name)) throw std::runtime_error("--answers " + name + "=...: the name must match [a-z0-9-]+");
  if (find_variant(name)) throw std::runtime_error("--answers " + name + "=...: a variant of that name exists already");
  AnswersFile& answers = loaded_code().make<AnswersFile>(path);
  const std::string& stored_name = loaded_code().keep(name);
  const std::string& origin = loaded_code().keep("answers: " + path);
  Variant v{stored_name, ShapeKind::sphere, origin, nullptr};
  v.precision = answers.precision();
  v.external = &answers;
  v.origin = origin;
  v.all_shapes = true;
  return register_variant(v);
}

std::vector<std::string> answers_problems(const Variant& v) {
  if (auto* a = dynamic_cast<const AnswersFile*>(v.external)) return a->problems();
  return {};
}

}  // namespace rayproof::peers
