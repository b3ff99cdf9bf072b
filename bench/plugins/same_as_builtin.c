/* The built-in `textbook` sphere (lib/variants.cpp: Rietmann 2020's quadratic formula, nearest
   rule) written again as a plugin, line for line, so a benchmark can put the plugin path's cost
   beside the built-in's on the same formula. */
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

static const struct rayproof_variant variants[] = {
    {"textbook-plugin", "sphere", "nearest", "the built-in textbook sphere, as a plugin (bench)", textbook, 0},
};

const struct rayproof_variant* rayproof_plugin(int abi, int* count) {
  if (abi != RAYPROOF_PLUGIN_ABI) return 0;
  *count = 1;
  return variants;
}
