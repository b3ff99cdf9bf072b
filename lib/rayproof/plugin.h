/* rayproof plugin ABI, version 1 (docs/spec/plugin.md). Plain C: a plugin needs nothing else
   from rayproof to build. Export rayproof_plugin() from a shared library and pass it to any
   rayproof command with --plugin PATH. */
#ifndef RAYPROOF_PLUGIN_H
#define RAYPROOF_PLUGIN_H
#ifdef __cplusplus
extern "C" {
#endif

#define RAYPROOF_PLUGIN_ABI 1

/* What an intersection function returns. */
enum rayproof_answer {
  RAYPROOF_MISS = 0,
  RAYPROOF_ENTER = 1,
  RAYPROOF_EXIT = 2,
  RAYPROOF_TANGENT = 3,
  RAYPROOF_BOUNDARY = 4,
  RAYPROOF_HIT = 5 /* a contact whose kind the code does not say (bool + t code) */
};

/* ray = origin[3], direction[3]. shape = the numbers of cases.md in order:
   sphere center[3], radius (4); plane normal[3], offset (4);
   triangle v0[3], v1[3], v2[3] (9); box min[3], max[3] (6).
   *t is written when the answer is not RAYPROOF_MISS. */
typedef int (*rayproof_fn_f64)(const double ray[6], const double shape[], double* t);
typedef int (*rayproof_fn_f32)(const float ray[6], const float shape[], float* t);

struct rayproof_variant {
  const char* name;    /* [a-z0-9-]+, unique among all variants in use */
  const char* shape;   /* "sphere", "plane", "triangle" or "box" */
  const char* rule;    /* "nearest" or "enter-only": which contact the code reports */
  const char* source;  /* one line: the paper, formula or project it comes from */
  rayproof_fn_f64 f64; /* exactly one of f64 and f32 is not NULL */
  rayproof_fn_f32 f32;
};

/* The one exported symbol. abi is the caller's RAYPROOF_PLUGIN_ABI; a plugin built for
   another ABI returns NULL. Otherwise it returns an array of *count variants that stays
   valid while the library is loaded. */
const struct rayproof_variant* rayproof_plugin(int abi, int* count);

#ifdef __cplusplus
}
#endif
#endif
