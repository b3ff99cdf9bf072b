// The one home for rayproof's child processes: exec commands (exec_process.h) and the plugin and
// tracer workers (plugin.cpp, tracer_plugin.cpp). Each child starts in its own process group, so
// ending it ends whatever it started (`sleep 60 & exit 0`, a plugin that forked); every wait is
// bounded, so a child that closed its pipes but runs on cannot hold rayproof in waitpid; and each
// holds a lifeline, so none outlives rayproof, even one killed by SIGKILL.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <dirent.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <iterator>
#include <sstream>
#include <string_view>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

extern char** environ;

namespace rayproof::peers {

// Children in their own groups no longer share the terminal's Ctrl-C: rayproof keeps their
// group ids here and, on SIGINT, SIGTERM or SIGHUP, kills every group before it dies of the
// signal itself (async-signal-safe: atomics and kill only).
namespace child_detail {
inline constexpr int kSlots = 1024;
inline std::atomic<pid_t> live_groups[kSlots];

inline void end_children_and_die(int sig) {
  for (auto& g : live_groups)
    if (const pid_t pid = g.load(std::memory_order_relaxed); pid > 0) ::kill(-pid, SIGKILL);
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}

inline void remember(pid_t pid) {
  static const bool installed = [] {
    for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
      struct sigaction old {};
      ::sigaction(sig, nullptr, &old);
      if (old.sa_handler == SIG_DFL) ::signal(sig, end_children_and_die);  // never replace someone's handler
    }
    return true;
  }();
  (void)installed;
  for (auto& g : live_groups) {
    pid_t empty = 0;
    if (g.compare_exchange_strong(empty, pid)) return;
  }
}

inline void forget(pid_t pid) {
  for (auto& g : live_groups) {
    pid_t expected = pid;
    if (g.compare_exchange_strong(expected, 0)) return;
  }
}
}  // namespace child_detail

// The lifeline (issue 42): each child is told rayproof's pid and, first thing, asks the kernel
// for SIGUSR2 when its parent dies — of anything, SIGKILL included — and then kills its whole
// process group: a worker spinning in a plugin, an exec command and what it started in its
// group never outlive rayproof. The pid check closes the race of a parent that died before
// the request was made.
inline constexpr const char* kParentPidEnv = "RAYPROOF_PARENT_PID";
inline constexpr const char* kMemoryLimitEnv = "RAYPROOF_MEMORY_LIMIT";

// --worker-memory (issue 42): the bytes of data (heap and private mappings: RLIMIT_DATA) each
// child may hold, 0 for no limit. Not applied under AddressSanitizer, whose shadow memory the
// limit would count.
inline std::atomic<std::uint64_t> child_memory_limit{0};
#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kMemoryLimitApplies = false;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kMemoryLimitApplies = false;
#else
inline constexpr bool kMemoryLimitApplies = true;
#endif
#else
inline constexpr bool kMemoryLimitApplies = true;
#endif

inline void hold_lifeline() {
  if (const char* limit = std::getenv(kMemoryLimitEnv)) {
    const rlim_t bytes = static_cast<rlim_t>(std::strtoull(limit, nullptr, 10));
    ::unsetenv(kMemoryLimitEnv);
    const rlimit data{bytes, bytes};
    if (kMemoryLimitApplies && bytes > 0) ::setrlimit(RLIMIT_DATA, &data);
  }
  const char* parent = std::getenv(kParentPidEnv);
  if (!parent) return;
  const pid_t expected = static_cast<pid_t>(std::atol(parent));
  ::unsetenv(kParentPidEnv);  // not passed on to what this child starts
  ::signal(SIGUSR2, [](int) { ::kill(0, SIGKILL); });
  ::prctl(PR_SET_PDEATHSIG, SIGUSR2);
  if (::getppid() != expected) ::kill(0, SIGKILL);
}

// The environment a child is started with: this process's, with `set` (NAME=value each)
// replacing any inherited variable of the same name, and the lifeline's parent pid.
inline std::vector<std::string> child_environment(std::initializer_list<std::string> set) {
  std::vector<std::string> env(set);
  env.push_back(std::string(kParentPidEnv) + "=" + std::to_string(::getpid()));
  if (const std::uint64_t limit = child_memory_limit.load())
    env.push_back(std::string(kMemoryLimitEnv) + "=" + std::to_string(limit));
  for (char** e = environ; *e; ++e) {
    const std::string_view entry(*e);
    const bool replaced = std::any_of(env.begin(), env.end(), [&](const std::string& mine) {
      return entry.substr(0, entry.find('=') + 1) == std::string_view(mine).substr(0, mine.find('=') + 1);
    });
    if (!replaced) env.emplace_back(entry);
  }
  return env;
}

// Orphans: a helper an exec command started in a session of its own (`setsid`) escapes the
// group kill, and when its parent exits it would be adopted by init. rayproof's command line
// makes itself their subreaper instead, and at exit ends every child it still has.
inline void end_adopted_children() {
  const std::string me = std::to_string(::getpid());
  if (DIR* proc = ::opendir("/proc")) {
    while (const dirent* d = ::readdir(proc)) {
      const pid_t pid = static_cast<pid_t>(std::atol(d->d_name));
      if (pid <= 0) continue;
      std::ifstream stat("/proc/" + std::string(d->d_name) + "/stat");
      std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
      const std::size_t close = text.rfind(')');  // "pid (name) state ppid ...": the name may hold spaces
      if (close == std::string::npos) continue;
      std::istringstream fields(text.substr(close + 1));
      std::string state, ppid;
      fields >> state >> ppid;
      if (ppid == me) {
        ::kill(pid, SIGKILL);
        ::waitpid(pid, nullptr, 0);
      }
    }
    ::closedir(proc);
  }
}
inline void adopt_orphans() {
  if (::prctl(PR_SET_CHILD_SUBREAPER, 1) == 0) std::atexit(end_adopted_children);
}

// Runs `spawn` on one thread that lives as long as the process: the kernel sends a child's
// parent-death signal when the *thread* that started it ends, and campaign threads end after
// every batch (child_process.cpp).
pid_t on_spawner_thread(const std::function<pid_t()>& spawn);

// Starts `path` with `argv` and `envp` in a new process group (its pid is the group's id), with
// each {from, to} of `dups` duplicated onto descriptor `to`. Throws naming `what`.
inline pid_t spawn_in_own_group(const char* path, char* const argv[], char* const envp[],
                                std::initializer_list<std::pair<int, int>> dups, const std::string& what) {
  ::signal(SIGPIPE, SIG_IGN);  // a child that exits early is reported, not fatal on the next write
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  for (const auto& [from, to] : dups) posix_spawn_file_actions_adddup2(&actions, from, to);
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attributes, 0);
  pid_t pid = -1;
  const int rc = static_cast<int>(on_spawner_thread([&] {
    const int r = ::posix_spawn(&pid, path, &actions, &attributes, argv, envp);
    return static_cast<pid_t>(r);
  }));
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attributes);
  if (rc != 0) throw std::runtime_error("cannot start " + what + ": " + std::string(std::strerror(rc)));
  child_detail::remember(pid);
  return pid;
}

// This executable again, as a worker: `env_name=value` in its environment (every other variable
// kept, an inherited env_name replaced) and argv {arg0}.
inline pid_t spawn_worker(const char* env_name, const std::string& value, const char* arg0,
                          std::initializer_list<std::pair<int, int>> dups, const std::string& what) {
  std::vector<std::string> env_text = child_environment({std::string(env_name) + "=" + value});
  std::vector<char*> envp;
  for (std::string& e : env_text) envp.push_back(e.data());
  envp.push_back(nullptr);
  std::string name = arg0;
  char* argv[] = {name.data(), nullptr};
  return spawn_in_own_group("/proc/self/exe", argv, envp.data(), dups, what);
}

// Whether the child ended within `seconds`. It is left unreaped: while it is a zombie its pid,
// and so its process group's id, cannot be reused by an unrelated process.
inline bool ended_within(pid_t pid, double seconds) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  for (int nap_us = 200;; nap_us = std::min(nap_us * 2, 20000)) {
    siginfo_t info{};
    if (::waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG | WNOWAIT) != 0 && errno != EINTR) return true;
    if (info.si_pid == pid) return true;
    if (std::chrono::steady_clock::now() >= deadline) return false;
    ::usleep(static_cast<useconds_t>(nap_us));
  }
}

// Ends the child: up to `grace` seconds to exit by itself, then SIGKILL. Either way its whole
// process group is killed (what it started and left running) before it is reaped. Returns the
// wait status; `killed` says whether it had to be killed.
inline int end_child(pid_t pid, double grace, bool* killed = nullptr, std::uint64_t* peak_bytes = nullptr) {
  const bool ended = ended_within(pid, grace);
  if (killed) *killed = !ended;
  ::kill(-pid, SIGKILL);
  int status = 0;
  rusage usage{};
  while (::wait4(pid, &status, 0, &usage) < 0 && errno == EINTR) {}
  if (peak_bytes) *peak_bytes = static_cast<std::uint64_t>(usage.ru_maxrss) * 1024;  // resident peak, KiB on Linux
  child_detail::forget(pid);
  return status;
}

// An exec command (`/bin/sh -c COMMAND`) in a new process group, each {from, to} of `dups`
// duplicated onto `to`. In rayproof's command line (after use_exec_launcher) it runs under the
// launcher (child_process.cpp), which holds the lifeline for it.
void use_exec_launcher();
pid_t spawn_exec_command(const std::string& command, std::initializer_list<std::pair<int, int>> dups,
                         const std::string& what);

// What a short-lived worker wrote to its standard output before it ended: how plugin and tracer
// tables are read, so that a library's load-time code (constructors, the table function) runs in
// a worker and never in rayproof (an exit(0), a printf, a crash or a fork there are the
// library's, reported). At most `max_bytes` are kept and `seconds` waited; then it is killed.
struct WorkerReport {
  std::string text;
  int status = 0;       // the wait status
  bool killed = false;  // it had to be killed (too slow or too much output)
};

inline WorkerReport run_reporting_worker(const char* env_name, const std::string& value, const char* arg0,
                                         double seconds, std::size_t max_bytes = 1 << 20) {
  int out[2];
  if (::pipe2(out, O_CLOEXEC) != 0) throw std::runtime_error("cannot create a pipe for " + std::string(arg0));
  pid_t pid;
  try {
    pid = spawn_worker(env_name, value, arg0, {{out[1], 1}}, arg0);
  } catch (...) {
    ::close(out[0]), ::close(out[1]);
    throw;
  }
  ::close(out[1]);
  WorkerReport report;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  for (;;) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
    pollfd p{out[0], POLLIN, 0};
    if (left <= 0 || ::poll(&p, 1, static_cast<int>(std::min<long long>(left, 100))) < 0) {
      if (errno == EINTR && left > 0) continue;
      break;
    }
    if (!(p.revents & (POLLIN | POLLHUP | POLLERR))) continue;
    char buffer[65536];
    const ssize_t n = ::read(out[0], buffer, sizeof buffer);
    if (n <= 0) break;
    report.text.append(buffer, static_cast<std::size_t>(std::min<std::size_t>(
                                   static_cast<std::size_t>(n), max_bytes - std::min(max_bytes, report.text.size()))));
    if (report.text.size() >= max_bytes) break;
  }
  ::close(out[0]);
  report.status = end_child(pid, 0.5, &report.killed);
  return report;
}

}  // namespace rayproof::peers
