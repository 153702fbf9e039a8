// Tests that read the real flights in ../shared/data skip on a machine without them,
// but CI has them: there (QUADID_REQUIRE_SHARED=1, set by .ci/run) a missing file is a
// failure, so a moved or renamed data set cannot turn the real-flight tests into
// silent skips (issue 36: tests that cannot fail).
#pragma once
#include <cstdlib>
#include <cstring>
#include <filesystem>

#include <gtest/gtest.h>

namespace quadid_test {
inline bool shared_data_required() {
  const char* v = std::getenv("QUADID_REQUIRE_SHARED");
  return v != nullptr && std::strcmp(v, "1") == 0;
}
}  // namespace quadid_test

// Use in a TEST body: QUADID_REQUIRE_SHARED_FILE(path);
#define QUADID_REQUIRE_SHARED_FILE(path)                                                        \
  do {                                                                                          \
    if (!std::filesystem::exists(path)) {                                                       \
      if (quadid_test::shared_data_required())                                                  \
        FAIL() << (path) << " absent, and QUADID_REQUIRE_SHARED=1 says the shared data is here"; \
      GTEST_SKIP() << (path) << " absent";                                                      \
    }                                                                                           \
  } while (0)
