#include "cdt/detail/predicates.hpp"

#include <gtest/gtest.h>

#include <cstddef>

#include "predicate_cases.hpp"

namespace {

using cdt::detail::incircle;
using cdt::detail::orient2d;

TEST(Predicates, OrientMatchesIndependentOracle) {
  const auto cases = trixel_test::make_predicate_cases();
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < cases.orient_expected.size(); ++i) {
    const double* c = &cases.orient_coords[6 * i];
    if (orient2d(c[0], c[1], c[2], c[3], c[4], c[5]) != cases.orient_expected[i]) ++wrong;
  }
  EXPECT_EQ(wrong, 0u) << "of " << cases.orient_expected.size() << " queries";
}

TEST(Predicates, IncircleMatchesIndependentOracle) {
  const auto cases = trixel_test::make_predicate_cases();
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < cases.incircle_expected.size(); ++i) {
    const double* c = &cases.incircle_coords[8 * i];
    if (incircle(c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]) != cases.incircle_expected[i]) ++wrong;
  }
  EXPECT_EQ(wrong, 0u) << "of " << cases.incircle_expected.size() << " queries";
}

// The exact paths must agree with the filtered entry points whenever the filter decides, so they
// are checked on their own against the same oracle.
TEST(Predicates, ExactFallbacksMatchOracle) {
  const auto cases = trixel_test::make_predicate_cases();
  for (std::size_t i = 0; i < cases.orient_expected.size(); ++i) {
    const double* c = &cases.orient_coords[6 * i];
    ASSERT_EQ(cdt::detail::orient2d_exact(c[0], c[1], c[2], c[3], c[4], c[5]), cases.orient_expected[i]) << i;
  }
  for (std::size_t i = 0; i < cases.incircle_expected.size(); ++i) {
    const double* c = &cases.incircle_coords[8 * i];
    ASSERT_EQ(cdt::detail::incircle_exact(c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]),
              cases.incircle_expected[i])
        << i;
  }
}

// Naive double evaluation is wrong on the near-degenerate sets; this guards against the sets
// silently becoming easy (which would make the tests above unable to fail).
TEST(Predicates, CasesDefeatNaiveFloatingPoint) {
  const auto cases = trixel_test::make_predicate_cases();
  std::size_t naive_wrong = 0;
  for (std::size_t i = 0; i < cases.orient_expected.size(); ++i) {
    const double* c = &cases.orient_coords[6 * i];
    const double det = (c[0] - c[4]) * (c[3] - c[5]) - (c[1] - c[5]) * (c[2] - c[4]);
    if (((det > 0) - (det < 0)) != cases.orient_expected[i]) ++naive_wrong;
  }
  EXPECT_GT(naive_wrong, 100u);
}

TEST(Predicates, ExpansionSumIsExact) {
  using cdt::detail::Expansion;
  // 1e100 + 1 - 1e100 is 1 exactly in expansion arithmetic.
  Expansion<1> a;
  a.t[0] = 1e100;
  a.n = 1;
  Expansion<1> b;
  b.t[0] = 1.0;
  b.n = 1;
  Expansion<2> ab;
  cdt::detail::expansion_sum(a, b, ab);
  Expansion<1> c;
  c.t[0] = -1e100;
  c.n = 1;
  Expansion<3> abc;
  cdt::detail::expansion_sum(ab, c, abc);
  ASSERT_EQ(abc.n, 1);
  EXPECT_EQ(abc.t[0], 1.0);
}

TEST(Predicates, OrientationAndIncircleConventions) {
  EXPECT_EQ(orient2d(0, 0, 1, 0, 0, 1), 1);
  EXPECT_EQ(orient2d(0, 0, 0, 1, 1, 0), -1);
  EXPECT_EQ(orient2d(0, 0, 1, 1, 2, 2), 0);
  EXPECT_EQ(incircle(0, 0, 1, 0, 0, 1, 0.25, 0.25), 1);
  EXPECT_EQ(incircle(0, 0, 1, 0, 0, 1, 1, 1), 0);
  EXPECT_EQ(incircle(0, 0, 1, 0, 0, 1, 2, 2), -1);
  EXPECT_EQ(incircle(0, 0, 0, 1, 1, 0, 0.25, 0.25), -1); // clockwise triangle flips the sign
}

} // namespace
