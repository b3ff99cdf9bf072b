// What every campaign's findings file needs, in one place: a lock so two campaigns never write
// one file, a hash of the bytes written so a resume can tell the file is the one its
// checkpoint describes, and the checkpoint protocol (written atomically beside the options'
// fingerprint; read back only by a campaign with the same options).
#pragma once

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "rayproof/core/atomic_file.h"
#include "rayproof/core/json_fields.h"

namespace rayproof::fuzz {

// FNV-1a over the findings bytes written.
struct FindingsHash {
  std::uint64_t value = 0xcbf29ce484222325ull;
  void add(std::string_view bytes) {
    for (unsigned char c : bytes) value = (value ^ c) * 0x100000001b3ull;
  }
};

// Where a variant's or tracer's code comes from, for a campaign's fingerprint: its origin ("built-in",
// "exec: COMMAND", a library) and, where the origin is a file (a plugin), the FNV-1a hash of its
// bytes — another build of the library under the same path and name changes the findings as
// surely as an option does (issue 42).
inline std::string code_identity(const std::string& origin) {
  std::ifstream in(origin, std::ios::binary);
  if (!in) return origin;
  FindingsHash h;
  char buffer[1 << 16];
  while (in.read(buffer, sizeof buffer) || in.gcount() > 0) h.add(std::string_view(buffer, std::size_t(in.gcount())));
  char hex[20];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h.value));
  return origin + " fnv1a:" + hex;
}

// The findings file, locked for the campaign (flock: a second campaign on the same output is
// refused instead of interleaving with this one).
class FindingsLock {
 public:
  explicit FindingsLock(const std::string& path) {
    fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) throw std::runtime_error(path + ": cannot write: " + std::strerror(errno));
    if (::flock(fd_, LOCK_EX | LOCK_NB) != 0)
      throw std::runtime_error(path + ": another rayproof campaign is writing it; wait for it or choose another -o");
  }
  ~FindingsLock() { ::close(fd_); }
  FindingsLock(const FindingsLock&) = delete;

 private:
  int fd_ = -1;
};

// Whether a findings line is a rounding-level finding (found.level is "rounding"). Read by a SAX
// parser that stops at that key: found's keys come before the mesh, which is most of a line's
// bytes, so a line is not parsed whole (a full parse of every line cost as much as judging).
// A line that is not a JSON object, or has no found.level before its first error, is no rounding
// finding.
inline bool is_rounding_finding(const std::string& line) {
  struct LevelReader : nlohmann::json_sax<json> {
    int depth = 0;
    bool in_found = false, at_found = false, at_level = false, rounding = false;
    bool value() { return at_level = at_found = false, true; }
    bool null() override { return value(); }
    bool boolean(bool) override { return value(); }
    bool number_integer(number_integer_t) override { return value(); }
    bool number_unsigned(number_unsigned_t) override { return value(); }
    bool number_float(number_float_t, const string_t&) override { return value(); }
    bool binary(binary_t&) override { return value(); }
    bool string(string_t& s) override {
      if (!at_level) return value();
      rounding = s == "rounding";
      return false;  // found.level read: stop
    }
    bool start_object(std::size_t) override {
      if (depth == 1) in_found = at_found;
      at_found = at_level = false;
      return ++depth, true;
    }
    bool end_object() override {
      if (--depth == 1) in_found = false;
      return true;
    }
    bool start_array(std::size_t) override { return at_found = at_level = false, ++depth, true; }
    bool end_array() override { return --depth, true; }
    bool key(string_t& k) override {
      at_found = depth == 1 && k == "found";
      at_level = in_found && depth == 2 && k == "level";
      return true;
    }
    bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception&) override { return false; }
  } reader;
  json::sax_parse(line, &reader, nlohmann::detail::input_format_t::json, false);
  return reader.rounding;
}

// The findings file rewritten (atomically) with bug-level findings before rounding-level ones
// (found.level), each group in the order found (verdicts.md §4). A line that is not a finding
// stays with the bugs.
inline void rewrite_bugs_first(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return;  // a device or FIFO: written as it came
  std::ifstream in(path);
  std::string line, bugs, rounding;
  while (std::getline(in, line)) (is_rounding_finding(line) ? rounding : bugs) += line + "\n";
  if (rounding.empty()) return;
  AtomicFile file(path);
  file.stream() << bugs << rounding;
  file.commit();
}

// Whether the first `bytes` bytes of the file hash to `expected`.
inline bool prefix_matches(const std::string& path, std::uintmax_t bytes, const FindingsHash& expected) {
  std::ifstream in(path, std::ios::binary);
  FindingsHash h;
  std::vector<char> buffer(1 << 16);
  while (bytes > 0 && in) {
    in.read(buffer.data(), static_cast<std::streamsize>(std::min<std::uintmax_t>(bytes, buffer.size())));
    h.add(std::string_view(buffer.data(), static_cast<size_t>(in.gcount())));
    bytes -= static_cast<std::uintmax_t>(in.gcount());
  }
  return bytes == 0 && h.value == expected.value;
}

// Writes {"fingerprint": fingerprint, ...state's keys} to `path` atomically.
inline void write_checkpoint(const std::string& path, const json& fingerprint, const json& state) {
  json j = {{"fingerprint", fingerprint}};
  j.update(state);
  AtomicFile f(path);
  f.stream() << json_text(j) << "\n";
  f.commit();
}

// Reads the checkpoint at `path` with `parse` (json → the campaign's Checkpoint), after checking
// that it belongs to a campaign with this fingerprint; every way it can be unreadable throws a
// runtime_error naming the file.
template <class Parse>
auto read_checkpoint(const std::string& path, const json& fingerprint, Parse&& parse) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  try {
    const json j = parse_json_text(text.str());
    if (j.at("fingerprint") != fingerprint)
      throw std::runtime_error(path +
                               ": checkpoint belongs to a campaign with other options: " + j.at("fingerprint").dump());
    return parse(j);
  } catch (const json::exception& e) {
    throw std::runtime_error(path + ": unreadable checkpoint: " + e.what());
  } catch (const FieldError& e) {
    throw std::runtime_error(path + ": unreadable checkpoint: " + std::string(e.what()));
  }
}

// Opens the (locked) findings file `output` for appending. A fresh run first removes any old
// checkpoint, then empties the file and saves `fresh` (a kill in the first batch resumes from
// zero); `resume` loads the checkpoint, checks that the file holds the findings it records (size,
// hash of the bytes) and cuts the file back to them (a batch written after it is done again).
// Checkpoint: has `findings_bytes` and `findings_hash`.
template <class Checkpoint, class Load, class Save>
Checkpoint open_findings_file(const std::string& output, const std::string& checkpoint_path, bool resume, Load&& load,
                              Save&& save, std::ofstream& out) {
  Checkpoint cp;
  const bool has_checkpoint = std::filesystem::exists(checkpoint_path);
  if (resume && has_checkpoint) {
    cp = load();
    const std::uintmax_t size = std::filesystem::file_size(output);
    if (size < cp.findings_bytes)
      throw std::runtime_error(output + ": " + std::to_string(size) + " bytes, shorter than the " +
                               std::to_string(cp.findings_bytes) + " its checkpoint records: not the file " +
                               checkpoint_path + " belongs to; refusing to resume");
    if (!prefix_matches(output, cp.findings_bytes, cp.findings_hash))
      throw std::runtime_error(output + ": its first " + std::to_string(cp.findings_bytes) +
                               " bytes are not the findings " + checkpoint_path + " records; refusing to resume");
    std::filesystem::resize_file(output, cp.findings_bytes);
  } else {
    if (resume && std::filesystem::file_size(output) > 0)
      throw std::runtime_error(checkpoint_path + ": no checkpoint to resume from");
    if (has_checkpoint) std::filesystem::remove(checkpoint_path);  // a fresh run supersedes it first
    std::filesystem::resize_file(output, 0);
    save(cp);
  }
  out.open(output, std::ios::app | std::ios::binary);
  if (!out) throw std::runtime_error(output + ": cannot write");
  return cp;
}

}  // namespace rayproof::fuzz
