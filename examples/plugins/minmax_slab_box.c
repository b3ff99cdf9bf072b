/* The branch-free slab test of BVH traversal loops (Tavian Barnes, "Fast, Branchless Ray/Bounding
   Box Intersections", 2011 and 2015): t1 = (min - o) * inv_dir, t2 = (max - o) * inv_dir, then
   tmin = max(tmin, min(t1, t2)), tmax = min(tmax, max(t1, t2)); hit when tmax >= max(tmin, 0).
   Its t is the entry distance, or 0 from inside (traversal only needs the box, not the point).
   Build: cc -O2 -shared -fPIC -I lib -o minmax_slab_box.so examples/plugins/minmax_slab_box.c -lm */
#include <math.h>

#include "rayproof/plugin.h"

static int minmax_slab(const double ray[6], const double b[], double* t) {
  double tmin = -INFINITY, tmax = INFINITY;
  for (int i = 0; i < 3; ++i) {
    const double inv = 1.0 / ray[3 + i];
    const double t1 = (b[i] - ray[i]) * inv, t2 = (b[3 + i] - ray[i]) * inv;
    tmin = fmax(tmin, fmin(t1, t2));
    tmax = fmin(tmax, fmax(t1, t2));
  }
  if (tmax < fmax(tmin, 0.0)) return RAYPROOF_MISS;
  *t = tmin > 0 ? tmin : tmax; /* entering, else leaving from inside */
  return tmin > 0 ? RAYPROOF_ENTER : RAYPROOF_EXIT;
}

static const struct rayproof_variant variants[] = {
    {"minmax-slab", "box", "nearest", "Barnes 2011/2015, branchless slab test (fmin/fmax, as in BVH traversal)",
     minmax_slab, 0},
};

const struct rayproof_variant* rayproof_plugin(int abi, int* count) {
  if (abi != RAYPROOF_PLUGIN_ABI) return 0;
  *count = 1;
  return variants;
}
