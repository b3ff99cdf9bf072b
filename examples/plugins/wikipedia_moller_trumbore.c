/* Möller–Trumbore as the Wikipedia article "Möller–Trumbore intersection algorithm" gives it
   (C++ implementation section), in float with its EPSILON = 0.0000001 against the determinant
   and t > EPSILON for a hit. It reports a hit without saying front or back.
   Build: cc -O2 -shared -fPIC -I lib -o wikipedia_moller_trumbore.so examples/plugins/wikipedia_moller_trumbore.c */
#include <math.h>

#include "rayproof/plugin.h"

#define EPSILON 0.0000001f

static void cross(const float a[3], const float b[3], float out[3]) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}
static float dot(const float a[3], const float b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static int wikipedia_mt(const float ray[6], const float v[], float* t) {
  const float* dir = ray + 3;
  const float edge1[3] = {v[3] - v[0], v[4] - v[1], v[5] - v[2]};
  const float edge2[3] = {v[6] - v[0], v[7] - v[1], v[8] - v[2]};
  float h[3], q[3];
  cross(dir, edge2, h);
  const float a = dot(edge1, h);
  if (a > -EPSILON && a < EPSILON) return RAYPROOF_MISS; /* the ray is parallel to the triangle */
  const float f = 1.0f / a;
  const float s[3] = {ray[0] - v[0], ray[1] - v[1], ray[2] - v[2]};
  const float u = f * dot(s, h);
  if (u < 0.0f || u > 1.0f) return RAYPROOF_MISS;
  cross(s, edge1, q);
  const float w = f * dot(dir, q);
  if (w < 0.0f || u + w > 1.0f) return RAYPROOF_MISS;
  const float hit = f * dot(edge2, q);
  if (hit > EPSILON) {
    *t = hit;
    return RAYPROOF_HIT;
  }
  return RAYPROOF_MISS; /* a line intersection but not a ray intersection */
}

static const struct rayproof_variant variants[] = {
    {"wikipedia-mt", "triangle", "nearest", "Wikipedia, Moller-Trumbore intersection algorithm (float, EPSILON 1e-7)",
     0, wikipedia_mt},
};

const struct rayproof_variant* rayproof_plugin(int abi, int* count) {
  if (abi != RAYPROOF_PLUGIN_ABI) return 0;
  *count = 1;
  return variants;
}
