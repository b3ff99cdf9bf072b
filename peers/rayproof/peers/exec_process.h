// One running command of the exec protocols (plugin.md's exec variants, tracer.md's exec
// tracers): started with /bin/sh -c, fed lines and read back through poll() on non-blocking
// pipes, so neither side can wedge the other on a full pipe; its standard error is rayproof's.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "rayproof/core/hit.h"

extern char** environ;

namespace rayproof::peers {

// One running command with its pipes.
class ExecProcess {
 public:
  explicit ExecProcess(const std::string& command) {
    int in[2], out[2];
    if (::pipe2(in, O_CLOEXEC) != 0 || ::pipe2(out, O_CLOEXEC) != 0)
      throw std::runtime_error("--exec: cannot create pipes: " + std::string(std::strerror(errno)));
    ::signal(SIGPIPE, SIG_IGN);  // a command that exits early is reported, not fatal
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, in[0], 0);
    posix_spawn_file_actions_adddup2(&actions, out[1], 1);
    char sh[] = "/bin/sh", dash_c[] = "-c";
    std::string text = command;
    char* argv[] = {sh, dash_c, text.data(), nullptr};
    const int rc = ::posix_spawn(&pid_, "/bin/sh", &actions, nullptr, argv, environ);
    posix_spawn_file_actions_destroy(&actions);
    ::close(in[0]), ::close(out[1]);
    to_ = in[1], from_ = out[0];
    if (rc != 0) throw std::runtime_error("--exec: cannot start /bin/sh: " + std::string(std::strerror(rc)));
    ::fcntl(to_, F_SETFL, O_NONBLOCK);
    ::fcntl(from_, F_SETFL, O_NONBLOCK);
  }
  ~ExecProcess() {
    if (to_ >= 0) ::close(to_);
    ::close(from_);
    if (!reaped_) {
      // Given its end of input the command should exit; one that does not is ended.
      for (int i = 0; i < 50 && ::waitpid(pid_, nullptr, WNOHANG) == 0; ++i) ::usleep(10000);
      if (::waitpid(pid_, nullptr, WNOHANG) == 0) ::kill(pid_, SIGKILL), ::waitpid(pid_, nullptr, 0);
    }
  }
  ExecProcess(const ExecProcess&) = delete;

  // Sends the lines and reads as many answer lines, interleaved. Returns "" when all came, else
  // why not, with `answered` lines in `lines` and `kind` the failure to blame on the next case.
  std::string exchange(const std::string& payload, std::size_t expected, double case_timeout,
                       std::vector<std::string>& lines, HitFailure& kind) {
    std::size_t sent = 0;
    auto last_progress = std::chrono::steady_clock::now();
    while (lines.size() < expected) {
      pollfd p[2] = {{from_, POLLIN, 0}, {sent < payload.size() ? to_ : -1, POLLOUT, 0}};
      const int ready = ::poll(p, 2, 50);
      if (ready < 0 && errno != EINTR) return kind = HitFailure::crash, "poll failed";
      if (p[1].revents & (POLLOUT | POLLERR)) {
        const ssize_t n = ::write(to_, payload.data() + sent, payload.size() - sent);
        if (n > 0) sent += static_cast<std::size_t>(n);
        else if (n < 0 && errno != EAGAIN) return kind = HitFailure::crash, ended("stopped reading its input");
      }
      if (p[0].revents & (POLLIN | POLLHUP | POLLERR)) {
        char buffer[65536];
        const ssize_t n = ::read(from_, buffer, sizeof buffer);
        if (n == 0) return kind = HitFailure::crash, ended("exited early");
        if (n > 0) {
          last_progress = std::chrono::steady_clock::now();
          pending_.append(buffer, static_cast<std::size_t>(n));
          std::size_t from = 0;  // cut the complete lines off once, not one by one
          for (std::size_t nl; lines.size() < expected && (nl = pending_.find('\n', from)) != std::string::npos; from = nl + 1)
            lines.push_back(pending_.substr(from, nl - from));
          pending_.erase(0, from);
        }
      }
      if (std::chrono::duration<double>(std::chrono::steady_clock::now() - last_progress).count() > case_timeout) {
        ::kill(pid_, SIGKILL);
        ::waitpid(pid_, nullptr, 0);
        reaped_ = true;
        kind = HitFailure::timeout;
        return "no answer within " + std::to_string(case_timeout) + " s (--case-timeout)";
      }
    }
    return "";
  }

 private:
  std::string ended(const std::string& what) {
    int status = 0;
    ::close(to_), to_ = -1;
    ::waitpid(pid_, &status, 0);
    reaped_ = true;
    std::string how = WIFEXITED(status) ? "status " + std::to_string(WEXITSTATUS(status))
                                        : "signal " + std::to_string(WTERMSIG(status));
    return what + " (" + how + ")";
  }
  pid_t pid_ = -1;
  int to_ = -1, from_ = -1;
  bool reaped_ = false;
  std::string pending_;
};

}  // namespace rayproof::peers
