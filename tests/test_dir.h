// A directory of the running test's own (emptied when the test first asks for it), so tests
// that run in parallel processes, or two test runs at once, never share a file name.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

namespace rayproof::testing_support {

inline std::string test_dir() {
  static std::string prepared;
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = std::string(info->test_suite_name()) + "-" + info->name();
  for (char& c : name)
    if (c == '/') c = '-';
  const std::string dir = ::testing::TempDir() + "/rayproof-" + std::to_string(::getpid()) + "-" + name;
  if (dir != prepared) {
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    prepared = dir;
  }
  return dir;
}

}  // namespace rayproof::testing_support
