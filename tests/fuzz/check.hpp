// FUZZ_CHECK: a property every fuzz target asserts of what a reader accepted. It aborts (so
// libFuzzer keeps the input as a crasher, and the replay test fails) in every build type, unlike
// assert, which Release builds drop.
#pragma once

#include <cstdio>
#include <cstdlib>

#define FUZZ_CHECK(condition)                                                                  \
  do {                                                                                         \
    if (!(condition)) {                                                                        \
      std::fprintf(stderr, "%s:%d: property violated: %s\n", __FILE__, __LINE__, #condition); \
      std::abort();                                                                            \
    }                                                                                          \
  } while (false)
