/* Plugins that must not load, one per compile definition: each is a one-line error, exit code 2. */
#include "rayproof/plugin.h"

static int answer(const double r[6], const double s[], double* t) { (void)r, (void)s, (void)t; return 0; }
static int answer_f(const float r[6], const float s[], float* t) { (void)r, (void)s, (void)t; return 0; }

#if defined(BAD_SHAPE)
static const struct rayproof_variant v[] = {{"bad-shape", "torus", "nearest", "", answer, 0}};
#elif defined(BAD_RULE)
static const struct rayproof_variant v[] = {{"bad-rule", "sphere", "first", "", answer, 0}};
#elif defined(BOTH_FUNCTIONS)
static const struct rayproof_variant v[] = {{"both", "sphere", "nearest", "", answer, answer_f}};
#elif defined(NAME_CLASH)
static const struct rayproof_variant v[] = {{"stable", "sphere", "nearest", "", answer, 0}};
#elif defined(BAD_NAME)
static const struct rayproof_variant v[] = {{"Bad Name", "sphere", "nearest", "", answer, 0}};
#else
static const struct rayproof_variant v[] = {{"other-abi", "sphere", "nearest", "", answer, 0}};
#endif

const struct rayproof_variant* rayproof_plugin(int abi, int* count) {
#if !defined(BAD_SHAPE) && !defined(BAD_RULE) && !defined(BOTH_FUNCTIONS) && !defined(NAME_CLASH) && !defined(BAD_NAME)
  if (abi == RAYPROOF_PLUGIN_ABI) return 0; /* built for another ABI */
#endif
  (void)abi, (void)answer_f;
  *count = 1;
  return v;
}
