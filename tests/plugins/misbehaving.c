/* A plugin that does everything a plugin should not, each on a case that the tests can aim at:
   rayproof must report each and never go down. The sphere's radius picks the misbehaviour. */
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include "rayproof/plugin.h"

/* The textbook quadratic, nearest root with t > 0, answered as a bare hit. */
static int sphere_hit(const double r[6], const double s[], double* t) {
  const double oc[3] = {r[0] - s[0], r[1] - s[1], r[2] - s[2]};
  const double a = r[3] * r[3] + r[4] * r[4] + r[5] * r[5];
  const double b = 2 * (oc[0] * r[3] + oc[1] * r[4] + oc[2] * r[5]);
  const double c = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - s[3] * s[3];
  const double disc = b * b - 4 * a * c;
  if (disc < 0) return RAYPROOF_MISS;
  const double t0 = (-b - sqrt(disc)) / (2 * a), t1 = (-b + sqrt(disc)) / (2 * a);
  if (t0 > 0) return *t = t0, RAYPROOF_HIT;
  if (t1 > 0) return *t = t1, RAYPROOF_HIT;
  return RAYPROOF_MISS;
}

/* radius 13: segfault; 17: abort; 19: hang; otherwise the honest answer. */
static int crashing(const double r[6], const double s[], double* t) {
  if (s[3] == 13) *(volatile int*)0 = 1;
  if (s[3] == 17) abort();
  if (s[3] == 19)
    for (;;) pause();
  if (s[3] == 23) { /* closes the worker's response pipe (descriptor 101) and runs on */
    close(101);
    for (;;) pause();
  }
  return sphere_hit(r, s, t);
}

/* radius 3: returns 7; 5: a NaN t; 7: a hit without writing t. */
static int garbage(const double r[6], const double s[], double* t) {
  if (s[3] == 3) return 7;
  if (s[3] == 5) return *t = NAN, RAYPROOF_HIT;
  if (s[3] == 7) return RAYPROOF_HIT;
  return sphere_hit(r, s, t);
}

/* Crashes on every case whose origin has x > 0.5: a fuzz campaign meets it at once. */
static int crash_often(const double r[6], const double s[], double* t) {
  if (r[0] > 0.5) raise(SIGSEGV);
  return sphere_hit(r, s, t);
}

/* Writes to standard output and standard error on every call (a debugging printf left in), a
   line that looks like an answer included; answers honestly. */
static int chatty(const double r[6], const double s[], double* t) {
  printf("{\"id\": \"fake\", \"class\": \"miss\"}\n");
  fflush(stdout);
  fprintf(stderr, "chatty plugin: called\n");
  return sphere_hit(r, s, t);
}

/* Takes 0.15 s on every case: a batch of several takes longer than a short --case-timeout, each
   case does not. */
static int slow(const double r[6], const double s[], double* t) {
  usleep(150000);
  return sphere_hit(r, s, t);
}

/* The same quadratic in float. */
static int sphere_float(const float r[6], const float s[], float* t) {
  const float oc[3] = {r[0] - s[0], r[1] - s[1], r[2] - s[2]};
  const float a = r[3] * r[3] + r[4] * r[4] + r[5] * r[5];
  const float b = 2 * (oc[0] * r[3] + oc[1] * r[4] + oc[2] * r[5]);
  const float c = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - s[3] * s[3];
  const float disc = b * b - 4 * a * c;
  if (disc < 0) return RAYPROOF_MISS;
  const float t0 = (-b - sqrtf(disc)) / (2 * a), t1 = (-b + sqrtf(disc)) / (2 * a);
  if (t0 > 0) return *t = t0, RAYPROOF_HIT;
  if (t1 > 0) return *t = t1, RAYPROOF_HIT;
  return RAYPROOF_MISS;
}

static const struct rayproof_variant variants[] = {
    {"test-crashing", "sphere", "nearest",
     "tests: crashes on radius 13 and 17, hangs on 19, closes its pipe and hangs on 23", crashing, 0},
    {"test-garbage", "sphere", "nearest", "tests: plugin errors on radius 3, 5, 7", garbage, 0},
    {"test-float", "sphere", "nearest", "tests: the textbook quadratic in float", 0, sphere_float},
    {"test-crash-often", "sphere", "nearest", "tests: segfaults when origin.x > 0.5", crash_often, 0},
    {"test-chatty", "sphere", "nearest", "tests: prints to stdout and stderr on every call", chatty, 0},
    {"test-slow", "sphere", "nearest", "tests: 0.15 s per case", slow, 0},
};

const struct rayproof_variant* rayproof_plugin(int abi, int* count) {
  if (abi != RAYPROOF_PLUGIN_ABI) return 0;
  *count = sizeof variants / sizeof variants[0];
  return variants;
}
