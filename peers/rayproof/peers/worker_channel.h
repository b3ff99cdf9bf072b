// The one boundary between rayproof and a library it does not trust (plugins, tracer plugins):
// a worker process — this executable re-executed with ENV=serve:PATH, in its own process group —
// two pipes and one shared file. A request is one byte each way: rayproof fills the file, wakes
// the worker and waits; the worker answers through the file and wakes rayproof. While it works
// the worker writes the index of the item (case, ray) it is on into the file's header, so a
// worker that dies or stops making progress for `timeout` seconds is blamed for that item and
// every earlier answer is kept. A library that forks is caught by the worker (library_table.h),
// which marks the request instead of answering; nothing of that request is judged.
// Both sides of both kinds of worker live here, so the crash, hang and fork rules are one.
#pragma once

#include <sys/types.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <string>

#include "rayproof/core/answer.h"
#include "rayproof/peers/child_process.h"

namespace rayproof::peers {

// The first bytes of every worker's shared file: what the channel itself reads and writes.
struct ChannelHeader {
  std::atomic<std::uint64_t> progress;  // the item the worker is on, written before each call
  std::atomic<std::uint32_t> forked;    // set by the worker when the library forked
  std::uint64_t bytes;                  // the file's size: the worker maps it again when it grew
};

// The worker's fixed descriptors.
constexpr int kChannelRequestFd = 100, kChannelResponseFd = 101, kChannelSharedFd = 102;

// rayproof's end.
class WorkerChannel {
 public:
  // `env`: the variable the worker recognises itself by; `path`: the library it serves; `what`
  // ("plugin", "tracer"): how messages name it. The shared file starts `bytes` long.
  WorkerChannel(const char* env, const std::string& path, const char* process_name, std::string what,
                std::size_t bytes);
  ~WorkerChannel();  // the worker reads EOF and exits; bounded, its process group goes too
  WorkerChannel(const WorkerChannel&) = delete;
  WorkerChannel& operator=(const WorkerChannel&) = delete;

  // The shared file at least `bytes` long (pointers into it are invalid after it grows).
  void ensure(std::size_t bytes);
  char* shared() const { return map_; }
  ChannelHeader& header() const { return *reinterpret_cast<ChannelHeader*>(map_); }

  // How a request ended: answered (`reason` empty), or why the worker is gone — a crash, a hang
  // (`timed_out`) or a fork (`forked`) — and the item it was on (`at`: 0 after a fork, whose
  // answers are never judged).
  struct Outcome {
    std::string reason;
    bool timed_out = false, forked = false, out_of_memory = false;
    std::uint64_t at = 0;
    bool answered() const { return reason.empty(); }
    // The failure blamed on the item it was on (a fork is a protocol error: a copy answered).
    AnswerFailure failure() const {
      return forked          ? AnswerFailure::protocol
             : timed_out     ? AnswerFailure::timeout
             : out_of_memory ? AnswerFailure::out_of_memory
                             : AnswerFailure::crash;
    }
  };
  Outcome run(double timeout);

 private:
  Outcome finish();  // the worker's end, bounded (one that closed its pipe but runs on is killed)
  std::string what_;
  pid_t pid_ = -1;
  int request_ = -1, response_ = -1, fd_ = -1;
  bool reaped_ = false;
  char* map_ = nullptr;
  std::size_t bytes_ = 0;
};

// Before main (a static initializer: peers/external.h says why), becomes the worker `serve`
// when `env` is set in this process's environment; `serve` never returns. False otherwise.
inline bool become_worker_if_asked(const char* env, void (*serve)(const std::string& setting)) {
  if (const char* setting = std::getenv(env)) {
    hold_lifeline();  // a worker never outlives rayproof (child_process.h)
    serve(setting);
  }
  return false;
}

// The worker's end: serves each request (`serve(file)`: the shared file, mapped again only when
// rayproof grew it), marks one during which the library forked (so it is never judged), answers;
// ends the process when rayproof closes the channel.
[[noreturn]] void serve_requests(const std::function<void(char* file)>& serve);

}  // namespace rayproof::peers
