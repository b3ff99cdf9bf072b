// The one thread-pool helper: `threads` workers, worker 0 on the calling thread.
#pragma once

#include <algorithm>
#include <thread>
#include <vector>

namespace rayproof {

// Every hardware thread (at least one): the default of every command's --threads.
inline int default_threads() { return static_cast<int>(std::max(1u, std::thread::hardware_concurrency())); }

// Runs work(w) for w = 0 … threads − 1 in parallel and returns when all have finished. Work is
// split by the callee (a stride over w, or a shared counter), so results never depend on timing.
template <class Work>
void run_workers(int threads, Work&& work) {
  threads = std::max(1, threads);
  std::vector<std::thread> pool;
  pool.reserve(threads - 1);
  for (int w = 1; w < threads; ++w) pool.emplace_back([&work, w] { work(w); });
  work(0);
  for (std::thread& t : pool) t.join();
}

}  // namespace rayproof
