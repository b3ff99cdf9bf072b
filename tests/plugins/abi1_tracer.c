/* A tracer library built against ABI 1 of rayproof/tracer.h (its struct without `range`): it
   answers only abi == 1, so rayproof must fall back from ABI 2 and read rows of the shorter
   stride. Two tracers, so a wrong stride shows in the second row. Brute force Möller–Trumbore. */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

struct rayproof_mesh {
  const double* vertices;
  uint32_t vertex_count;
  const uint32_t* indices;
  uint32_t triangle_count;
};
struct rayproof_ray {
  double origin[3], direction[3], tmin, tmax;
};
struct rayproof_trace {
  uint32_t triangle;
  double t;
};
struct rayproof_tracer_abi1 {
  const char* name;
  const char* precision;
  const char* source;
  void* (*build)(const struct rayproof_mesh* mesh);
  void (*nearest)(void* scene, const struct rayproof_ray* rays, size_t count, struct rayproof_trace* out);
  size_t (*all_hits)(void* scene, const struct rayproof_ray* ray, uint32_t* triangles, size_t capacity);
  void (*release)(void* scene);
};

static void* build(const struct rayproof_mesh* mesh) {
  struct rayproof_mesh* copy = malloc(sizeof *copy);
  *copy = *mesh; /* the arrays stay valid until release (tracer.md) */
  return copy;
}
static int hit(const struct rayproof_mesh* m, uint32_t i, const struct rayproof_ray* r, double* t) {
  const double* a = m->vertices + 3 * m->indices[3 * i];
  const double* b = m->vertices + 3 * m->indices[3 * i + 1];
  const double* c = m->vertices + 3 * m->indices[3 * i + 2];
  const double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const double* d = r->direction;
  const double p[3] = {d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]};
  const double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
  if (det == 0) return 0;
  const double s[3] = {r->origin[0] - a[0], r->origin[1] - a[1], r->origin[2] - a[2]};
  const double u = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) / det;
  if (u < 0 || u > 1) return 0;
  const double q[3] = {s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0]};
  const double v = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) / det;
  if (v < 0 || u + v > 1) return 0;
  *t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
  return *t > r->tmin && *t < r->tmax;
}
static void nearest(void* scene, const struct rayproof_ray* rays, size_t count, struct rayproof_trace* out) {
  const struct rayproof_mesh* m = scene;
  for (size_t k = 0; k < count; ++k) {
    out[k].triangle = 0xffffffffu;
    double best = rays[k].tmax, t;
    for (uint32_t i = 0; i < m->triangle_count; ++i)
      if (hit(m, i, rays + k, &t) && t < best) best = t, out[k].triangle = i, out[k].t = t;
  }
}
static void release(void* scene) { free(scene); }

static const struct rayproof_tracer_abi1 kTracers[] = {
    {"abi-one-first", "double", "test: an ABI 1 library", build, nearest, NULL, release},
    {"abi-one-second", "double", "test: its second row", build, nearest, NULL, release},
};

const struct rayproof_tracer_abi1* rayproof_tracers(int abi, int* count) {
  if (abi != 1) return NULL;
  *count = 2;
  return kTracers;
}
