/* Scratchapixel's geometric ray-sphere solution ("A Minimal Ray-Tracer: Rendering Simple Shapes",
   lesson "Ray-Sphere Intersection", geometric solution): project the center on the ray (tca),
   Pythagoras for thc. It assumes a unit direction, so the caller's direction is normalised first
   and t converted back to the caller's units, as users adapting it do.
   Build: cc -O2 -shared -fPIC -I lib -o scratchapixel_sphere.so examples/plugins/scratchapixel_sphere.c -lm */
#include <math.h>

#include "rayproof/plugin.h"

static int scratchapixel_sphere(const double ray[6], const double s[], double* t) {
  const double length = sqrt(ray[3] * ray[3] + ray[4] * ray[4] + ray[5] * ray[5]);
  const double dir[3] = {ray[3] / length, ray[4] / length, ray[5] / length};
  const double L[3] = {s[0] - ray[0], s[1] - ray[1], s[2] - ray[2]};
  const double tca = L[0] * dir[0] + L[1] * dir[1] + L[2] * dir[2];
  if (tca < 0) return RAYPROOF_MISS;
  const double d2 = L[0] * L[0] + L[1] * L[1] + L[2] * L[2] - tca * tca;
  const double radius2 = s[3] * s[3];
  if (d2 > radius2) return RAYPROOF_MISS;
  const double thc = sqrt(radius2 - d2);
  double t0 = tca - thc, t1 = tca + thc;
  if (t0 > t1) {
    const double x = t0;
    t0 = t1;
    t1 = x;
  }
  if (t0 < 0) {
    t0 = t1; /* if t0 is negative, use t1 instead */
    if (t0 < 0) return RAYPROOF_MISS;
  }
  *t = t0 / length;
  return RAYPROOF_HIT;
}

static const struct rayproof_variant variants[] = {
    {"scratchapixel-sphere", "sphere", "nearest", "Scratchapixel, ray-sphere intersection, geometric solution",
     scratchapixel_sphere, 0},
};

const struct rayproof_variant* rayproof_plugin(int abi, int* count) {
  if (abi != RAYPROOF_PLUGIN_ABI) return 0;
  *count = 1;
  return variants;
}
