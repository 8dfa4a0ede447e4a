// CHECK(cond, printf-args...) for the plants' native physics tests (plant/tests, plant3d/tests):
// a failed check prints where and why and counts in g_fail; the test's main returns g_fail != 0.
#pragma once
#include <cstdio>

static int g_fail = 0;
#define CHECK(cond, ...)                                           \
  do {                                                             \
    if (!(cond)) {                                                 \
      std::printf("  FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond); \
      std::printf(__VA_ARGS__);                                    \
      std::printf("\n");                                           \
      ++g_fail;                                                    \
    }                                                              \
  } while (0)
