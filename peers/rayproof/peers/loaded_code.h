// The one owner of what the user's code loaded into this process: plugins and their workers,
// exec commands, answers files, tracer libraries and states, and the strings (names, sources,
// origins) the variant and tracer registries point into. Registered variants and tracers hold
// plain pointers into it, so it lives until exit; what it owns keeps its address (each object is
// allocated once, the strings sit in a deque) and is destroyed in the reverse order of loading.
#pragma once

#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace rayproof::peers {

class LoadedCode {
 public:
  LoadedCode() = default;
  LoadedCode(const LoadedCode&) = delete;
  LoadedCode& operator=(const LoadedCode&) = delete;
  ~LoadedCode() {
    while (!objects_.empty()) objects_.pop_back();  // the last loaded first
  }

  // A new T owned until exit.
  template <class T, class... Args>
  T& make(Args&&... args) {
    auto owned = std::make_unique<T>(std::forward<Args>(args)...);
    T& object = *owned;
    const std::lock_guard lock(mutex_);
    objects_.push_back({owned.release(), [](void* p) { delete static_cast<T*>(p); }});
    return object;
  }
  // A string the registries may point into until exit.
  const std::string& keep(std::string text) {
    const std::lock_guard lock(mutex_);
    return strings_.emplace_back(std::move(text));
  }

 private:
  std::mutex mutex_;
  std::deque<std::string> strings_;
  std::vector<std::unique_ptr<void, void (*)(void*)>> objects_;
};

LoadedCode& loaded_code();

}  // namespace rayproof::peers
