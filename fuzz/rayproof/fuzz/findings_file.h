// What every campaign's findings file needs, in one place: a lock so two campaigns never write
// one file, and a hash of the bytes written so a resume can tell the file is the one its
// checkpoint describes.
#pragma once

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace rayproof::fuzz {

// FNV-1a over the findings bytes written.
struct FindingsHash {
  std::uint64_t value = 0xcbf29ce484222325ull;
  void add(std::string_view bytes) {
    for (unsigned char c : bytes) value = (value ^ c) * 0x100000001b3ull;
  }
};

// The findings file, locked for the campaign (flock: a second campaign on the same output is
// refused instead of interleaving with this one).
class FindingsLock {
 public:
  explicit FindingsLock(const std::string& path) {
    fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) throw std::runtime_error(path + ": cannot write: " + std::strerror(errno));
    if (::flock(fd_, LOCK_EX | LOCK_NB) != 0)
      throw std::runtime_error(path + ": another rayproof campaign is writing it; wait for it or choose another -o");
  }
  ~FindingsLock() { ::close(fd_); }
  FindingsLock(const FindingsLock&) = delete;

 private:
  int fd_ = -1;
};

// Whether the first `bytes` bytes of the file hash to `expected`.
inline bool prefix_matches(const std::string& path, std::uintmax_t bytes, const FindingsHash& expected) {
  std::ifstream in(path, std::ios::binary);
  FindingsHash h;
  std::vector<char> buffer(1 << 16);
  while (bytes > 0 && in) {
    in.read(buffer.data(), static_cast<std::streamsize>(std::min<std::uintmax_t>(bytes, buffer.size())));
    h.add(std::string_view(buffer.data(), static_cast<size_t>(in.gcount())));
    bytes -= static_cast<std::uintmax_t>(in.gcount());
  }
  return bytes == 0 && h.value == expected.value;
}

}  // namespace rayproof::fuzz
