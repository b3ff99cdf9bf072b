// Processes that answer for one piece of external code (plugin workers, --exec commands): one
// per thread at a time, started on first need, handed back after a batch that went well. A
// process that failed is not handed back; its destructor ends it.
#pragma once

#include <signal.h>
#include <string.h>
#include <sys/wait.h>

#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "rayproof/peers/child_process.h"

namespace rayproof::peers {

// How a child process ended, for a one-line report: "killed by SIGSEGV", "exited with status 3".
inline std::string signal_reason(int status) {
  if (WIFSIGNALED(status)) {
    const char* name = sigabbrev_np(WTERMSIG(status));
    return std::string("killed by SIG") + (name ? name : std::to_string(WTERMSIG(status)));
  }
  if (WIFEXITED(status)) return "exited with status " + std::to_string(WEXITSTATUS(status));
  return "ended";
}

// Ends a plugin or tracer worker whose pipe failed (bounded: one that closed its pipe but runs
// on is killed with its group) and says why it stopped.
// A worker that died holding at least half of its --worker-memory limit ran out of memory: the
// limit made its allocation fail (careless code then crashes on the NULL; C++ code aborts on
// std::bad_alloc), and `out_of_memory` is set with the peak in the reason.
inline std::string end_worker(pid_t pid, bool* out_of_memory = nullptr) {
  bool killed = false;
  std::uint64_t peak = 0;
  const int status = end_child(pid, 1.0, &killed, &peak);
  if (killed) return "closed its response pipe and kept running (killed)";
  const std::uint64_t limit = child_memory_limit.load();
  const bool died = WIFSIGNALED(status) || (WIFEXITED(status) && WEXITSTATUS(status) != 0);
  if (died && kMemoryLimitApplies && limit > 0 && peak >= limit / 2) {
    if (out_of_memory) *out_of_memory = true;
    return "out of memory: " + signal_reason(status) + " at " + std::to_string(peak >> 20) + " MiB resident, its " +
           std::to_string(limit >> 20) + " MiB limit (--worker-memory)";
  }
  return signal_reason(status);
}

// Why a piece of external code stopped (a crash, a hang, a protocol error): the first stop's
// reason, read from any thread. `note` records a reason without stopping, where none is yet.
struct StopReason {
  std::atomic<bool> stopped{false};
  void stop(const std::string& why) {
    if (stopped.exchange(true)) return;
    std::lock_guard lock(mutex_);
    reason_ = why;
  }
  void note(const std::string& why) {
    std::lock_guard lock(mutex_);
    if (reason_.empty()) reason_ = why;
  }
  std::string reason() const {
    std::lock_guard lock(mutex_);
    return reason_;
  }

 private:
  mutable std::mutex mutex_;
  std::string reason_;
};

template <class Process>
class ProcessPool {
 public:
  // An idle process, or a new one made by start().
  template <class Start>
  std::unique_ptr<Process> take(Start start) {
    {
      std::lock_guard lock(mutex_);
      if (!idle_.empty()) {
        std::unique_ptr<Process> p = std::move(idle_.back());
        idle_.pop_back();
        return p;
      }
    }
    return start();
  }
  void give_back(std::unique_ptr<Process> p) {
    std::lock_guard lock(mutex_);
    idle_.push_back(std::move(p));
  }

 private:
  std::mutex mutex_;
  std::vector<std::unique_ptr<Process>> idle_;
};

}  // namespace rayproof::peers
