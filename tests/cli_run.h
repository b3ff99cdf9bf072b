// Running the rayproof command line from a test: its exit status, standard output and standard
// error (kept in the test's own directory, so tests running in parallel never share it).
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "test_dir.h"

namespace rayproof::testing_support {

struct CliRun {
  int status;
  std::string out, err;
};

inline CliRun run_cli(const std::string& args) {
  const std::string err_path = test_dir() + "/stderr.txt";
  const std::string cmd = std::string(RAYPROOF_CLI) + " " + args + " 2>" + err_path;
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  const int status = pclose(p);
  std::stringstream err;
  err << std::ifstream(err_path).rdbuf();
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out, err.str()};
}

}  // namespace rayproof::testing_support
