/* The float sphere of shader code, in the widely shared GLSL style (Inigo Quilez,
   "Intersectors", sphIntersect: b = dot(oc, rd); c = dot(oc, oc) - r*r; h = b*b - c;
   t = -b - sqrt(h)) for a normalised rd, written in C floats as the GPU computes it.
   Build: cc -O2 -shared -fPIC -I lib -o glsl_sphere.so examples/plugins/glsl_sphere.c -lm */
#include <math.h>

#include "rayproof/plugin.h"

static int glsl_sphere(const float ray[6], const float s[], float* t) {
  const float len = sqrtf(ray[3] * ray[3] + ray[4] * ray[4] + ray[5] * ray[5]);
  const float rd[3] = {ray[3] / len, ray[4] / len, ray[5] / len}; /* normalize(rd) */
  const float oc[3] = {ray[0] - s[0], ray[1] - s[1], ray[2] - s[2]};
  const float b = oc[0] * rd[0] + oc[1] * rd[1] + oc[2] * rd[2];
  const float c = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - s[3] * s[3];
  float h = b * b - c;
  if (h < 0.0f) return RAYPROOF_MISS; /* no intersection */
  h = sqrtf(h);
  const float near = -b - h, far = -b + h;
  const float hit = near > 0.0f ? near : far;
  if (hit <= 0.0f) return RAYPROOF_MISS;
  *t = hit / len;
  return RAYPROOF_HIT;
}

static const struct rayproof_variant variants[] = {
    {"glsl-sphere", "sphere", "nearest", "Quilez, Intersectors: sphIntersect (GLSL style, float)", 0, glsl_sphere},
};

const struct rayproof_variant* rayproof_plugin(int abi, int* count) {
  if (abi != RAYPROOF_PLUGIN_ABI) return 0;
  *count = 1;
  return variants;
}
