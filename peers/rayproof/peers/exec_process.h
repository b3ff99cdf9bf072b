// One running command of the exec protocols (plugin.md's exec variants, tracer.md's exec
// tracers): started with /bin/sh -c, fed lines and read back through poll() on non-blocking
// pipes, so neither side can wedge the other on a full pipe; its standard error is rayproof's.
// Started and ended through child_process.h: its own process group, every wait bounded.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "rayproof/core/answer.h"
#include "rayproof/peers/child_process.h"

namespace rayproof::peers {

// One running command with its pipes.
class ExecProcess {
 public:
  // An answer line longer than this is a protocol error, not a buffer that grows without bound
  // (a command streaming bytes with no newline); exchange() may be given a larger one.
  static constexpr std::size_t kMaxLineBytes = 1 << 20;

  explicit ExecProcess(const std::string& command) {
    int in[2], out[2];
    if (::pipe2(in, O_CLOEXEC) != 0 || ::pipe2(out, O_CLOEXEC) != 0)
      throw std::runtime_error("--exec: cannot create pipes: " + std::string(std::strerror(errno)));
    try {
      pid_ = spawn_exec_command(command, {{in[0], 0}, {out[1], 1}}, "/bin/sh for --exec");
    } catch (...) {
      for (int fd : {in[0], in[1], out[0], out[1]}) ::close(fd);
      throw;
    }
    ::close(in[0]), ::close(out[1]);
    to_ = in[1], from_ = out[0];
    ::fcntl(to_, F_SETFL, O_NONBLOCK);
    ::fcntl(from_, F_SETFL, O_NONBLOCK);
  }
  ~ExecProcess() {
    if (to_ >= 0) ::close(to_);
    ::close(from_);
    // Given its end of input the command should exit; one that does not is ended, and so is
    // anything it left running.
    if (!reaped_) end_child(pid_, 0.5);
  }
  ExecProcess(const ExecProcess&) = delete;

  // Sends the lines and reads as many answer lines, interleaved. Returns "" when all came, else
  // why not, with `answered` lines in `lines` and `kind` the failure to blame on the next case.
  // The clock restarts only on progress (input taken, a whole answer line), never on stray bytes.
  std::string exchange(const std::string& payload, std::size_t expected, double case_timeout,
                       std::vector<std::string>& lines, AnswerFailure& kind,
                       std::size_t max_line_bytes = kMaxLineBytes) {
    std::size_t sent = 0;
    auto last_progress = std::chrono::steady_clock::now();
    while (lines.size() < expected) {
      pollfd p[2] = {{from_, POLLIN, 0}, {sent < payload.size() ? to_ : -1, POLLOUT, 0}};
      const int ready = ::poll(p, 2, 50);
      if (ready < 0 && errno != EINTR) return kind = AnswerFailure::crash, "poll failed";
      if (p[1].revents & (POLLOUT | POLLERR)) {
        const ssize_t n = ::write(to_, payload.data() + sent, payload.size() - sent);
        if (n > 0)
          sent += static_cast<std::size_t>(n), last_progress = std::chrono::steady_clock::now();
        else if (n < 0 && errno != EAGAIN)
          return kind = AnswerFailure::crash, ended("stopped reading its input", case_timeout);
      }
      if (p[0].revents & (POLLIN | POLLHUP | POLLERR)) {
        const std::size_t before = lines.size();
        const ssize_t n = read_lines(expected, lines, max_line_bytes);
        if (lines.size() > before) last_progress = std::chrono::steady_clock::now();
        if (n == 0 && lines.size() < expected)
          return kind = AnswerFailure::crash, ended("closed its standard output", case_timeout);
      }
      if (pending_.size() > max_line_bytes) {
        kind = AnswerFailure::protocol;
        end_child(pid_, 0), reaped_ = true;
        return "an answer line longer than " + std::to_string(max_line_bytes) + " bytes (no newline)";
      }
      // A command that ended while something it started holds its output open never sends EOF:
      // look for its end directly, and take what it wrote before.
      if (ready == 0 && lines.size() < expected && ended_within(pid_, 0)) {  // only when the pipes are quiet
        read_lines(expected, lines, max_line_bytes);
        if (lines.size() < expected) return kind = AnswerFailure::crash, ended("exited", case_timeout);
      }
      if (lines.size() < expected &&
          std::chrono::duration<double>(std::chrono::steady_clock::now() - last_progress).count() > case_timeout) {
        end_child(pid_, 0), reaped_ = true;
        kind = AnswerFailure::timeout;
        return "no answer within " + std::to_string(case_timeout) + " s (--case-timeout)";
      }
    }
    return "";
  }

 private:
  // Reads what is there (non-blocking) and cuts off the complete lines, scanning only bytes not
  // scanned before; stops early once an unfinished line is longer than max_line_bytes. Returns
  // the last read's result (0: end of file).
  ssize_t read_lines(std::size_t expected, std::vector<std::string>& lines, std::size_t max_line_bytes) {
    ssize_t n = -1;
    char buffer[65536];
    while ((n = ::read(from_, buffer, sizeof buffer)) > 0) {
      pending_.append(buffer, static_cast<std::size_t>(n));
      std::size_t from = 0, nl;  // from: where the current line starts
      while (lines.size() < expected && (nl = pending_.find('\n', scanned_)) != std::string::npos) {
        lines.push_back(pending_.substr(from, nl - from));
        from = scanned_ = nl + 1;
      }
      pending_.erase(0, from);
      // Short of lines, everything left was scanned and holds no newline; else rescan later.
      scanned_ = lines.size() < expected ? pending_.size() : 0;
      if (pending_.size() > max_line_bytes) break;
    }
    return n;
  }

  // The command's end, bounded: "exited early (status 1)" when it ended by itself, else
  // "<what> and kept running (killed)". Its process group goes with it either way.
  std::string ended(const std::string& what, double grace) {
    ::close(to_), to_ = -1;
    bool killed = false;
    const int status = end_child(pid_, std::min(grace, 1.0), &killed);
    reaped_ = true;
    if (killed) return what + " and kept running (killed)";
    const std::string how = WIFEXITED(status) ? "status " + std::to_string(WEXITSTATUS(status))
                                              : "signal " + std::to_string(WTERMSIG(status));
    return "exited early (" + how + ")";
  }
  pid_t pid_ = -1;
  int to_ = -1, from_ = -1;
  bool reaped_ = false;
  std::string pending_;
  std::size_t scanned_ = 0;  // pending_[0, scanned_) holds no newline
};

}  // namespace rayproof::peers
