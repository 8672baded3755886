// Locating ../shared/data for tests; tests that need it skip with a clear message when it is absent.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "densemap/io/scan_source.h"

namespace densemap::test {

inline std::string dataDir() {
  if (const char* env = std::getenv("DENSEMAP_DATA_DIR")) return env;
  return DENSEMAP_DEFAULT_DATA_DIR;
}

inline bool haveData(const std::string& sub) { return std::filesystem::exists(dataDir() + "/" + sub); }

#define DENSEMAP_REQUIRE_DATA(sub)                                                                    \
  do {                                                                                                \
    if (!::densemap::test::haveData(sub))                                                             \
      GTEST_SKIP()                                                                                    \
          << "real data not found at " << ::densemap::test::dataDir() << "/" << (sub)                 \
          << " (clone next to ../shared or set DENSEMAP_DATA_DIR); simulator tests still cover this"; \
  } while (0)

}  // namespace densemap::test
