// Case files (docs/spec/cases.md): JSON Lines, one ray–shape query per line.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "rayproof/core/hit.h"
#include "rayproof/core/json_fields.h"
#include "rayproof/core/query.h"

namespace rayproof {

struct Expectation {
  HitClass cls;
  std::optional<double> t;  // may be +inf ("inf"): a contact beyond the double range
};

// A query read from a case file (its id required), with what the file says about it.
struct Case : Query {
  std::optional<Expectation> expect;
  json found;  // kept verbatim, otherwise ignored; null when absent
};

// One line that could not be read: "FILE:LINE: field: message".
struct CaseError {
  std::string file;
  long line = 0;
  std::string field;
  std::string message;
  std::string to_string() const;
};

// Parses one line's JSON text. Throws FieldError (field "" for a JSON syntax error).
Case parse_case(const std::string& text);
json case_to_json(const Case& c);

// Reads a case file line by line, calling on_case for each good case and on_error for each bad
// one; the rest of the file is still read after an error. Blank lines are skipped. Duplicate
// ids are errors. Returns false if the file cannot be opened (reported through on_error).
// Lines holding a "mesh" (docs/spec/tracer.md: mesh cases) go to on_mesh_case, read by
// read_mesh_case (core/mesh_case.h); without it they are errors.
struct MeshCase;
bool read_case_file(const std::string& path, const std::function<void(const Case&, long line)>& on_case,
                    const std::function<void(const CaseError&)>& on_error,
                    const std::function<void(const MeshCase&, long line)>& on_mesh_case = {});

}  // namespace rayproof
