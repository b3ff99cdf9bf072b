// Reading a plugin's or tracer library's table (plugin.md, tracer.md) from the short-lived worker
// that loaded it (child_process.h, run_reporting_worker): the worker writes one JSON line, each
// of the library's strings as {"text": its first 4096 bytes, "bytes": its length}, or
// {"error": why}. Here that line is checked and its strings bounded and escaped: a 10 MB name is
// an error quoting 80 bytes of it, a source with ESC sequences reaches no terminal raw.
#pragma once

#include <dlfcn.h>
#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <functional>
#include <stdexcept>
#include <string>

#include "rayproof/core/json_fields.h"
#include "rayproof/peers/child_process.h"
#include "rayproof/peers/process_pool.h"

namespace rayproof::peers {

inline constexpr std::size_t kMaxNameBytes = 64;         // a variant's or tracer's name
inline constexpr std::size_t kMaxSourceBytes = 1000;     // its source line, as shown by `variants`
inline constexpr std::size_t kMaxReportedString = 4096;  // of a library's strings, the bytes the table worker copies

// ------------------------------------------------------------------------- the worker's side
// How a worker starts, from its environment setting "table:PATH" or "serve:PATH": fork watching
// set up before any library code runs (below), the table's
// descriptor (standard output, before that is pointed at standard error so that a library's
// printf never lands in rayproof's results), and crash signals left to end the process as they
// are (a sanitizer's handlers would turn them into an exit status), so rayproof can name them.
struct WorkerStart {
  bool table_only;
  std::string path;
  int report_fd;
};

// A library that forks (fork(), not posix_spawn or system()) is seen through pthread_atfork:
// the copy learns it is one before fork() returns in it, and the worker learns that it forked
// before fork() returns in the worker, so the batch it is on is reported, with no race and no
// system call per call.
namespace worker_detail {
inline bool is_copy = false, forked = false;
inline void mark_parent() { forked = true; }
inline void mark_child() { is_copy = true; }
}  // namespace worker_detail
inline bool is_forked_copy() { return worker_detail::is_copy; }  // this process is a copy: it must never answer
inline bool library_forked() { return worker_detail::forked; }   // the library forked in this worker

inline WorkerStart start_worker(const std::string& setting) {
  ::pthread_atfork(nullptr, worker_detail::mark_parent, worker_detail::mark_child);
  WorkerStart w{setting.rfind("table:", 0) == 0, setting.substr(setting.find(':') + 1), -1};
  if (w.table_only) w.report_fd = ::dup(1);
  ::dup2(2, 1);
  for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT, SIGTRAP}) ::signal(sig, SIG_DFL);
  return w;
}

// Loads the library and calls its table function `symbol` (see `header`); null with `error`
// set when there is no usable table. `what`: "variants" or "tracers".
template <class Row>
const Row* load_library_table(const std::string& path, const char* symbol, int abi, const char* header,
                              const char* what, int& count, std::string& error) {
  void* lib = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!lib) return error = ::dlerror(), nullptr;
  using Entry = const Row* (*)(int, int*);
  const auto entry = reinterpret_cast<Entry>(::dlsym(lib, symbol));
  if (!entry)
    return error = std::string("no symbol ") + symbol + " (export it with C linkage: see " + header + ")", nullptr;
  count = 0;
  const Row* table = entry(abi, &count);
  if (!table)
    error = std::string(symbol) + " returned NULL for ABI " + std::to_string(abi) + " (built for another ABI?)";
  else if (count <= 0 || count > 64)
    error = std::string(symbol) + " gave " + std::to_string(count) + " " + what + " (1 to 64 expected)",
    table = nullptr;
  return table;
}

// One of the library's strings as the table worker reports it: bounded (a 10 MB name is
// reported by its length, never copied whole); escaped later, on rayproof's side.
inline json describe_string(const char* text) {
  if (!text) return nullptr;
  const std::size_t bytes = ::strnlen(text, kMaxReportedString + 1);
  return json{{"text", std::string(text, std::min(bytes, kMaxReportedString))}, {"bytes", bytes}};
}

// Writes {"error": error} or {key: rows} as one line to the table descriptor and ends the worker.
[[noreturn]] inline void report_table_and_exit(int fd, const std::string& error, const char* key, const json& rows) {
  const std::string text = json_text(error.empty() ? json{{key, rows}} : json{{"error", error}}) + "\n";
  for (std::size_t at = 0; at < text.size();) {
    const ssize_t n = ::write(fd, text.data() + at, text.size() - at);
    if (n <= 0) ::_exit(5);
    at += static_cast<std::size_t>(n);
  }
  ::_exit(0);
}

// After a worker loaded its table: a copy the library forked at load time ends saying nothing;
// a table worker reports `describe(entry)` for each entry (under `key`) and ends; a serving
// worker without a table ends (status 3), else goes on to serve.
template <class Entry, class Describe>
void report_table_or_go_on(const WorkerStart& start, const Entry* table, int count, const std::string& error,
                           const char* key, Describe&& describe) {
  if (is_forked_copy()) ::_exit(0);
  if (start.table_only) {
    json rows = json::array();
    for (int i = 0; table && i < count; ++i) rows.push_back(describe(table[i]));
    report_table_and_exit(start.report_fd, error, key, rows);
  }
  if (!table) ::_exit(3);
}

// ---------------------------------------------------------------------- rayproof's side

// The table the worker reported, or `fail(why)` thrown: the worker ended without a report
// (exit at load, a crash, a hang past `seconds`), wrote something unreadable, or said an error.
inline json read_table_in_worker(const char* env_name, const std::string& file, const char* arg0, double seconds,
                                 const std::function<std::runtime_error(const std::string&)>& fail) {
  const WorkerReport r = run_reporting_worker(env_name, "table:" + file, arg0, std::max(seconds, 10.0));
  json table;
  try {
    table = parse_json_text(r.text);
  } catch (const std::exception&) {
    if (r.killed) throw fail("loading it did not finish within " + std::to_string(std::max(seconds, 10.0)) + " s");
    throw fail("loading it ended the worker process (" + signal_reason(r.status) + ") before it gave its table" +
               (r.text.empty() ? "" : " (it wrote '" + printable_prefix(r.text, 80) + "')"));
  }
  if (!table.is_object()) throw fail("the table worker wrote '" + printable_prefix(r.text, 80) + "'");
  if (table.contains("error"))
    throw fail(printable_prefix(table.at("error").is_string() ? table.at("error").get<std::string>() : "", 1000));
  return table;
}

// A string of the table ("" when the library gave NULL), as the library wrote it (at most 4096 bytes).
inline std::string table_string(const json& entry, const char* key) {
  const json& s = entry.contains(key) ? entry.at(key) : json();
  return s.is_object() && s.contains("text") && s.at("text").is_string() ? s.at("text").get<std::string>() : "";
}

// Whether the entry's `key` is a valid name: [a-z0-9-]+, at most kMaxNameBytes.
inline bool bounded_name(const json& entry, const char* key) {
  const json& s = entry.contains(key) ? entry.at(key) : json();
  if (!s.is_object() || s.value("bytes", std::size_t{0}) > kMaxNameBytes) return false;
  const std::string name = table_string(entry, key);
  return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-';
  });
}

// Row `i` of a table of `kind`s ("variant", "tracer"): its label for messages ("variant 3
// 'name'"), after its name is checked; `fail(text)` makes the exception thrown for a bad name.
template <class Fail>
std::string checked_row_label(const json& row, const char* kind, std::size_t i, Fail&& fail) {
  const std::string name = table_string(row, "name");
  std::string where = kind + (" " + std::to_string(i)) + (name.empty() ? "" : " '" + printable_prefix(name, 80) + "'");
  if (!bounded_name(row, "name"))
    throw fail(where + ": name must match [a-z0-9-]+ (at most " + std::to_string(kMaxNameBytes) + " bytes)");
  return where;
}

// The source line, escaped for terminals and cut to kMaxSourceBytes.
inline std::string table_source(const json& entry) {
  return printable_prefix(table_string(entry, "source"), kMaxSourceBytes);
}

}  // namespace rayproof::peers
