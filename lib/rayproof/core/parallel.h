// The one thread-pool helper: `threads` workers, worker 0 on the calling thread.
#pragma once

#include <algorithm>
#include <exception>
#include <string>
#include <thread>
#include <vector>

namespace rayproof {

// Every hardware thread (at least one): the default of every command's --threads.
inline int default_threads() { return static_cast<int>(std::max(1u, std::thread::hardware_concurrency())); }
// "1 thread", "2 threads": how every report says it.
inline std::string threads_text(int threads) {
  return std::to_string(threads) + (threads == 1 ? " thread" : " threads");
}

// Runs work(w) for w = 0 … threads − 1 in parallel and returns when all have finished. Work is
// split by the callee (a stride over w, or a shared counter), so results never depend on timing.
// An exception thrown by any worker is rethrown here after every worker has finished (the first
// one thrown; a worker that throws stops only itself), never ending the process from a thread.
template <class Work>
void run_workers(int threads, Work&& work) {
  threads = std::max(1, threads);
  std::vector<std::exception_ptr> failed(threads);
  auto guarded = [&](int w) {
    try {
      work(w);
    } catch (...) {
      failed[w] = std::current_exception();
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(threads - 1);
  for (int w = 1; w < threads; ++w) pool.emplace_back([&guarded, w] { guarded(w); });
  guarded(0);
  for (std::thread& t : pool) t.join();
  for (const std::exception_ptr& e : failed)
    if (e) std::rethrow_exception(e);
}

}  // namespace rayproof
