#pragma once

#include <cstdlib>
#include <string>

namespace teleop::test {

/// Number of cases for seeded randomized tests: TELEOP_PROPERTY_COUNT when set to a positive integer, else
/// `default_count`. Raise it for a long soak: TELEOP_PROPERTY_COUNT=1000000 ctest -R proto.
inline int PropertyCount(int default_count) {
  const char* env = std::getenv("TELEOP_PROPERTY_COUNT");
  if (env == nullptr) return default_count;
  try {
    const int n = std::stoi(env);
    return n > 0 ? n : default_count;
  } catch (...) {
    return default_count;
  }
}

}  // namespace teleop::test
