/* A small float BVH of the kind people write from tutorials (median split, a stack, a slab test,
   Möller–Trumbore), exported as two tracers, each with the bugs public trackers keep reporting:

   naive-float-bvh      1/0 replaced by 1e30 "to avoid division by zero" (tinybvh, many ports),
                        and Wikipedia's |det| < 1e-7 "parallel" test, not scale invariant.
   naive-float-bvh-nan  the slab test with fminf/fmaxf over (b - o) * (1/d): for a zero direction
                        component and an origin on the slab's plane, 0 * inf = NaN, and fminf
                        drops the NaN the wrong way (the 0·inf case of Williams et al. 2005).

   float-bvh-careful-slab the same BVH and triangle test with a slab test that survives 1/0:
                        inv = 1/d (±inf), NaN ends ignored by comparisons — the control that
                        shows which holes the two slab bugs add.

   float-bvh-top-left   careful slab + Woop et al.'s watertight test in float with a top-left tie
                        rule on zero edge functions: one hit per shared edge, as GPU APIs promise.
   float-bvh-top-left-1e30  the same with the 1e30 reciprocal: now an edge owned by the triangle
                        in the skipped node is a hole (with an inclusive test the neighbour hid it).

   The first three test triangles inclusively (u >= 0, v >= 0, u + v <= 1); all accept t > tmin:
   any-hit reports both triangles of a shared edge, and a ray leaving a surface can hit it again.
   rayproof finds each (README, "What rayproof finds in tracers").
   Build: cc -O2 -shared -fPIC -I lib -o naive_float_bvh.so examples/tracers/naive_float_bvh.c */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rayproof/tracer.h"

typedef struct {
  float lo[3], hi[3];
  int left, count, first;
} Node; /* leaf: count > 0 */
typedef struct {
  float* v;      /* 9 floats per triangle, in the order of `ids` */
  uint32_t* ids; /* the mesh's triangle index of each */
  Node* nodes;
  int node_count;
  int slab_kind; /* which slab test (which tracer): 0 1e30, 1 fminf NaN, 2 careful */
  int top_left;  /* triangle test: 0 Möller–Trumbore, 1 watertight with a top-left rule */
} Scene;

static void grow(float lo[3], float hi[3], const float* p) {
  for (int k = 0; k < 3; ++k) {
    if (p[k] < lo[k]) lo[k] = p[k];
    if (p[k] > hi[k]) hi[k] = p[k];
  }
}

static int build_node(Scene* s, int first, int count) {
  const int index = s->node_count++;
  Node* n = &s->nodes[index];
  for (int k = 0; k < 3; ++k) n->lo[k] = INFINITY, n->hi[k] = -INFINITY;
  float clo[3] = {INFINITY, INFINITY, INFINITY}, chi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (int i = first; i < first + count; ++i) {
    float c[3];
    for (int k = 0; k < 3; ++k) c[k] = (s->v[9 * i + k] + s->v[9 * i + 3 + k] + s->v[9 * i + 6 + k]) / 3;
    for (int j = 0; j < 3; ++j) grow(n->lo, n->hi, s->v + 9 * i + 3 * j);
    grow(clo, chi, c);
  }
  if (count <= 2) {
    n->count = count, n->first = first;
    return index;
  }
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (chi[k] - clo[k] > chi[axis] - clo[axis]) axis = k;
  const float mid = (clo[axis] + chi[axis]) / 2;
  int split = first;
  for (int i = first; i < first + count; ++i) {
    const float c = (s->v[9 * i + axis] + s->v[9 * i + 3 + axis] + s->v[9 * i + 6 + axis]) / 3;
    if (c < mid) {
      float tmp[9];
      memcpy(tmp, s->v + 9 * i, sizeof tmp);
      memcpy(s->v + 9 * i, s->v + 9 * split, sizeof tmp);
      memcpy(s->v + 9 * split, tmp, sizeof tmp);
      const uint32_t id = s->ids[i];
      s->ids[i] = s->ids[split], s->ids[split] = id;
      ++split;
    }
  }
  if (split == first || split == first + count) split = first + count / 2; /* median by count */
  n->count = 0;
  build_node(s, first, split - first);
  s->nodes[index].left = build_node(s, split, first + count - split);
  return index;
}

static void* build(const struct rayproof_mesh* mesh, int slab_kind, int top_left) {
  Scene* s = calloc(1, sizeof *s);
  const int n = (int)mesh->triangle_count;
  s->v = malloc(sizeof(float) * 9 * n);
  s->ids = malloc(sizeof(uint32_t) * n);
  s->nodes = malloc(sizeof(Node) * 2 * n);
  s->slab_kind = slab_kind, s->top_left = top_left;
  for (int i = 0; i < n; ++i) {
    s->ids[i] = (uint32_t)i;
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) s->v[9 * i + 3 * j + k] = (float)mesh->vertices[3 * mesh->indices[3 * i + j] + k];
  }
  build_node(s, 0, n);
  return s;
}
static void* build_1e30(const struct rayproof_mesh* mesh) { return build(mesh, 0, 0); }
static void* build_nan(const struct rayproof_mesh* mesh) { return build(mesh, 1, 0); }
static void* build_careful(const struct rayproof_mesh* mesh) { return build(mesh, 2, 0); }
static void* build_top_left(const struct rayproof_mesh* mesh) { return build(mesh, 2, 1); }
static void* build_top_left_1e30(const struct rayproof_mesh* mesh) { return build(mesh, 0, 1); }

static void release(void* scene) {
  Scene* s = scene;
  free(s->v), free(s->ids), free(s->nodes), free(s);
}

typedef struct {
  float o[3], d[3], inv[3], tmin, tmax;
} FRay;

static FRay make_ray(const struct rayproof_ray* r, int slab_kind) {
  FRay f;
  for (int k = 0; k < 3; ++k) {
    f.o[k] = (float)r->origin[k], f.d[k] = (float)r->direction[k];
    if (slab_kind != 0)
      f.inv[k] = 1.0f / f.d[k];
    else
      f.inv[k] = f.d[k] != 0 ? 1.0f / f.d[k] : 1e30f; /* "avoid the division by zero" */
  }
  f.tmin = (float)r->tmin, f.tmax = (float)r->tmax;
  return f;
}

static int slab(const FRay* r, const Node* n, float tfar_limit, int slab_kind) {
  float t0 = r->tmin, t1 = tfar_limit;
  for (int k = 0; k < 3; ++k) {
    const float a = (n->lo[k] - r->o[k]) * r->inv[k], b = (n->hi[k] - r->o[k]) * r->inv[k];
    if (slab_kind != 2) {
      t0 = fmaxf(t0, fminf(a, b));
      t1 = fminf(t1, fmaxf(a, b));
      continue;
    }
    /* careful: the near end by the sign of inv, and a NaN end (0 * inf) changes nothing */
    const float near = r->inv[k] < 0 ? b : a, far = r->inv[k] < 0 ? a : b;
    if (near > t0) t0 = near;
    if (far < t1) t1 = far;
  }
  /* and conservative: each end rounds three times (difference, reciprocal, product), so the far
     end widened by 1 + 2*gamma(3) covers the exact interval (pbrt-v4's robust box test); without
     it a ray grazing a node's face drops the node (found by rayproof: any-hit holes on shared
     edges, bug-level) */
  if (slab_kind == 2) t1 *= 1.0f + 2.0f * (3 * 0x1p-24f / (1 - 3 * 0x1p-24f));
  return t0 <= t1;
}

/* Möller–Trumbore, Wikipedia's form; inclusive edges. */
static int triangle(const FRay* r, const float* v, float* t) {
  const float e1[3] = {v[3] - v[0], v[4] - v[1], v[5] - v[2]}, e2[3] = {v[6] - v[0], v[7] - v[1], v[8] - v[2]};
  const float h[3] = {r->d[1] * e2[2] - r->d[2] * e2[1], r->d[2] * e2[0] - r->d[0] * e2[2],
                      r->d[0] * e2[1] - r->d[1] * e2[0]};
  const float det = e1[0] * h[0] + e1[1] * h[1] + e1[2] * h[2];
  if (det > -1e-7f && det < 1e-7f) return 0;
  const float f = 1.0f / det;
  const float s[3] = {r->o[0] - v[0], r->o[1] - v[1], r->o[2] - v[2]};
  const float u = f * (s[0] * h[0] + s[1] * h[1] + s[2] * h[2]);
  if (u < 0.0f || u > 1.0f) return 0;
  const float q[3] = {s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0]};
  const float w = f * (r->d[0] * q[0] + r->d[1] * q[1] + r->d[2] * q[2]);
  if (w < 0.0f || u + w > 1.0f) return 0;
  *t = f * (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]);
  return *t > r->tmin && *t < r->tmax;
}

/* Woop, Benthin & Wald 2013 in float (zero edge functions recomputed in double), with a
   top-left rule: a zero edge function is inside only on edges pointing up, or right when flat. */
static int owns(float ex, float ey) { return ey > 0 || (ey == 0 && ex > 0); }
static int triangle_top_left(const FRay* r, const float* v, float* t) {
  int kz = 0;
  if (fabsf(r->d[1]) > fabsf(r->d[kz])) kz = 1;
  if (fabsf(r->d[2]) > fabsf(r->d[kz])) kz = 2;
  int kx = (kz + 1) % 3, ky = (kx + 1) % 3;
  if (r->d[kz] < 0) {
    const int k = kx;
    kx = ky;
    ky = k;
  }
  const float sx = r->d[kx] / r->d[kz], sy = r->d[ky] / r->d[kz], sz = 1.0f / r->d[kz];
  float p[3][3];
  for (int j = 0; j < 3; ++j)
    for (int k = 0; k < 3; ++k) p[j][k] = v[3 * j + k] - r->o[k];
  const float ax = p[0][kx] - sx * p[0][kz], ay = p[0][ky] - sy * p[0][kz];
  const float bx = p[1][kx] - sx * p[1][kz], by = p[1][ky] - sy * p[1][kz];
  const float cx = p[2][kx] - sx * p[2][kz], cy = p[2][ky] - sy * p[2][kz];
  float u = cx * by - cy * bx, w1 = ax * cy - ay * cx, w = bx * ay - by * ax;
  if (u == 0 || w1 == 0 || w == 0) {
    u = (float)((double)cx * by - (double)cy * bx);
    w1 = (float)((double)ax * cy - (double)ay * cx);
    w = (float)((double)bx * ay - (double)by * ax);
  }
  if ((u < 0 || w1 < 0 || w < 0) && (u > 0 || w1 > 0 || w > 0)) return 0;
  const float det = u + w1 + w;
  if (det == 0) return 0;
  if (u == 0 && !owns(cx - bx, cy - by)) return 0;
  if (w1 == 0 && !owns(ax - cx, ay - cy)) return 0;
  if (w == 0 && !owns(bx - ax, by - ay)) return 0;
  *t = (u * sz * p[0][kz] + w1 * sz * p[1][kz] + w * sz * p[2][kz]) / det;
  return *t > r->tmin && *t < r->tmax;
}

/* Visits the nodes the slab test accepts; `all` collects every hit, else keeps the nearest. */
static size_t trace(const Scene* s, const FRay* r, int all, uint32_t* out, size_t capacity,
                    struct rayproof_trace* best) {
  int stack[128], top = 0;
  size_t found = 0;
  float nearest = r->tmax;
  best->triangle = RAYPROOF_NO_TRIANGLE;
  stack[top++] = 0;
  while (top > 0) {
    const Node* n = &s->nodes[stack[--top]];
    if (!slab(r, n, nearest, s->slab_kind)) continue;
    if (n->count == 0) {
      stack[top++] = n->left;
      stack[top++] = (int)(n - s->nodes) + 1;
      continue;
    }
    for (int i = n->first; i < n->first + n->count; ++i) {
      float t;
      if (!(s->top_left ? triangle_top_left(r, s->v + 9 * i, &t) : triangle(r, s->v + 9 * i, &t))) continue;
      if (all) {
        if (found < capacity) out[found] = s->ids[i];
        ++found;
      } else if (t < nearest) {
        nearest = t, best->triangle = s->ids[i], best->t = t;
      }
    }
  }
  return found;
}

static void nearest(void* scene, const struct rayproof_ray* rays, size_t count, struct rayproof_trace* out) {
  const Scene* s = scene;
  for (size_t i = 0; i < count; ++i) {
    const FRay r = make_ray(rays + i, s->slab_kind);
    trace(s, &r, 0, NULL, 0, out + i);
  }
}

static size_t all_hits(void* scene, const struct rayproof_ray* ray, uint32_t* triangles, size_t capacity) {
  const Scene* s = scene;
  const FRay r = make_ray(ray, s->slab_kind);
  struct rayproof_trace unused;
  return trace(s, &r, 1, triangles, capacity, &unused);
}

static const struct rayproof_tracer kTracers[] = {
    {"naive-float-bvh", "float", "example: tutorial float BVH, 1/0 -> 1e30, |det| < 1e-7, inclusive MT", build_1e30,
     nearest, all_hits, release},
    {"naive-float-bvh-nan", "float", "example: tutorial float BVH, fminf/fmaxf slab with 0*inf = NaN, inclusive MT",
     build_nan, nearest, all_hits, release},
    {"float-bvh-careful-slab", "float", "example: the same float BVH with a slab test that survives 1/0 (the control)",
     build_careful, nearest, all_hits, release},
    {"float-bvh-top-left", "float", "example: careful slab + float watertight with a top-left tie rule", build_top_left,
     nearest, all_hits, release},
    {"float-bvh-top-left-1e30", "float", "example: float watertight with a top-left tie rule, 1/0 -> 1e30 slab",
     build_top_left_1e30, nearest, all_hits, release},
};

const struct rayproof_tracer* rayproof_tracers(int abi, int* count) {
  if (abi != RAYPROOF_TRACER_ABI) return NULL;
  *count = 5;
  return kTracers;
}
