#pragma once

// A fresh directory for one test's (or benchmark's) files, removed with its content at the end. Under $TEST_TMPDIR
// when set (as GoogleTest's TempDir()), else the system's temporary directory ($TMPDIR, else /tmp). Header-only and
// without GoogleTest, so that benchmarks and test servers use it too.

#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>

namespace teleop::test {

class ScopedTempDir {
 public:
  /// `<root>/teleop-<name>-<pid>-<n>`, created empty (a leftover of the same name is removed first).
  explicit ScopedTempDir(const std::string& name) {
    static std::atomic<int> counter{0};
    path_ = Root() / ("teleop-" + name + "-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
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
  static std::filesystem::path Root() {
    const char* test_tmpdir = std::getenv("TEST_TMPDIR");
    if (test_tmpdir != nullptr && *test_tmpdir != '\0') return test_tmpdir;
    return std::filesystem::temp_directory_path();
  }

  std::filesystem::path path_;
};

}  // namespace teleop::test
