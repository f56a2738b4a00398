// CGAL's exact predicates as an oracle on random near-degenerate doubles, where no closed-form answer
// exists: points snapped to lines and circles and then perturbed by a few ulps.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "cdt/detail/predicates.hpp"
#include "predicate_cases.hpp"

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using P = Kernel::Point_2;

double unit(trixel_test::Rng& rng) { return static_cast<double>(rng.next() >> 11) / 9007199254740992.0; }

double nudge(double v, trixel_test::Rng& rng) {
  const int steps = static_cast<int>(rng.range(-3, 3));
  for (int s = 0; s < (steps < 0 ? -steps : steps); ++s) v = std::nextafter(v, steps < 0 ? -1e300 : 1e300);
  return v;
}

TEST(PredicatesCgal, OrientNearLinesAgreesWithCgal) {
  trixel_test::Rng rng(7);
  int wrong = 0;
  for (int i = 0; i < 100000; ++i) {
    const double ax = unit(rng) * 100, ay = unit(rng) * 100, bx = unit(rng) * 100, by = unit(rng) * 100;
    const double s = unit(rng) * 2 - 0.5;
    const double cx = nudge(ax + s * (bx - ax), rng), cy = nudge(ay + s * (by - ay), rng);
    const int expected = static_cast<int>(CGAL::orientation(P(ax, ay), P(bx, by), P(cx, cy)));
    if (cdt::detail::orient2d(ax, ay, bx, by, cx, cy) != expected) ++wrong;
  }
  EXPECT_EQ(wrong, 0);
}

TEST(PredicatesCgal, IncircleNearCirclesAgreesWithCgal) {
  trixel_test::Rng rng(11);
  int wrong = 0;
  for (int i = 0; i < 100000; ++i) {
    const double cx0 = unit(rng) * 1000, cy0 = unit(rng) * 1000, r = 0.001 + unit(rng) * 10;
    double p[8];
    for (int k = 0; k < 4; ++k) {
      const double angle = unit(rng) * 6.283185307179586;
      p[2 * k] = nudge(cx0 + r * std::cos(angle), rng);
      p[2 * k + 1] = nudge(cy0 + r * std::sin(angle), rng);
    }
    const int expected = static_cast<int>(
        CGAL::side_of_oriented_circle(P(p[0], p[1]), P(p[2], p[3]), P(p[4], p[5]), P(p[6], p[7])));
    if (cdt::detail::incircle(p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]) != expected) ++wrong;
  }
  EXPECT_EQ(wrong, 0);
}

// incircle's exact fallback on its own, where the filter is not asked first: points near circles of
// radii from 1e-150 to 1e50 (products of four differences far below the smallest double, and far
// above 1), and points of unrelated magnitudes, whose differences have tails (two_diff) and whose
// products span thousands of binary places.
TEST(PredicatesCgal, IncircleExactAgreesWithCgalAcrossMagnitudes) {
  trixel_test::Rng rng(13);
  int wrong = 0;
  int count = 0;
  const auto check = [&](const double* p) {
    const int expected = static_cast<int>(
        CGAL::side_of_oriented_circle(P(p[0], p[1]), P(p[2], p[3]), P(p[4], p[5]), P(p[6], p[7])));
    if (cdt::detail::incircle_exact(p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]) != expected) ++wrong;
    ++count;
  };
  for (const double scale : {1e-150, 1e-80, 1e-20, 1.0, 1e20, 1e50}) {
    for (int i = 0; i < 5000; ++i) {
      const double cx0 = unit(rng) * 1000 * scale, cy0 = unit(rng) * 1000 * scale;
      const double r = (0.001 + unit(rng) * 10) * scale;
      double p[8];
      for (int k = 0; k < 4; ++k) {
        const double angle = unit(rng) * 6.283185307179586;
        p[2 * k] = nudge(cx0 + r * std::cos(angle), rng);
        p[2 * k + 1] = nudge(cy0 + r * std::sin(angle), rng);
      }
      check(p);
    }
  }
  for (int i = 0; i < 20000; ++i) {
    double p[8];
    for (double& v : p) {
      v = std::ldexp(unit(rng) + 0.5, static_cast<int>(rng.range(-200, 190)));
      if (rng.range(0, 1) != 0) v = -v;
    }
    check(p);
  }
  // Three corners of a rectangle far from the origin and the fourth a few ulps off the circle.
  for (int i = 0; i < 5000; ++i) {
    const double x0 = 1e15 + unit(rng), x1 = x0 + 1e-3 + unit(rng), y0 = unit(rng) * 1e-9, y1 = 3 + unit(rng);
    double p[8] = {x0, y0, x1, y0, x1, y1, x0, y1};
    const auto k = static_cast<std::size_t>(6 + rng.range(0, 1));
    p[k] = nudge(p[k], rng);
    check(p);
  }
  EXPECT_EQ(wrong, 0) << "of " << count;
}

// The exponent of v's lowest set bit.
int lowest_bit(double v) {
  int exponent = 0;
  double m = std::ldexp(std::frexp(std::fabs(v), &exponent), 53); // an integer below 2^53
  int e = exponent - 53;
  while (std::fmod(m, 2.0) == 0.0) m /= 2, ++e;
  return e;
}

// incircle's integer path (coordinates within 2^61 units of the lowest set bit among them) at its
// limits, against CGAL and against the wide accumulator: significands of 53 bits and of one bit, zeros,
// signs, exponents from -1074 up, spans of exactly 61 bits and of 62, where the path must decline.
TEST(PredicatesCgal, IncircleIntegerPathAgreesAtItsLimits) {
  trixel_test::Rng rng(17);
  int wrong = 0, taken = 0, declined_wrongly = 0;
  const double full = 9007199254740991.0; // 2^53 - 1
  for (int i = 0; i < 40000; ++i) {
    const int base = static_cast<int>(rng.range(-1074, 900));
    const int span = static_cast<int>(rng.range(0, 1)) != 0 ? 61 : 62;
    double p[8];
    for (double& v : p) {
      switch (rng.range(0, 4)) {
      case 0:
        v = std::ldexp(full, base + span - 53); // the top bit at base + span - 1
        break;
      case 1:
        v = std::ldexp(1.0, base); // the lowest bit
        break;
      case 2:
        v = std::ldexp(static_cast<double>(rng.next() >> 11),
                       base + static_cast<int>(rng.range(0, span - 53)));
        break;
      case 3:
        v = std::ldexp(1.0, base + static_cast<int>(rng.range(0, span - 1)));
        break;
      default:
        v = 0.0;
      }
      if (rng.range(0, 1) != 0) v = -v;
    }
    // The span of these eight, as the integer path measures it: |v| < 2^(ilogb(v) + 1).
    int low = 1 << 20, high = -(1 << 20);
    for (const double v : p) {
      if (v == 0.0) continue;
      low = std::min(low, lowest_bit(v));
      high = std::max(high, std::ilogb(v) + 1);
    }
    int sign = 7;
    const bool fits =
        cdt::detail::incircle_detail::small_sign(p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], sign);
    if (fits != (high - low <= 61)) ++declined_wrongly;
    if (!fits) continue;
    ++taken;
    const int expected = static_cast<int>(
        CGAL::side_of_oriented_circle(P(p[0], p[1]), P(p[2], p[3]), P(p[4], p[5]), P(p[6], p[7])));
    if (sign != expected ||
        cdt::detail::incircle_exact_wide(p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]) != expected)
      ++wrong;
  }
  EXPECT_EQ(declined_wrongly, 0);
  EXPECT_GT(taken, 10000);
  EXPECT_EQ(wrong, 0) << "of " << taken;
}

} // namespace
