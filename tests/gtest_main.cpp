// The project's GoogleTest main: a binary whose tests skipped (a real part such as ../shared/data
// or a network namespace is absent) exits 77, which CTest reports as "Skipped" (SKIP_RETURN_CODE),
// never as passed.
#include <cstdio>

#include <gtest/gtest.h>

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  const int result = RUN_ALL_TESTS();
  if (result != 0) return result;
  const testing::UnitTest& unit = *testing::UnitTest::GetInstance();
  if (unit.skipped_test_count() > 0) {
    std::fprintf(stderr, "SKIPPED: %d test(s) of this binary did not run; see the reasons above.\n",
                 unit.skipped_test_count());
    return 77;
  }
  return 0;
}
