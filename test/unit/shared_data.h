// Locating ../shared/data (real third-party inputs) from tests: skip when it is missing, or fail
// when TOPO_REQUIRE_SHARED_DATA=1 (CI), so a missing data set can never pass silently there.
#pragma once

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdlib>
#include <string>

namespace topo_test {

inline std::string sharedDataDir() { return std::string(TOPO_SOURCE_DIR) + "/../shared/data"; }

inline bool fileExists(const std::string& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0;
}

inline bool sharedDataRequired() {
  const char* v = std::getenv("TOPO_REQUIRE_SHARED_DATA");
  return v && std::string(v) == "1";
}

}  // namespace topo_test

/// In a TEST body: sets `var` to the full path of shared/data/<rel>, or skips/fails the test.
#define TOPO_SHARED_FILE(var, rel)                                                     \
  const std::string var = topo_test::sharedDataDir() + "/" + (rel);                    \
  if (!topo_test::fileExists(var)) {                                                   \
    if (topo_test::sharedDataRequired()) FAIL() << "missing shared data file " << var; \
    GTEST_SKIP() << "no shared data at " << var;                                       \
  }
