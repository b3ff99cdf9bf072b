// Processes that answer for one piece of external code (plugin workers, --exec commands): one
// per thread at a time, started on first need, handed back after a batch that went well. A
// process that failed is not handed back; its destructor ends it.
#pragma once

#include <memory>
#include <mutex>
#include <vector>

namespace rayproof::peers {

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
