/* The built-in `textbook` sphere (lib/variants.cpp: Rietmann 2020's quadratic formula, nearest
   rule) and `moller-trumbore` triangle written again as a plugin, line for line, so a benchmark
   (and an audit of a scene) can put the plugin path's cost beside the built-in's on the same
   formula. */
#include <math.h>

#include "rayproof/plugin.h"

static int textbook(const double r[6], const double s[], double* t) {
  const double oc[3] = {r[0] - s[0], r[1] - s[1], r[2] - s[2]};
  const double a = r[3] * r[3] + r[4] * r[4] + r[5] * r[5];
  const double b = 2 * (r[3] * oc[0] + r[4] * oc[1] + r[5] * oc[2]);
  const double c = (oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2]) - s[3] * s[3];
  const double disc = b * b - 4 * a * c;
  if (disc < 0) return RAYPROOF_MISS;
  const double root = sqrt(disc);
  const double t0 = (-b - root) / (2 * a), t1 = (-b + root) / (2 * a);
  if (disc == 0) return t0 > 0 ? (*t = t0, RAYPROOF_TANGENT) : RAYPROOF_MISS;
  if (t0 > 0) return *t = t0, RAYPROOF_ENTER;
  if (t1 > 0) return *t = t1, RAYPROOF_EXIT;
  return RAYPROOF_MISS;
}

static void cross3(const double a[3], const double b[3], double out[3]) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}
static double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/* Möller & Trumbore 1997, as lib/variants.cpp computes it (nearest rule). */
static int moller_trumbore(const double r[6], const double s[], double* t_out) {
  const double* d = r + 3;
  const double e1[3] = {s[3] - s[0], s[4] - s[1], s[5] - s[2]};
  const double e2[3] = {s[6] - s[0], s[7] - s[1], s[8] - s[2]};
  double p[3], q[3];
  cross3(d, e2, p);
  const double det = dot3(e1, p);
  if (det == 0) return RAYPROOF_MISS;
  const double inv_det = 1 / det;
  const double sv[3] = {r[0] - s[0], r[1] - s[1], r[2] - s[2]};
  const double u = dot3(sv, p) * inv_det;
  if (u < 0 || u > 1) return RAYPROOF_MISS;
  cross3(sv, e1, q);
  const double v = dot3(d, q) * inv_det;
  if (v < 0 || u + v > 1) return RAYPROOF_MISS;
  const double t = dot3(e2, q) * inv_det;
  if (!(t > 0)) return RAYPROOF_MISS;
  *t_out = t;
  if (u == 0 || v == 0 || u + v == 1) return RAYPROOF_BOUNDARY;
  return det > 0 ? RAYPROOF_ENTER : RAYPROOF_EXIT;
}

static const struct rayproof_variant variants[] = {
    {"textbook-plugin", "sphere", "nearest", "the built-in textbook sphere, as a plugin (bench)", textbook, 0},
    {"moller-trumbore-plugin", "triangle", "nearest", "the built-in moller-trumbore, as a plugin (bench)",
     moller_trumbore, 0},
};

const struct rayproof_variant* rayproof_plugin(int abi, int* count) {
  if (abi != RAYPROOF_PLUGIN_ABI) return 0;
  *count = 2;
  return variants;
}
