// Reading a plugin's or tracer library's table (plugin.md, tracer.md) from the short-lived worker
// that loaded it (child_process.h, run_reporting_worker): the worker writes one JSON line, each
// of the library's strings as {"text": its first 4096 bytes, "bytes": its length}, or
// {"error": why}. Here that line is checked and its strings bounded and escaped: a 10 MB name is
// an error quoting 80 bytes of it, a source with ESC sequences reaches no terminal raw.
#pragma once

#include <cstddef>
#include <functional>
#include <stdexcept>
#include <string>

#include "rayproof/core/json_fields.h"
#include "rayproof/peers/child_process.h"
#include "rayproof/peers/process_pool.h"

namespace rayproof::peers {

inline constexpr std::size_t kMaxNameBytes = 64;      // a variant's or tracer's name
inline constexpr std::size_t kMaxSourceBytes = 1000;  // its source line, as shown by `variants`

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
  if (table.contains("error")) throw fail(printable_prefix(table.at("error").is_string() ? table.at("error").get<std::string>() : "", 1000));
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

// The source line, escaped for terminals and cut to kMaxSourceBytes.
inline std::string table_source(const json& entry) { return printable_prefix(table_string(entry, "source"), kMaxSourceBytes); }

}  // namespace rayproof::peers
