/* The sphere of "Ray Tracing in One Weekend" (Peter Shirley, v4.0, section 6: the half-b form,
   hit only for t in [0.001, inf)) as people paste it into their first path tracer. It says "hit
   at t" and nothing more: a RAYPROOF_HIT plugin.
   Build: cc -O2 -shared -fPIC -I lib -o weekend_sphere.so examples/plugins/weekend_sphere.c -lm */
#include <math.h>

#include "rayproof/plugin.h"

static int weekend_sphere(const double ray[6], const double s[], double* t) {
  const double oc[3] = {s[0] - ray[0], s[1] - ray[1], s[2] - ray[2]}; /* center - origin */
  const double* d = ray + 3;
  const double a = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
  const double h = d[0] * oc[0] + d[1] * oc[1] + d[2] * oc[2];
  const double c = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - s[3] * s[3];
  const double discriminant = h * h - a * c;
  if (discriminant < 0) return RAYPROOF_MISS;
  const double sqrtd = sqrt(discriminant);
  double root = (h - sqrtd) / a; /* nearest root in the acceptable range */
  if (root <= 0.001) {
    root = (h + sqrtd) / a;
    if (root <= 0.001) return RAYPROOF_MISS;
  }
  *t = root;
  return RAYPROOF_HIT;
}

static const struct rayproof_variant variants[] = {
    {"weekend-sphere", "sphere", "nearest", "Shirley, Ray Tracing in One Weekend v4 sec. 6 (half-b, t_min 0.001)",
     weekend_sphere, 0},
};

const struct rayproof_variant* rayproof_plugin(int abi, int* count) {
  if (abi != RAYPROOF_PLUGIN_ABI) return 0;
  *count = 1;
  return variants;
}
