/* Tracers that misbehave on purpose, one way each, for tests/test_tracers.cpp: rayproof must
   count or report each and never crash, keeping what it judged before. */
#include <math.h>
#include <signal.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "rayproof/tracer.h"

static int scene_token;
static void* build_ok(const struct rayproof_mesh* mesh) {
  (void)mesh;
  return &scene_token;
}
static void* build_crash(const struct rayproof_mesh* mesh) {
  (void)mesh;
  raise(SIGSEGV);
  return NULL;
}
static void* build_null(const struct rayproof_mesh* mesh) {
  (void)mesh;
  return NULL;
}
static void release(void* scene) { (void)scene; }
/* Takes memory in 64 MiB blocks, touching each, up to 1 GiB (then gives it back and builds):
   under a smaller --worker-memory malloc fails first and, as careless code does, it writes
   through the NULL it got. */
static void* build_hog(const struct rayproof_mesh* mesh) {
  (void)mesh;
  enum { kBlock = 64 << 20, kBlocks = 16 };
  char* blocks[kBlocks];
  for (int i = 0; i < kBlocks; ++i) {
    blocks[i] = malloc(kBlock);
    memset(blocks[i], 1, kBlock);
  }
  for (int i = 0; i < kBlocks; ++i) free(blocks[i]);
  return &scene_token;
}

/* Every ray: triangle 0 with t = NaN. */
static void nearest_nan(void* s, const struct rayproof_ray* rays, size_t n, struct rayproof_trace* out) {
  (void)s, (void)rays;
  for (size_t i = 0; i < n; ++i) out[i].triangle = 0, out[i].t = NAN;
}
/* Every ray: a triangle index no mesh here has. */
static void nearest_out_of_range(void* s, const struct rayproof_ray* rays, size_t n, struct rayproof_trace* out) {
  (void)s, (void)rays;
  for (size_t i = 0; i < n; ++i) out[i].triangle = 1000000, out[i].t = 1;
}
/* Every ray: triangle 0 at a t below tmin. */
static void nearest_outside(void* s, const struct rayproof_ray* rays, size_t n, struct rayproof_trace* out) {
  (void)s;
  for (size_t i = 0; i < n; ++i) out[i].triangle = 0, out[i].t = rays[i].tmin - 1;
}
/* Misses everything, until the third call: then it crashes. */
static int calls;
static void nearest_crash_later(void* s, const struct rayproof_ray* rays, size_t n, struct rayproof_trace* out) {
  (void)s, (void)rays;
  if (++calls >= 3) raise(SIGABRT);
  for (size_t i = 0; i < n; ++i) out[i].triangle = RAYPROOF_NO_TRIANGLE, out[i].t = 0;
}
static void nearest_hang(void* s, const struct rayproof_ray* rays, size_t n, struct rayproof_trace* out) {
  (void)s, (void)rays, (void)n, (void)out;
  for (;;) pause();
}
/* Forks on every call, then misses: the copy must never answer, the batch never be judged. */
static void nearest_forks(void* s, const struct rayproof_ray* rays, size_t n, struct rayproof_trace* out) {
  (void)s, (void)rays;
  (void)fork();
  for (size_t i = 0; i < n; ++i) out[i].triangle = RAYPROOF_NO_TRIANGLE, out[i].t = 0;
}
/* Any-hit lists every triangle twice. */
static size_t all_twice(void* s, const struct rayproof_ray* ray, uint32_t* out, size_t capacity) {
  (void)s, (void)ray;
  if (capacity >= 2) out[0] = 0, out[1] = 0;
  return 2;
}
/* Any-hit reports 100 hits out of range (more than the first capacity offered): rayproof must ask
   again with room for all, then count the answer a tracer error. */
static size_t all_many(void* s, const struct rayproof_ray* ray, uint32_t* out, size_t capacity) {
  (void)s, (void)ray;
  for (size_t i = 0; i < 100 && i < capacity; ++i) out[i] = 1000000u + (uint32_t)i;
  return 100;
}

/* Any-hit writes 64 bytes of 0xff past the ray it was given: into the next rays, or, for the
   batch's last ray, over the per-ray counts rayproof reads back (issue 42). */
static size_t all_corrupts(void* s, const struct rayproof_ray* ray, uint32_t* out, size_t capacity) {
  (void)s, (void)out, (void)capacity;
  memset((char*)(ray + 1), 0xff, 64);
  return 0;
}
/* Any-hit claims 10^6 hits (on meshes of a few triangles), all triangle 0: never more room than
   the mesh's triangles + 1 may be made for it (issue 42). */
static size_t all_huge(void* s, const struct rayproof_ray* ray, uint32_t* out, size_t capacity) {
  (void)s, (void)ray;
  for (size_t i = 0; i < capacity && i < 1000000; ++i) out[i] = 0;
  return 1000000;
}

/* Answers one ray two ways: triangle 0 at tmin + 1 on every third call, else a miss (issue 42). */
static int flaky_calls;
static void nearest_flaky(void* s, const struct rayproof_ray* rays, size_t n, struct rayproof_trace* out) {
  (void)s;
  const int hit = ++flaky_calls % 3 == 0;
  for (size_t i = 0; i < n; ++i) {
    out[i].triangle = hit ? 0 : RAYPROOF_NO_TRIANGLE;
    out[i].t = rays[i].tmin + 1;
  }
}

/* Zero-copy: keeps the mesh's pointers from build() and reads the vertices only while tracing
   (brute force, Möller–Trumbore in double). Right only if the mesh stays valid and unchanged
   until release(), as tracer.md promises (issue 42, item 15). */
static struct rayproof_mesh kept;
static void* build_keep(const struct rayproof_mesh* mesh) {
  kept = *mesh; /* the pointers, not the data */
  return &kept;
}
static void nearest_zero_copy(void* s, const struct rayproof_ray* rays, size_t n, struct rayproof_trace* out) {
  const struct rayproof_mesh* m = (const struct rayproof_mesh*)s;
  for (size_t r = 0; r < n; ++r) {
    const double* o = rays[r].origin;
    const double* d = rays[r].direction;
    out[r].triangle = RAYPROOF_NO_TRIANGLE, out[r].t = rays[r].tmax;
    for (uint32_t k = 0; k < m->triangle_count; ++k) {
      const double* a = m->vertices + 3 * m->indices[3 * k];
      const double* b = m->vertices + 3 * m->indices[3 * k + 1];
      const double* c = m->vertices + 3 * m->indices[3 * k + 2];
      double e1[3], e2[3], p[3], sv[3], q[3];
      for (int i = 0; i < 3; ++i) e1[i] = b[i] - a[i], e2[i] = c[i] - a[i], sv[i] = o[i] - a[i];
      p[0] = d[1] * e2[2] - d[2] * e2[1], p[1] = d[2] * e2[0] - d[0] * e2[2], p[2] = d[0] * e2[1] - d[1] * e2[0];
      const double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
      if (det == 0) continue;
      const double u = (sv[0] * p[0] + sv[1] * p[1] + sv[2] * p[2]) / det;
      if (u < 0 || u > 1) continue;
      q[0] = sv[1] * e1[2] - sv[2] * e1[1], q[1] = sv[2] * e1[0] - sv[0] * e1[2], q[2] = sv[0] * e1[1] - sv[1] * e1[0];
      const double v = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) / det;
      if (v < 0 || u + v > 1) continue;
      const double t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
      if (t > rays[r].tmin && t < out[r].t) out[r].triangle = k, out[r].t = t;
    }
  }
}

static const struct rayproof_tracer kTracers[] = {
    {"bad-build-crash", "double", "test: segfaults in build", build_crash, nearest_nan, NULL, release},
    {"bad-build-null", "double", "test: build returns NULL", build_null, nearest_nan, NULL, release},
    {"bad-nan-t", "double", "test: NaN t", build_ok, nearest_nan, all_twice, release},
    {"bad-out-of-range", "double", "test: triangle out of range", build_ok, nearest_out_of_range, all_many, release},
    {"bad-t-outside", "float", "test: t below tmin", build_ok, nearest_outside, NULL, release},
    {"bad-crash-later", "double", "test: aborts on its third call", build_ok, nearest_crash_later, NULL, release},
    {"bad-hang", "double", "test: never answers", build_ok, nearest_hang, NULL, release},
    {"bad-forks", "double", "test: forks on every call", build_ok, nearest_forks, NULL, release},
    {"bad-corrupts-counts", "double", "test: any-hit writes past its ray", build_ok, nearest_out_of_range, all_corrupts,
     release},
    {"bad-huge-any-hit", "double", "test: any-hit claims 10^6 hits", build_ok, nearest_out_of_range, all_huge, release},
    {"bad-flaky", "double", "test: answers one ray two ways", build_ok, nearest_flaky, NULL, release},
    {"zero-copy", "double", "test: reads the mesh only while tracing", build_keep, nearest_zero_copy, NULL, release},
    {"bad-hog", "double", "test: takes 1 GiB in build", build_hog, nearest_out_of_range, NULL, release},
};

const struct rayproof_tracer* rayproof_tracers(int abi, int* count) {
  if (abi != RAYPROOF_TRACER_ABI) return NULL;
  *count = (int)(sizeof kTracers / sizeof kTracers[0]);
  return kTracers;
}
