#pragma once

// A fresh directory for one test's files, under GoogleTest's TempDir(), removed with its content at the end.

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <string>
#include <system_error>

namespace teleop::test {

class ScopedTempDir {
 public:
  /// `<TempDir>/teleop-<name>-<pid>-<n>`, created empty (a leftover of the same name is removed first).
  explicit ScopedTempDir(const std::string& name) {
    static std::atomic<int> counter{0};
    path_ = std::filesystem::path(::testing::TempDir()) /
            ("teleop-" + name + "-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
    std::filesystem::create_directories(path_);
  }
  ~ScopedTempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  ScopedTempDir(const ScopedTempDir&) = delete;
  ScopedTempDir& operator=(const ScopedTempDir&) = delete;

  const std::filesystem::path& path() const noexcept { return path_; }
  /// `path()/file` as a string.
  std::string File(const std::string& file) const { return (path_ / file).string(); }

 private:
  std::filesystem::path path_;
};

}  // namespace teleop::test
