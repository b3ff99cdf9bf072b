// How rayproof times code, in one place: a steady-clock stopwatch, a sink that keeps answers
// alive so that timed work cannot be optimised away, and the fastest of a few passes (a busy
// moment on the machine must not decide a cost). `trade`, `audit`, the campaigns and `render`
// time with these; the benchmarks use Google Benchmark's own harness (bench/).
#pragma once

#include <algorithm>
#include <chrono>
#include <limits>

namespace rayproof {

class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  double seconds() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }

 private:
  std::chrono::steady_clock::time_point start_;
};

// Makes `value` observable: the compiler must compute it (what benchmark::DoNotOptimize does).
template <class T>
inline void keep_alive(const T& value) {
  asm volatile("" : : "r,m"(value) : "memory");
}

// The fewest seconds of `passes` runs of `pass` (each returns its own seconds, e.g. one timed
// where external code runs, or a negative number when it cannot be timed: then that is returned).
template <class Pass>
double fastest_of(int passes, Pass&& pass) {
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i < passes; ++i) {
    const double s = pass();
    if (s < 0) return s;
    best = std::min(best, s);
  }
  return best;
}

}  // namespace rayproof
