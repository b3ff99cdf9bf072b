#include "rayproof/core/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace rayproof {

namespace {
std::runtime_error system_error(const std::string& path, const std::string& what) {
  return std::runtime_error(path + ": " + what + ": " + std::strerror(errno));
}
}  // namespace

AtomicFile::AtomicFile(std::string path) : path_(std::move(path)) {
  struct stat st {};
  const bool exists = ::lstat(path_.c_str(), &st) == 0;
  if (exists && !S_ISREG(st.st_mode)) {
    if (S_ISDIR(st.st_mode)) throw std::runtime_error(path_ + ": is a directory, not a file to write");
    fd_ = ::open(path_.c_str(), O_WRONLY | O_CLOEXEC | (S_ISLNK(st.st_mode) ? O_TRUNC : 0));
    if (fd_ < 0) throw system_error(path_, "cannot write");
  } else {
    const std::filesystem::path target(path_);
    const std::string dir = target.has_parent_path() ? target.parent_path().string() : ".";
    std::string pattern = dir + "/." + target.filename().string() + ".XXXXXX";
    fd_ = ::mkstemp(pattern.data());
    if (fd_ < 0) throw system_error(path_, "cannot create a file in " + dir);
    temp_ = pattern;
    if (exists)
      ::fchmod(fd_, st.st_mode & 07777);  // keep the replaced file's permissions
    else
      ::fchmod(fd_, 0644);
  }
  buffer_ = std::make_unique<__gnu_cxx::stdio_filebuf<char>>(fd_, std::ios::out | std::ios::binary, 1 << 16);
  stream_ = std::make_unique<std::ostream>(buffer_.get());
}

AtomicFile::~AtomicFile() {
  if (committed_) return;
  stream_.reset();
  buffer_.reset();  // closes fd_
  if (!temp_.empty()) ::unlink(temp_.c_str());
}

void AtomicFile::commit() {
  stream_->flush();
  const bool written = static_cast<bool>(*stream_);
  const int saved = errno;
  stream_.reset();
  const bool closed = buffer_->close() != nullptr;
  buffer_.reset();
  if (!written || !closed) {
    errno = written ? errno : saved;
    if (!temp_.empty()) ::unlink(temp_.c_str());
    committed_ = true;
    throw system_error(path_, "write failed");
  }
  if (!temp_.empty() && std::rename(temp_.c_str(), path_.c_str()) != 0) {
    const auto error = system_error(path_, "cannot replace");
    ::unlink(temp_.c_str());
    committed_ = true;
    throw error;
  }
  committed_ = true;
}

bool same_file(const std::string& a, const std::string& b) {
  struct stat sa {
  }, sb{};
  if (::stat(a.c_str(), &sa) != 0 || ::stat(b.c_str(), &sb) != 0) return false;
  return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

void refuse_output_over_input(const std::string& output, const std::vector<std::string>& inputs) {
  if (output.empty()) return;
  for (const std::string& in : inputs)
    if (in != "-" && same_file(output, in))
      throw std::runtime_error(output + ": is also an input (" + in + "); write the output elsewhere");
}

}  // namespace rayproof
