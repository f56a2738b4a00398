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
  std::size_t wide = 0; // queries past the integer path's span, which the wide accumulator decides
  for (std::size_t i = 0; i < cases.incircle_expected.size(); ++i) {
    const double* c = &cases.incircle_coords[8 * i];
    ASSERT_EQ(cdt::detail::incircle_exact(c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]),
              cases.incircle_expected[i])
        << i;
    ASSERT_EQ(cdt::detail::incircle_exact_wide(c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]),
              cases.incircle_expected[i])
        << i;
    int sign = 0;
    if (!cdt::detail::incircle_detail::small_sign(c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], sign))
      ++wide;
  }
  EXPECT_GE(wide, 250u);
}

// The filters alone (the device's first pass) either decide a query as the exact predicate does or
// say kUndecided; on the near-degenerate sets they must leave many undecided, or the second pass with
// the exact tests would go untested.
TEST(Predicates, FiltersDecideExactlyOrLeaveUndecided) {
  const auto cases = trixel_test::make_predicate_cases();
  std::size_t wrong = 0, undecided = 0;
  for (std::size_t i = 0; i < cases.orient_expected.size(); ++i) {
    const double* c = &cases.orient_coords[6 * i];
    const int sign = cdt::detail::orient2d_filter(c[0], c[1], c[2], c[3], c[4], c[5]);
    if (sign == cdt::detail::kUndecided)
      ++undecided;
    else if (sign != cases.orient_expected[i])
      ++wrong;
  }
  for (std::size_t i = 0; i < cases.incircle_expected.size(); ++i) {
    const double* c = &cases.incircle_coords[8 * i];
    double det = 0;
    const int sign = cdt::detail::incircle_filter(c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], det);
    if (sign == cdt::detail::kUndecided)
      ++undecided;
    else if (sign != cases.incircle_expected[i])
      ++wrong;
  }
  EXPECT_EQ(wrong, 0u);
  EXPECT_GT(undecided, 100u);
  EXPECT_LT(undecided, cases.orient_expected.size() + cases.incircle_expected.size());
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

namespace {

using cdt::detail::incircle_perturbed;

struct P {
  double x;
  double y;
};

int perturbed(const P& a, const P& b, const P& c, const P& d) {
  return incircle_perturbed(a.x, a.y, b.x, b.y, c.x, c.y, d.x, d.y);
}

// The twelve lattice points of the circle of radius 5, counter-clockwise, moved off the origin (by
// half-integers, as pixel centres are): every four of them are co-circular and in convex position.
// For each such quadrilateral a b c d the perturbed test must say exactly one diagonal is Delaunay,
// the same whichever corner each triangle is read from, and agree with incircle off the circle.
TEST(Predicates, PerturbedIncircleKeepsExactlyOneDiagonalOfCoCircularPoints) {
  const P circle[12] = {{5, 0},  {4, 3},   {3, 4},   {0, 5},  {-3, 4}, {-4, 3},
                        {-5, 0}, {-4, -3}, {-3, -4}, {0, -5}, {3, -4}, {4, -3}};
  for (const P shift : {P{0, 0}, P{100.5, 7.5}, P{-3.5, 2000.5}}) {
    P p[12];
    for (int i = 0; i < 12; ++i) p[i] = {circle[i].x + shift.x, circle[i].y + shift.y};
    int quads = 0;
    for (int i = 0; i < 12; ++i)
      for (int j = i + 1; j < 12; ++j)
        for (int k = j + 1; k < 12; ++k)
          for (int l = k + 1; l < 12; ++l) {
            const P &a = p[i], &b = p[j], &c = p[k], &d = p[l];
            ASSERT_EQ(incircle(a.x, a.y, b.x, b.y, c.x, c.y, d.x, d.y), 0);
            // Diagonal a-c: triangles (a, b, c) and (a, c, d); diagonal b-d: (a, b, d) and (b, c, d).
            const int ac1 = perturbed(a, b, c, d), ac2 = perturbed(a, c, d, b);
            const int bd1 = perturbed(a, b, d, c), bd2 = perturbed(b, c, d, a);
            ASSERT_NE(ac1, 0);
            ASSERT_NE(bd1, 0);
            EXPECT_EQ(ac1, ac2) << i << j << k << l; // one lifting: both triangles of a diagonal agree
            EXPECT_EQ(bd1, bd2) << i << j << k << l;
            EXPECT_NE(ac1, bd1) << i << j << k << l; // and exactly one diagonal passes (sign < 0)
            EXPECT_EQ(perturbed(b, c, a, d), ac1);   // the triangle read from another corner
            EXPECT_EQ(perturbed(c, a, b, d), ac1);
            ++quads;
          }
    EXPECT_EQ(quads, 495);
  }
  // Off the circle the perturbation changes nothing.
  const P a{0, 0}, b{4, 0}, c{0, 4};
  EXPECT_EQ(perturbed(a, b, c, {1, 1}), 1);
  EXPECT_EQ(perturbed(a, b, c, {5, 5}), -1);
  // A unit square: the lexicographically first corner (0, 0) is pushed out, so the diagonal
  // (1, 0)-(0, 1) is kept.
  EXPECT_EQ(perturbed({0, 0}, {1, 0}, {1, 1}, {0, 1}), 1);  // diagonal (0,0)-(1,1) fails
  EXPECT_EQ(perturbed({0, 0}, {1, 0}, {0, 1}, {1, 1}), -1); // diagonal (1,0)-(0,1) passes
}

} // namespace
