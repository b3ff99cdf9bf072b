// How many crashes (or hangs) one external variant may have before it is stopped: after each
// below the budget a fresh worker goes on with the next case, so one bad case does not end a
// campaign's view of that code (--max-crashes, default 10). Shared by plugins and exec commands.
#pragma once

#include <atomic>
#include <mutex>
#include <string>

namespace rayproof::peers {

class CrashBudget {
 public:
  explicit CrashBudget(int max_crashes) : max_(max_crashes < 1 ? 1 : max_crashes) {}

  // Records one crash or hang and why; true when the variant must now stop (the budget is spent
  // or it had already stopped).
  bool spend(const std::string& why) {
    std::lock_guard lock(mutex_);
    last_ = why;
    const int n = ++crashes_;
    if (n < max_ || !stop_reason_.empty()) return !stop_reason_.empty();
    stop_reason_ =
        why + (max_ > 1 ? " (crash " + std::to_string(n) + ", --max-crashes " + std::to_string(max_) + ")" : "");
    stopped_ = true;
    return true;
  }
  // Stops now whatever the count (a protocol error, a forking plugin: a fresh worker would do the same).
  void stop(const std::string& why) {
    std::lock_guard lock(mutex_);
    last_ = why;
    if (stop_reason_.empty()) stop_reason_ = why;
    stopped_ = true;
  }
  bool stopped() const { return stopped_.load(); }
  std::string stop_reason() const {
    std::lock_guard lock(mutex_);
    return stop_reason_;
  }
  std::string last_failure() const {
    std::lock_guard lock(mutex_);
    return last_;
  }

 private:
  const int max_;
  int crashes_ = 0;
  std::atomic<bool> stopped_{false};
  mutable std::mutex mutex_;
  std::string stop_reason_, last_;
};

}  // namespace rayproof::peers
