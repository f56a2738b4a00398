#pragma once
// sRGB to CIELAB, compiled for the host and, in the CUDA build, for the device (the trixel stage's
// kernel converts each trixel's colour beside its sums), with the same operations in the same order
// and no contracted multiply-adds on either side: the same Lab to the bit. The grouping compares
// colours in CIELAB (grouping.hpp: srgb_to_lab).

#include <array>
#include <cmath>
#include <cstdint>

#include "cdt/detail/host_device.hpp"

#ifndef __CUDA_ARCH__
#include <bit>
#endif

namespace vectorize::detail {

/// Intervals of the sRGB transfer curve's table (srgb_linear_table: this many plus one nodes).
constexpr int kLinearSamples = 4096;

/// The sRGB transfer curve at c in [0, 1], exactly (std::pow).
inline double srgb_to_linear_exact(double c) {
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

/// The curve at the nodes i / kLinearSamples, i = 0..kLinearSamples, made once by the host; the device
/// receives a copy of it (its own pow rounds differently).
inline const double* srgb_linear_table() {
  static const auto table = [] {
    std::array<double, kLinearSamples + 1> t{};
    for (int i = 0; i <= kLinearSamples; ++i)
      t[i] = srgb_to_linear_exact(static_cast<double>(i) / kLinearSamples);
    return t;
  }();
  return table.data();
}

/// The sRGB transfer curve, interpolated linearly in `table` (srgb_linear_table): grouping converts a
/// colour at every join, and pow() dominated. Within 1e-6 of the curve, far below what Delta E can tell
/// apart. c in [0, 1].
CDT_HD_INLINE double srgb_to_linear(double c, const double* table) {
  const double x = c * kLinearSamples;
  const int whole = static_cast<int>(x);
  const int i = whole < kLinearSamples - 1 ? whole : kLinearSamples - 1;
  const double f = x - i;
  return table[i] + (table[i + 1] - table[i]) * f;
}

/// The cube root's first estimate for t > 0 (finite): t's bits with the exponent divided by three, a
/// few per cent off.
CDT_HD_INLINE double cube_root_estimate(double t) {
  constexpr std::uint64_t kThirdOfOneBits = 0x2A9F7893782DA1CE; // cbrt's exponent bias, and a tweak
#ifdef __CUDA_ARCH__
  return __longlong_as_double(
      static_cast<long long>(static_cast<std::uint64_t>(__double_as_longlong(t)) / 3 + kThirdOfOneBits));
#else
  return std::bit_cast<double>(std::bit_cast<std::uint64_t>(t) / 3 + kThirdOfOneBits);
#endif
}

/// One step of Halley's iteration towards t's cube root from y: it cubes the error.
CDT_HD_INLINE double halley_step(double t, double y) {
  const double y3 = y * y * y;
  return y - y * (y3 - t) / (2.0 * y3 + t);
}

/// Three steps from the estimate y (cube_root_estimate), written out: a loop of them kept GCC from
/// vectorising the grouping's loop over many roots.
CDT_HD_INLINE double cube_root_refine(double t, double y) {
  return halley_step(t, halley_step(t, halley_step(t, y)));
}

/// The cube root of t > 0 (finite): an estimate from t's bits (its exponent divided by three, a few
/// per cent off), then three steps of Halley's iteration, each cubing the error, the last one's
/// correction small against the estimate. Within 3 units in the last place, and the correctly rounded
/// root for 9 in 10 arguments (glibc's std::cbrt: 1 unit, correctly rounded for about half); three
/// times as fast as std::cbrt, which was a fifth of the grouping's time.
CDT_HD_INLINE double cube_root(double t) { return cube_root_refine(t, cube_root_estimate(t)); }

/// lab_f's linear part, below the cube root's range.
CDT_HD_INLINE double lab_f_linear(double t) {
  constexpr double delta = 6.0 / 29.0;
  return t / (3 * delta * delta) + 4.0 / 29.0;
}

CDT_HD_INLINE double lab_f(double t) {
  constexpr double delta = 6.0 / 29.0;
  return t > delta * delta * delta ? cube_root(t) : lab_f_linear(t);
}

/// std::clamp(v, 0, 1), also on the device.
CDT_HD_INLINE double clamp_unit(double v) { return v < 0.0 ? 0.0 : 1.0 < v ? 1.0 : v; }

/// XYZ, normalised by the D65 white point, of the linear sRGB colour `linear`.
CDT_HD_INLINE void xyz_of_linear(const double* linear, double* xyz) {
  const double r = linear[0];
  const double g = linear[1];
  const double b = linear[2];
  xyz[0] = (0.4124564 * r + 0.3575761 * g + 0.1804375 * b) / 0.95047;
  xyz[1] = 0.2126729 * r + 0.7151522 * g + 0.0721750 * b;
  xyz[2] = (0.0193339 * r + 0.1191920 * g + 0.9503041 * b) / 1.08883;
}

/// CIELAB from lab_f of X, Y and Z.
CDT_HD_INLINE void lab_of_f(double fx, double fy, double fz, double* lab) {
  lab[0] = 116.0 * fy - 16.0;
  lab[1] = 500.0 * (fx - fy);
  lab[2] = 200.0 * (fy - fz);
}

/// CIELAB (D65 white) of the non-premultiplied sRGB colour rgb, with the curve's table `table`.
CDT_HD_INLINE void lab_of_rgb(const float* rgb, const double* table, double* lab) {
  const double linear[3] = {srgb_to_linear(clamp_unit(static_cast<double>(rgb[0])), table),
                            srgb_to_linear(clamp_unit(static_cast<double>(rgb[1])), table),
                            srgb_to_linear(clamp_unit(static_cast<double>(rgb[2])), table)};
  double xyz[3];
  xyz_of_linear(linear, xyz);
  lab_of_f(lab_f(xyz[0]), lab_f(xyz[1]), lab_f(xyz[2]), lab);
}

} // namespace vectorize::detail
