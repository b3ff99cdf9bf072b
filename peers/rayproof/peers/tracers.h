// Tracers from outside rayproof (docs/spec/tracer.md): a user's shared library built against
// rayproof/tracer.h, run in worker processes; a command speaking the exec-tracer protocol; and
// the peers Embree (default and robust) and CGAL's AABB tree. Each becomes a registered Tracer
// (core/tracer.h).
#pragma once

#include <string>
#include <vector>

#include "rayproof/core/json_fields.h"
#include "rayproof/core/tracer.h"
#include "rayproof/peers/external.h"

namespace rayproof::peers {

// Loads a tracer library and registers its tracers. Throws std::runtime_error with one line
// naming the file for every loading error (missing file or symbol, ABI mismatch, a bad name or
// precision, no build or nearest function, a name clash).
std::vector<const Tracer*> load_tracer_plugin(const std::string& path, const ExternalOptions& options);

// Registers `name` as a tracer answered by `/bin/sh -c command` over the exec-tracer protocol
// (precision: options.exec_precision). Throws on a bad or clashing name.
const Tracer& add_exec_tracer(const std::string& name, const std::string& command, const ExternalOptions& options);
// One answer line of the exec-tracer protocol (tracer.md), checked: the answer due for `id`
// (nearest, or with `all` the any-hit list or {"error": "unsupported"}), or {"error": ...}
// without an id (the command could not read the mesh). Throws FieldError naming the field.
json read_tracer_answer_line(const std::string& line, const std::string& id, bool all);

// The peer tracers (the command line registers them once, Embree where it was built in).
void register_embree_tracers();  // embree_tracer.cpp, in rayproof::embree
void register_cgal_aabb_tracer();

}  // namespace rayproof::peers
