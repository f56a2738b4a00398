// The exact predicates evaluated on the device must give the independent oracle's answers, and
// therefore the host's: the CUDA executor relies on both sides of the machine agreeing.
#include <gtest/gtest.h>

#include <cstddef>
#include <sstream>
#include <string>
#include <vector>

#include "cdt/detail/predicates.hpp"
#include "cdt_kernels.hpp"
#include "predicate_cases.hpp"

namespace {

std::string describe(const double* c, int n) {
  std::ostringstream out;
  out.precision(17);
  for (int k = 0; k < n; ++k) out << (k == 0 ? "" : " ") << c[k];
  return out.str();
}

class GpuPredicates : public ::testing::Test {
protected:
  void SetUp() override {
    if (cdt::gpu::device_count() == 0) GTEST_SKIP() << "no CUDA device available";
  }
};

TEST_F(GpuPredicates, OrientOnDeviceMatchesOracleAndHost) {
  const auto cases = trixel_test::make_predicate_cases(4);
  std::vector<int> signs(cases.orient_expected.size(), 7); // poisoned: every entry must be written
  cdt::gpu::orient2d_signs(cases.orient_coords.data(), signs.data(), signs.size());
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < signs.size(); ++i) {
    const double* c = &cases.orient_coords[6 * i];
    const int host = cdt::detail::orient2d(c[0], c[1], c[2], c[3], c[4], c[5]);
    if (signs[i] != cases.orient_expected[i] || signs[i] != host) {
      if (wrong < 5) {
        ADD_FAILURE() << "query " << i << ": device " << signs[i] << ", host " << host << ", expected "
                      << cases.orient_expected[i] << " for " << describe(c, 6);
      }
      ++wrong;
    }
  }
  EXPECT_EQ(wrong, 0u) << "of " << signs.size() << " queries on " << cdt::gpu::device_description();
}

TEST_F(GpuPredicates, IncircleOnDeviceMatchesOracleAndHost) {
  const auto cases = trixel_test::make_predicate_cases(4);
  std::vector<int> signs(cases.incircle_expected.size(), 7);
  cdt::gpu::incircle_signs(cases.incircle_coords.data(), signs.data(), signs.size());
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < signs.size(); ++i) {
    const double* c = &cases.incircle_coords[8 * i];
    const int host = cdt::detail::incircle(c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]);
    if (signs[i] != cases.incircle_expected[i] || signs[i] != host) {
      if (wrong < 5) {
        ADD_FAILURE() << "query " << i << ": device " << signs[i] << ", host " << host << ", expected "
                      << cases.incircle_expected[i] << " for " << describe(c, 8);
      }
      ++wrong;
    }
  }
  EXPECT_EQ(wrong, 0u) << "of " << signs.size() << " queries";
}

// Regression: the device compiler once turned a pointer select between two local buffers in
// expansion_product into wrong code; this query (a == b, exact determinant 0) came out as +1.
TEST_F(GpuPredicates, ExactPathOnDuplicatePointGivesZero) {
  const double query[] = {2, 1, 2, 1, 1, 2, -4, 1};
  int sign = 7;
  cdt::gpu::incircle_signs(query, &sign, 1);
  EXPECT_EQ(sign, 0);
}

// The driver reserves a kernel's local memory for every thread the device can hold: incircle's exact
// path in expansions took 38 KB a thread, 10 GB of the H200's memory from the first flip on. The
// fixed-point accumulator keeps it near 1.5 KB.
TEST_F(GpuPredicates, ExactFallbackKeepsTheStackSmall) { EXPECT_LE(cdt::gpu::incircle_local_bytes(), 4096u); }

TEST_F(GpuPredicates, EmptyBatchIsANoOp) {
  cdt::gpu::orient2d_signs(nullptr, nullptr, 0);
  SUCCEED();
}

TEST_F(GpuPredicates, DeviceDescriptionNamesTheDevice) {
  EXPECT_NE(cdt::gpu::device_description().find("compute capability"), std::string::npos);
}

} // namespace
