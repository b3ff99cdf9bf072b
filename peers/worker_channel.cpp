// The worker channel (worker_channel.h): spawn, requests, the watchdog, crash and fork blame.
#include "rayproof/peers/worker_channel.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>

#include "rayproof/peers/child_process.h"
#include "rayproof/peers/library_table.h"
#include "rayproof/peers/process_pool.h"

namespace rayproof::peers {

WorkerChannel::WorkerChannel(const char* env, const std::string& path, const char* process_name, std::string what,
                             std::size_t bytes)
    : what_(std::move(what)) {
  int request[2], response[2];
  if (::pipe2(request, O_CLOEXEC) != 0 || ::pipe2(response, O_CLOEXEC) != 0)
    throw std::runtime_error("cannot create pipes for a " + what_ + " worker: " + std::string(std::strerror(errno)));
  fd_ = ::memfd_create("rayproof-worker", MFD_CLOEXEC);
  if (fd_ < 0) {
    for (int fd : {request[0], request[1], response[0], response[1]}) ::close(fd);
    throw std::runtime_error("cannot create shared memory for a " + what_ + " worker");
  }
  try {
    ensure(std::max(bytes, sizeof(ChannelHeader)));
    pid_ = spawn_worker(env, "serve:" + path, process_name,
                        {{request[0], kChannelRequestFd}, {response[1], kChannelResponseFd}, {fd_, kChannelSharedFd}},
                        ("a " + what_ + " worker").c_str());
  } catch (...) {
    for (int fd : {request[0], request[1], response[0], response[1]}) ::close(fd);
    if (map_) ::munmap(map_, bytes_);
    ::close(fd_);
    throw;
  }
  ::close(request[0]), ::close(response[1]);
  request_ = request[1], response_ = response[0];
}

WorkerChannel::~WorkerChannel() {
  ::close(request_), ::close(response_);           // the worker reads EOF and exits
  if (pid_ > 0 && !reaped_) end_child(pid_, 1.0);  // bounded; whatever the library left running goes too
  if (map_) ::munmap(map_, bytes_);
  ::close(fd_);
}

void WorkerChannel::ensure(std::size_t bytes) {
  if (bytes <= bytes_) return;
  bytes = std::max(bytes, bytes_ * 2);
  if (map_) ::munmap(map_, bytes_), map_ = nullptr;
  if (::ftruncate(fd_, static_cast<off_t>(bytes)) != 0)
    throw std::runtime_error("cannot grow a " + what_ + " worker's shared memory");
  void* map = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, 0);
  if (map == MAP_FAILED) throw std::runtime_error("cannot map a " + what_ + " worker's shared memory");
  map_ = static_cast<char*>(map), bytes_ = bytes;
  header().bytes = bytes_;
}

// The watchdog: the worker's progress is read every slice (a quarter of the timeout, between
// 1 and 100 ms); a hang is `timeout` seconds without the item index moving, so a long batch of
// quick items is never cut short, and one slow item is.
WorkerChannel::Outcome WorkerChannel::run(double timeout) {
  header().progress.store(0, std::memory_order_relaxed);
  const char byte = 1;
  if (::write(request_, &byte, 1) != 1) return finish();
  std::uint64_t last = 0;
  auto last_change = std::chrono::steady_clock::now();
  const int slice_ms = static_cast<int>(std::clamp(timeout * 250, 1.0, 100.0));
  for (;;) {
    pollfd p{response_, POLLIN, 0};
    if (::poll(&p, 1, slice_ms) > 0) {
      char got;
      if (::read(response_, &got, 1) != 1) return finish();
      if (header().forked.load() == 0) return {};
      ::kill(-pid_, SIGKILL);
      Outcome out = finish();
      out.at = 0, out.forked = true;  // no answer of this request is judged: another process wrote beside the worker
      out.reason = "the " + what_ + " forked: a copy of the worker returned from a " +
                   (what_ == "plugin" ? "plugin call (plugins" : "library call (libraries") + " must not fork)";
      return out;
    }
    const std::uint64_t now_at = header().progress.load(std::memory_order_relaxed);
    const auto now = std::chrono::steady_clock::now();
    if (now_at != last) {
      last = now_at, last_change = now;
    } else if (std::chrono::duration<double>(now - last_change).count() > timeout) {
      ::kill(-pid_, SIGKILL);
      Outcome out = finish();
      out.timed_out = true;
      out.reason = "no answer within " + std::to_string(timeout) + " s (--case-timeout)";
      return out;
    }
  }
}

WorkerChannel::Outcome WorkerChannel::finish() {
  reaped_ = true;
  Outcome out;
  out.at = header().progress.load(std::memory_order_relaxed);
  out.reason = end_worker(pid_, &out.out_of_memory);
  return out;
}

void serve_requests(const std::function<void(char* file)>& serve) {
  char* map = nullptr;
  std::uint64_t mapped = 0;
  char byte;
  while (::read(kChannelRequestFd, &byte, 1) == 1) {
    std::uint64_t bytes = 0;
    if (::pread(kChannelSharedFd, &bytes, sizeof bytes, offsetof(ChannelHeader, bytes)) != sizeof bytes) ::_exit(4);
    if (bytes != mapped) {
      if (map) ::munmap(map, mapped), map = nullptr;
      void* m = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, kChannelSharedFd, 0);
      if (m == MAP_FAILED) ::_exit(4);
      map = static_cast<char*>(m), mapped = bytes;
    }
    serve(map);
    if (library_forked()) reinterpret_cast<ChannelHeader*>(map)->forked.store(1);  // before the answer: never judged
    if (::write(kChannelResponseFd, &byte, 1) != 1) break;
  }
  ::_exit(0);
}

}  // namespace rayproof::peers
