/* Plugins that must not load, one per compile definition: each is a one-line error, exit code 2.
 * Their table is read in a worker (issue 26): code run at load time (an exit, a printf) is the
 * plugin's, and strings from the table are bounded and escaped. FORKING loads, and forks on
 * every call: its answers must be reported as a plugin error, never judged. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "rayproof/plugin.h"

static int answer(const double r[6], const double s[], double* t) {
  (void)r, (void)s, (void)t;
  return 0;
}
static int answer_f(const float r[6], const float s[], float* t) {
  (void)r, (void)s, (void)t;
  return 0;
}

#if defined(FORKING)
/* A correct enough sphere answer (miss or enter at the near root), computed after a fork(). */
static int forking(const double r[6], const double s[], double* t) {
  (void)fork();
  double oc[3], b = 0, c = -s[3] * s[3], a = 0;
  for (int i = 0; i < 3; ++i) oc[i] = r[i] - s[i], a += r[3 + i] * r[3 + i], b += oc[i] * r[3 + i], c += oc[i] * oc[i];
  const double disc = b * b - a * c;
  if (disc < 0) return RAYPROOF_MISS;
  *t = (-b - __builtin_sqrt(disc)) / a;
  return *t > 0 ? RAYPROOF_ENTER : RAYPROOF_MISS;
}
static const struct rayproof_variant v[] = {{"forking", "sphere", "nearest", "tests: forks on every call", forking, 0}};
#elif defined(BAD_SHAPE)
static const struct rayproof_variant v[] = {{"bad-shape", "torus", "nearest", "", answer, 0}};
#elif defined(BAD_RULE)
static const struct rayproof_variant v[] = {{"bad-rule", "sphere", "first", "", answer, 0}};
#elif defined(BOTH_FUNCTIONS)
static const struct rayproof_variant v[] = {{"both", "sphere", "nearest", "", answer, answer_f}};
#elif defined(NAME_CLASH)
static const struct rayproof_variant v[] = {{"stable", "sphere", "nearest", "", answer, 0}};
#elif defined(BAD_NAME)
static const struct rayproof_variant v[] = {{"Bad Name", "sphere", "nearest", "", answer, 0}};
#elif defined(ESC_SOURCE)
static const struct rayproof_variant v[] = {
    {"esc-source", "sphere", "nearest", "\x1b[2J\x1b]0;owned\x07line\nbreak", answer, 0}};
#else
static struct rayproof_variant v[] = {{"other-abi", "sphere", "nearest", "", answer, 0}};
#endif

const struct rayproof_variant* rayproof_plugin(int abi, int* count) {
  (void)abi, (void)answer_f, (void)answer;
  *count = 1;
#if defined(EXIT_AT_LOAD)
  exit(0);
#elif defined(PRINT_AT_LOAD)
  printf("{\"id\": \"not-a-result\"}\n");
  fflush(stdout);
  return 0; /* and then refuses the ABI: the printed line must not reach rayproof's output */
#elif defined(HUGE_NAME)
  char* name = malloc(10u << 20);
  memset(name, 'a', (10u << 20) - 1);
  name[(10u << 20) - 1] = 0;
  v[0].name = name;
  return v;
#elif !defined(BAD_SHAPE) && !defined(BAD_RULE) && !defined(BOTH_FUNCTIONS) && !defined(NAME_CLASH) && \
    !defined(BAD_NAME) && !defined(ESC_SOURCE) && !defined(FORKING)
  if (abi == RAYPROOF_PLUGIN_ABI) return 0; /* built for another ABI */
#endif
  return v;
}
