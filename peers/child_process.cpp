// The launcher of exec commands (child_process.h): rayproof again, started in the command's
// process group with the command in its environment, which takes the lifeline, runs the command
// under /bin/sh -c and ends as it ended. A shell cannot take a lifeline for the command; this
// process can, and keeps it while the command runs.
#include <sys/prctl.h>

#include <atomic>
#include <condition_variable>
#include <cstdlib>
#include <deque>
#include <future>
#include <mutex>
#include <string>
#include <thread>

#include "rayproof/peers/child_process.h"

namespace rayproof::peers {
namespace {

constexpr const char* kExecCommandEnv = "RAYPROOF_EXEC_COMMAND";
std::atomic<bool> launcher_in_use{false};

[[noreturn]] void launch(const char* command_text) {
  const std::string command = command_text;
  ::unsetenv(kExecCommandEnv);
  hold_lifeline();  // from here, rayproof's death ends this group: the command and what it started
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::signal(SIGUSR2, SIG_DFL);
    ::execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  if (pid < 0) ::_exit(127);
  ::close(0), ::close(1);  // the command holds the pipes: rayproof sees their ends when it exits
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {}
  if (WIFSIGNALED(status)) {  // end as the command ended, so rayproof reports its signal
    ::prctl(PR_SET_DUMPABLE, 0);
    ::signal(WTERMSIG(status), SIG_DFL);
    ::raise(WTERMSIG(status));
  }
  ::_exit(WIFEXITED(status) ? WEXITSTATUS(status) : 1);
}

// Before main (a static initializer, as the workers': peers/external.h says why).
[[maybe_unused]] const bool kIsLauncher = [] {
  if (const char* command = std::getenv(kExecCommandEnv)) launch(command);
  return false;
}();

// The thread every child is started from (on_spawner_thread): never joined and never destroyed,
// so it ends only with the process — and with it, through the lifeline, the children.
struct SpawnerThread {
  std::mutex mutex;
  std::condition_variable ready;
  std::deque<std::packaged_task<pid_t()>> tasks;
  SpawnerThread() {
    std::thread([this] {
      for (;;) {
        std::unique_lock<std::mutex> lock(mutex);
        ready.wait(lock, [this] { return !tasks.empty(); });
        std::packaged_task<pid_t()> task = std::move(tasks.front());
        tasks.pop_front();
        lock.unlock();
        task();
      }
    }).detach();
  }
};

}  // namespace

pid_t on_spawner_thread(const std::function<pid_t()>& spawn) {
  static SpawnerThread* const spawner = new SpawnerThread;
  std::packaged_task<pid_t()> task(spawn);
  std::future<pid_t> done = task.get_future();
  {
    const std::lock_guard<std::mutex> lock(spawner->mutex);
    spawner->tasks.push_back(std::move(task));
  }
  spawner->ready.notify_one();
  return done.get();
}

void use_exec_launcher() { launcher_in_use = true; }

pid_t spawn_exec_command(const std::string& command, std::initializer_list<std::pair<int, int>> dups,
                         const std::string& what) {
  if (!launcher_in_use) {  // a process that is not rayproof's command line (a test, the Python module)
    char sh[] = "/bin/sh", dash_c[] = "-c";
    std::string text = command;
    char* argv[] = {sh, dash_c, text.data(), nullptr};
    return spawn_in_own_group("/bin/sh", argv, environ, dups, what);
  }
  std::vector<std::string> env_text = child_environment({std::string(kExecCommandEnv) + "=" + command});
  std::vector<char*> envp;
  for (std::string& e : env_text) envp.push_back(e.data());
  envp.push_back(nullptr);
  char name[] = "rayproof-exec";
  char* argv[] = {name, nullptr};
  return spawn_in_own_group("/proc/self/exe", argv, envp.data(), dups, what);
}

}  // namespace rayproof::peers
