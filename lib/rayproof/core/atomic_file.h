// Every output rayproof writes goes through here: a file that appears whole or not at all.
//
// A regular file (or a new one) is written to a temporary created with a unique name in the
// same directory (mkstemp: O_EXCL, so a planted symlink is never followed) and renamed over the
// target on commit(); an abandoned one is removed. A target that is not a regular file — a
// character device, a FIFO, a symlink such as /dev/stdout — is written in place, never replaced
// (`-o /dev/null` and `-o /dev/stdout` just work; a device node is never swapped for a file).
// Construct it before the work starts: a path that cannot be written fails then, not after.
#pragma once

#include <ext/stdio_filebuf.h>

#include <memory>
#include <ostream>
#include <string>
#include <vector>

namespace rayproof {

class AtomicFile {
 public:
  // Throws std::runtime_error naming the path and the system's reason.
  explicit AtomicFile(std::string path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  std::ostream& stream() { return *stream_; }
  const std::string& path() const { return path_; }
  bool in_place() const { return temp_.empty(); }
  // Flushes, checks every write, closes and renames into place; throws on any failure.
  void commit();

 private:
  std::string path_, temp_;  // temp_ empty: written in place
  int fd_ = -1;
  std::unique_ptr<__gnu_cxx::stdio_filebuf<char>> buffer_;
  std::unique_ptr<std::ostream> stream_;
  bool committed_ = false;
};

// Whether two paths name the same existing file (same device and inode).
bool same_file(const std::string& a, const std::string& b);

// Throws std::runtime_error when `output` is one of `inputs` ("-o x.jsonl" reading x.jsonl).
void refuse_output_over_input(const std::string& output, const std::vector<std::string>& inputs);

}  // namespace rayproof
