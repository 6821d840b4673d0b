#pragma once

#include <cstdio>
#include <cstdlib>

// A property that must hold for every input: on violation print it and abort, so libFuzzer saves the input.
#define TELEOP_FUZZ_CHECK(condition)                                                          \
  do {                                                                                        \
    if (!(condition)) {                                                                       \
      std::fprintf(stderr, "%s:%d: property violated: %s\n", __FILE__, __LINE__, #condition); \
      std::abort();                                                                           \
    }                                                                                         \
  } while (false)
