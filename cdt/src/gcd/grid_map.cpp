// Phase 1 of gCD, first half: the grid mapping of Appendix B and the grid sites of section 3.1.
//
// Appendix B in integers: with q a power of two, scale = S * q and t = T * q for integers S and T, the
// grid position g * scale + t equals (g * S + T) * q, which is an exact double whenever the integer
// |g * S + T| < 2^53 (pMax + 1 bits, pMax = 52). The paper gets there with the scale's mantissa cut
// to pS = pMax - pM bits (pM = bits of m - 1, so g * S needs at most pMax bits) and the translation
// cut to pMax bits at the scale's quantum (Case 1) or the scale rounded up to the translation's
// quantum (Case 2). Both cases are the choice of one q here: the larger of the scale's quantum and the
// translations' quanta, doubled until the exactness bound holds at the two ends g = 0 and g = m - 1
// (g * S + T is linear in g, so the ends bound every g between them).

#include "gcd/grid_map.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <string>

#include "cdt/errors.hpp"
#include "executor/cpu_executor.hpp"

namespace cdt::detail {

namespace {

constexpr int kPMax = 52; // explicit mantissa bits of a double; the 53rd absorbs the sum's carry

/// 2^e, the power of two with v in [2^(e-1), 2^e) (v > 0).
int exponent_above(double v) {
  int e = 0;
  std::frexp(v, &e);
  return e;
}

/// The grid cell of one point (per-element work of assign_sites).
CDT_HD inline std::uint32_t site_cell(const GridMapping& mapping, double x, double y, std::uint32_t& gx,
                                      std::uint32_t& gy) {
  gx = mapping.grid_x(x);
  gy = mapping.grid_y(y);
  return gy * mapping.m + gx;
}

} // namespace

std::uint32_t choose_grid_size(std::size_t num_points, GridFor target) {
  // The host's parts insert the missing points of small inputs cheaply too, so its grid may go
  // coarser than the device's.
  const std::uint32_t min_side = target == GridFor::device ? 256 : 32;
  constexpr std::uint32_t kMax = 8192;
  // Past this side the device's grid is one power of two coarser (see grid_map.hpp).
  constexpr std::uint32_t kDeviceFine = 2048;
  // Compare in floating point: sqrt(n) for n near 2^64 does not fit the clamp otherwise.
  const double per_cell = target == GridFor::host ? 8.0 : target == GridFor::host_points ? 16.0 : 1.0;
  const double wanted = std::sqrt(static_cast<double>(num_points) / per_cell);
  std::uint32_t side = 2 * kMax;
  if (wanted < 2 * kMax) side = std::bit_ceil(std::max(static_cast<std::uint32_t>(std::ceil(wanted)), 1u));
  if (target == GridFor::device && side > kDeviceFine) side /= 2;
  return std::clamp(side, min_side, kMax);
}

GridMapping make_grid_mapping(std::span<const double> x, std::span<const double> y, std::uint32_t m) {
  CpuExecutor serial(1);
  return make_grid_mapping(x, y, m, serial);
}

GridMapping make_grid_mapping(std::span<const double> x, std::span<const double> y, std::uint32_t m,
                              CpuExecutor& executor) {
  if (m == 0 || m > kMaxGridSize)
    throw Error("grid size " + std::to_string(m) + " is outside [1, " + std::to_string(kMaxGridSize) + "]");
  if (x.size() != y.size()) throw Error("internal error: x and y of different lengths");
  GridMapping mapping;
  mapping.m = m;
  mapping.scale = 1.0;
  if (x.empty()) return mapping;

  // The bounding box, and the first point with a non-finite coordinate (n when none).
  struct Bounds {
    double x_min, x_max, y_min, y_max;
    std::size_t bad;
  };
  const std::size_t n = x.size();
  const Bounds bounds = executor.reduce(
      n, Bounds{x[0], x[0], y[0], y[0], n},
      [&](Bounds& b, std::size_t i) {
        if (b.bad != n) return;
        if (!std::isfinite(x[i]) || !std::isfinite(y[i])) {
          b.bad = i;
          return;
        }
        b.x_min = std::min(b.x_min, x[i]);
        b.x_max = std::max(b.x_max, x[i]);
        b.y_min = std::min(b.y_min, y[i]);
        b.y_max = std::max(b.y_max, y[i]);
      },
      [](Bounds& b, const Bounds& part) {
        b.bad = std::min(b.bad, part.bad);
        b.x_min = std::min(b.x_min, part.x_min);
        b.x_max = std::max(b.x_max, part.x_max);
        b.y_min = std::min(b.y_min, part.y_min);
        b.y_max = std::max(b.y_max, part.y_max);
      });
  if (bounds.bad != n)
    throw InvalidInputError(InvalidInputError::Kind::non_finite_coordinate, bounds.bad,
                            "point " + std::to_string(bounds.bad) + " has a non-finite coordinate");
  return grid_mapping_of_box(bounds.x_min, bounds.x_max, bounds.y_min, bounds.y_max, m);
}

GridMapping grid_mapping_of_box(double x_min, double x_max, double y_min, double y_max, std::uint32_t m) {
  if (m == 0 || m > kMaxGridSize)
    throw Error("grid size " + std::to_string(m) + " is outside [1, " + std::to_string(kMaxGridSize) + "]");
  GridMapping mapping;
  mapping.m = m;
  const int p_m = std::bit_width(m - 1);    // bits of the largest grid coordinate
  const int p_s = kPMax - p_m;              // mantissa bits left for the scale
  const double limit = std::ldexp(1.0, 53); // |g * S + T| must stay below this
  const double extent = std::max(x_max - x_min, y_max - y_min);
  // Aim a little above extent / m: the subtraction above may have rounded the extent down, and the
  // translations below are rounded down by up to one quantum (covered by the extra quantum in S).
  double target = extent * (1.0 + std::ldexp(1.0, -50)) / m;
  if (!(target > 0.0)) {
    // All points coincide: any positive scale keeps them in cell (0, 0); one relative to their
    // magnitude keeps the quanta below representable.
    target = std::max(std::fabs(x_min), std::fabs(y_min)) / m;
    if (!(target > 0.0)) target = 1.0;
  }

  // Smallest candidate quantum: S = target / q needs at most p_s bits, and T = t / q at most pMax bits.
  int q_exp = exponent_above(target) - p_s;
  if (x_min != 0.0) q_exp = std::max(q_exp, exponent_above(std::fabs(x_min)) - kPMax);
  if (y_min != 0.0) q_exp = std::max(q_exp, exponent_above(std::fabs(y_min)) - kPMax);
  q_exp = std::max(q_exp, -1074); // a quantum below the smallest subnormal would be zero
  for (int attempt = 0; attempt < 4096; ++attempt, ++q_exp) {
    const double q = std::ldexp(1.0, q_exp);
    // Rounding the scale up (Appendix B) and one quantum more for the rounded-down translation.
    const double s = std::ceil(target / q) + 1.0;
    const double t_x = std::floor(x_min / q);
    const double t_y = std::floor(y_min / q);
    if (!(s < std::ldexp(1.0, p_s)) || !(std::fabs(t_x) < limit) || !(std::fabs(t_y) < limit)) continue;
    // Integers now below 2^53, so the ends of g * S + T are exact in 64 bits.
    const auto s_int = static_cast<std::int64_t>(s);
    const auto top = static_cast<std::int64_t>(m - 1) * s_int;
    const auto lim = static_cast<std::int64_t>(1) << 53;
    const auto fits = [&](double t) {
      const auto t_int = static_cast<std::int64_t>(t);
      return t_int + top < lim && t_int + top > -lim;
    };
    if (!fits(t_x) || !fits(t_y)) continue;
    mapping.scale = s * q;
    mapping.tx = t_x * q;
    mapping.ty = t_y * q;
    return mapping;
  }
  throw Error("internal error: no exact grid mapping found");
}

GridSites assign_sites(const GridMapping& mapping, std::span<const double> x, std::span<const double> y,
                       CpuExecutor& executor) {
  if (x.size() != y.size()) throw Error("internal error: x and y of different lengths");
  if (x.size() >= kNone) throw Error("too many points for 32-bit indices");
  if (mapping.m == 0 || mapping.m > kMaxGridSize) throw Error("internal error: grid size out of range");
  const std::size_t n = x.size();
  const std::uint32_t m = mapping.m;
  GridSites sites;
  sites.gx.resize(n);
  sites.gy.resize(n);
  sites.cell_owner.assign(static_cast<std::size_t>(m) * m, kNone);
  std::uint32_t* gx = sites.gx.data();
  std::uint32_t* gy = sites.gy.data();
  std::uint32_t* owner = sites.cell_owner.data();
  // The point nearest the grid point wins every cell, the lowest index among equals, however the
  // threads interleave: first the cells' least distance, then the least index at it.
  std::vector<std::uint32_t> least(static_cast<std::size_t>(m) * m, kNone);
  executor.for_each(n, [&](std::size_t i) {
    const std::uint32_t cell = site_cell(mapping, x[i], y[i], gx[i], gy[i]);
    atomic_min(least.data() + cell, grid_point_distance_key(mapping, x[i], y[i], gx[i], gy[i]));
  });
  executor.for_each(n, [&](std::size_t i) {
    const std::size_t cell = static_cast<std::size_t>(gy[i]) * m + gx[i];
    if (grid_point_distance_key(mapping, x[i], y[i], gx[i], gy[i]) == least[cell])
      atomic_min(owner + cell, static_cast<std::uint32_t>(i));
  });
  sites.missing = executor.compact(n, [&](std::size_t i) {
    return owner[static_cast<std::size_t>(gy[i]) * m + gx[i]] != static_cast<std::uint32_t>(i);
  });
  sites.missing_owner.resize(sites.missing.size());
  const std::uint32_t* missing = sites.missing.data();
  std::uint32_t* missing_owner = sites.missing_owner.data();
  executor.for_each(sites.missing.size(), [&](std::size_t k) {
    const std::uint32_t p = missing[k];
    missing_owner[k] = owner[static_cast<std::size_t>(gy[p]) * m + gx[p]];
  });
  return sites;
}

} // namespace cdt::detail
