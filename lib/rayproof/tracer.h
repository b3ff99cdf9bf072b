/* rayproof tracer ABI, version 1 (docs/spec/tracer.md). Plain C: a tracer needs nothing else
   from rayproof to build. Export rayproof_tracers() from a shared library and pass it to
   `rayproof fuzz`, `check` or `audit` with --tracer PATH. */
#ifndef RAYPROOF_TRACER_H
#define RAYPROOF_TRACER_H
#ifdef __cplusplus
extern "C" {
#endif

#include <stddef.h>
#include <stdint.h>

#define RAYPROOF_TRACER_ABI 2
#define RAYPROOF_NO_TRIANGLE 0xffffffffu

/* A triangle mesh. Triangle i has vertices indices[3i], indices[3i+1], indices[3i+2]. */
struct rayproof_mesh {
  const double* vertices; /* x, y, z of each vertex */
  uint32_t vertex_count;
  const uint32_t* indices;
  uint32_t triangle_count;
};

/* A ray: points origin + t * direction with tmin < t < tmax (tmax may be +infinity). */
struct rayproof_ray {
  double origin[3], direction[3], tmin, tmax;
};

/* What a tracer reports for a ray: the triangle of its nearest hit and that hit's t,
   or triangle = RAYPROOF_NO_TRIANGLE for no hit (t is then ignored). */
struct rayproof_trace {
  uint32_t triangle;
  double t;
};

struct rayproof_tracer {
  const char* name;      /* [a-z0-9-]+, unique among the tracers and variants in use */
  const char* precision; /* "double" or "float" */
  const char* source;    /* one line: the project, paper or code it comes from */
  /* Builds the tracer's structure over a mesh; NULL if it cannot (reported, not fatal). The
     mesh's arrays stay valid and unchanged until release() of the scene built from them, so a
     tracer may keep pointers into them (as Embree's shared buffers do). */
  void* (*build)(const struct rayproof_mesh* mesh);
  /* Nearest hit of each of count rays. */
  void (*nearest)(void* scene, const struct rayproof_ray* rays, size_t count, struct rayproof_trace* out);
  /* Optional (may be NULL): every triangle the ray hits, as the tracer's any-hit traversal
     would report them; returns how many, writing at most capacity of them. */
  size_t (*all_hits)(void* scene, const struct rayproof_ray* ray, uint32_t* triangles, size_t capacity);
  void (*release)(void* scene);
  /* ABI 2: which parameters count as in range (verdicts.md): "open" (tmin < t < tmax, as
     DXR for triangles) or "closed" (tmin <= t <= tmax, as Embree and CGAL); NULL: "open". */
  const char* range;
};

/* The one exported symbol; NULL for another ABI. The array stays valid while loaded.
   rayproof asks for ABI 2 first, then 1: a library built against the ABI 1 header (the same
   struct without `range`) answers only abi == 1 and is judged as "open" unless
   --tracer-range says otherwise. */
const struct rayproof_tracer* rayproof_tracers(int abi, int* count);

#ifdef __cplusplus
}
#endif
#endif
