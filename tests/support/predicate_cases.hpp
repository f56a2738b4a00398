#pragma once
// Query sets for the exact predicates with answers known independently of the code under test:
// integer coordinates (checked with 128-bit integer arithmetic), points a few ulps off a line, and
// points a few ulps off a circle. Shared by the host tests and the device tests.

#include <cmath>
#include <cstdint>
#include <vector>

#include "pslg_generators.hpp"

namespace trixel_test {

struct PredicateCases {
  std::vector<double> orient_coords; ///< 6 per query: ax ay bx by cx cy
  std::vector<int> orient_expected;
  std::vector<double> incircle_coords; ///< 8 per query: ax ay bx by cx cy dx dy
  std::vector<int> incircle_expected;
};

// __extension__ keeps -Wpedantic quiet about the compiler extension; the oracle needs 128 bits.
__extension__ typedef __int128 Int128;

inline int sign_of(Int128 v) { return (v > 0) - (v < 0); }

/// Deterministic generator shared with the input generators, so that failures reproduce.
using Rng = trixel_gen::Random;

inline int orient_int(std::int64_t ax, std::int64_t ay, std::int64_t bx, std::int64_t by, std::int64_t cx,
                      std::int64_t cy) {
  const Int128 det = static_cast<Int128>(ax - cx) * (by - cy) - static_cast<Int128>(ay - cy) * (bx - cx);
  return sign_of(det);
}

inline int incircle_int(std::int64_t ax, std::int64_t ay, std::int64_t bx, std::int64_t by, std::int64_t cx,
                        std::int64_t cy, std::int64_t dx, std::int64_t dy) {
  const Int128 adx = ax - dx, ady = ay - dy, bdx = bx - dx, bdy = by - dy, cdx = cx - dx, cdy = cy - dy;
  const Int128 alift = adx * adx + ady * ady;
  const Int128 blift = bdx * bdx + bdy * bdy;
  const Int128 clift = cdx * cdx + cdy * cdy;
  const Int128 det =
      alift * (bdx * cdy - cdx * bdy) + blift * (cdx * ady - adx * cdy) + clift * (adx * bdy - bdx * ady);
  return sign_of(det);
}

/// Builds every query set. `scale` multiplies the number of random queries.
inline PredicateCases make_predicate_cases(int scale = 1) {
  PredicateCases cases;
  Rng rng(12345);
  auto add_orient = [&](double ax, double ay, double bx, double by, double cx, double cy, int expected) {
    cases.orient_coords.insert(cases.orient_coords.end(), {ax, ay, bx, by, cx, cy});
    cases.orient_expected.push_back(expected);
  };
  auto add_incircle = [&](double ax, double ay, double bx, double by, double cx, double cy, double dx,
                          double dy, int expected) {
    cases.incircle_coords.insert(cases.incircle_coords.end(), {ax, ay, bx, by, cx, cy, dx, dy});
    cases.incircle_expected.push_back(expected);
  };

  // 1. Integer coordinates: a small range gives many collinear and co-circular quadruples (a pixel
  //    lattice is exactly this), a large one exercises big magnitudes (2^20 keeps int128 exact).
  for (const std::int64_t range : {4ll, 16ll, 1ll << 20}) {
    for (int i = 0; i < 4000 * scale; ++i) {
      std::int64_t v[8];
      for (auto& c : v) c = rng.range(-range, range);
      add_orient(double(v[0]), double(v[1]), double(v[2]), double(v[3]), double(v[4]), double(v[5]),
                 orient_int(v[0], v[1], v[2], v[3], v[4], v[5]));
      // incircle's sign flips with the orientation of (a, b, c); the oracle is the plain determinant.
      add_incircle(double(v[0]), double(v[1]), double(v[2]), double(v[3]), double(v[4]), double(v[5]),
                   double(v[6]), double(v[7]), incircle_int(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]));
    }
  }
  // Integer coordinates translated far from the origin: differences stay exact, magnitudes do not.
  for (int i = 0; i < 2000 * scale; ++i) {
    std::int64_t v[8];
    for (auto& c : v) c = rng.range(-8, 8);
    const double off = 1099511627776.0; // 2^40
    add_incircle(off + v[0], off + v[1], off + v[2], off + v[3], off + v[4], off + v[5], off + v[6],
                 off + v[7], incircle_int(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]));
  }

  // 2. Points a few ulps off the line y = x through (12, 12) and (24, 24): orient(p, q, r) equals
  //    12 * (py - px) exactly, so its sign is known; naive floating point gets many of these wrong.
  const double ulp = 1.0 / 9007199254740992.0; // 2^-53
  for (int i = 0; i < 64; ++i) {
    for (int j = 0; j < 64; ++j) {
      const double px = 0.5 + i * ulp;
      const double py = 0.5 + j * ulp;
      add_orient(px, py, 12.0, 12.0, 24.0, 24.0, (j > i) - (j < i));
    }
  }

  // 3. Points a few ulps inside, on, or outside the unit circle through (1,0), (0,1), (-1,0), all
  //    translated by 2^20 so that the filter cannot decide: d = (0, -1 + k * 2^-30) is inside for
  //    k > 0, on for k = 0, outside for k < 0.
  const double t = 1048576.0; // 2^20
  for (int k = -40; k <= 40; ++k) {
    const double dy = -1.0 + k * (1.0 / 1073741824.0);
    add_incircle(t + 1.0, t, t, t + 1.0, t - 1.0, t, t, t + dy, (k > 0) - (k < 0));
    add_incircle(1.0, 0.0, 0.0, 1.0, -1.0, 0.0, 0.0, dy, (k > 0) - (k < 0));
  }

  // 4. Lattices of halves and sixteenths at spans around incircle's exact-in-double limit (5200
  //    lattice units) and far beyond it: three corners of an axis-aligned rectangle and the fourth,
  //    exactly on their circle or one unit off it. Beyond the limit a plain double evaluation of the
  //    cocircular case rounds to a nonzero value. The oracle is the integer determinant, whose sign the
  //    division by the lattice unit keeps.
  for (const double unit : {2.0, 16.0}) {
    for (const std::int64_t span : {1300ll, 2600ll, 2700ll, 40000ll, 1ll << 20}) {
      for (int i = 0; i < 1000 * scale; ++i) {
        const std::int64_t x0 = rng.range(-span, span), x1 = rng.range(-span, span);
        const std::int64_t y0 = rng.range(-span, span), y1 = rng.range(-span, span);
        std::int64_t corners[4][2] = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
        const int rotate = static_cast<int>(rng.range(0, 3));
        std::int64_t v[8];
        for (int k = 0; k < 4; ++k) {
          v[2 * k] = corners[(k + rotate) % 4][0];
          v[2 * k + 1] = corners[(k + rotate) % 4][1];
        }
        v[6 + rng.range(0, 1)] += rng.range(-1, 1) * rng.range(0, 1); // mostly exactly on the circle
        add_incircle(v[0] / unit, v[1] / unit, v[2] / unit, v[3] / unit, v[4] / unit, v[5] / unit,
                     v[6] / unit, v[7] / unit, incircle_int(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]));
      }
    }
  }

  // 5. Coordinates of very different magnitudes, past the span of incircle's integer path (more than
  //    2^61 units of the lowest set bit), so that its wide accumulator decides: the circle through
  //    (R, 0), (0, R) and (-R, 0) with R = 2^r, and d = (e, -R) outside it (e = 2^-k, |d|^2 = R^2 + e^2),
  //    d = (e, -R + R * 2^-52) inside it (|d|^2 = R^2 - 2^(1 - 52) R^2 + ...; the filter cannot decide
  //    either), and d = (0, -R) on it (a span of one bit: the integer path's). Each quadruple also turned by
  //    a quarter (which keeps every sign) and with a, b, c cycled.
  for (int i = 0; i < 150 * scale; ++i) {
    const double r = std::ldexp(1.0, static_cast<int>(rng.range(30, 60)));
    const double e = std::ldexp(1.0, -static_cast<int>(rng.range(40, 70))) * (rng.range(0, 1) != 0 ? 1 : -1);
    const double inner = -r + std::ldexp(r, -52);
    const double ds[3][2] = {{e, -r}, {0.0, -r}, {e, inner}};
    const int expected[3] = {-1, 0, 1};
    for (int k = 0; k < 3; ++k) {
      double v[8] = {r, 0.0, 0.0, r, -r, 0.0, ds[k][0], ds[k][1]};
      for (int turn = static_cast<int>(rng.range(0, 3)); turn > 0; --turn)
        for (int q = 0; q < 4; ++q) {
          const double x = v[2 * q];
          v[2 * q] = -v[2 * q + 1];
          v[2 * q + 1] = x;
        }
      const int cycle = static_cast<int>(rng.range(0, 2));
      const double a[6] = {v[0], v[1], v[2], v[3], v[4], v[5]};
      for (int q = 0; q < 3; ++q) {
        v[2 * q] = a[2 * ((q + cycle) % 3)];
        v[2 * q + 1] = a[2 * ((q + cycle) % 3) + 1];
      }
      add_incircle(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], expected[k]);
    }
  }
  return cases;
}

} // namespace trixel_test
