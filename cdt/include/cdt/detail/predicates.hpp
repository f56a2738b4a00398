#pragma once
// Exact geometric predicates orient2d and incircle for double coordinates.
//
// A floating-point filter with a proven error bound answers almost every call; when it cannot decide,
// the determinant is evaluated exactly: orient2d's with floating-point expansion arithmetic (sums of
// non-overlapping doubles, after Shewchuk, "Adaptive Precision Floating-Point Arithmetic and Fast
// Robust Geometric Predicates", 1997), incircle's in fixed-size integers when the coordinates span at
// most 61 bits (integer_detail), else as integer products added in one wide fixed-point accumulator
// (incircle_detail). The same code runs on the host and on the device.
//
// Error-free transformations need every operation rounded exactly once, so fused multiply-add must
// not be introduced by the compiler: on the device the arithmetic goes through the __d*_rn
// intrinsics, which are never contracted; on the host the cdt target compiles with
// -ffp-contract=off (see cdt/CMakeLists.txt). The one deliberate fma is the device's two-product.
//
// Preconditions: finite coordinates whose magnitude stays below about 1e60 (no overflow of the
// fourth powers in incircle) and differences that do not underflow (the engine's input checks accept
// nonzero coordinates from 1e-60 on).

#include <bit>
#include <cstdint>

#include "cdt/detail/host_device.hpp"

namespace cdt::detail {

CDT_HD_INLINE double fadd(double a, double b) {
#if defined(__CUDA_ARCH__)
  return __dadd_rn(a, b);
#else
  return a + b;
#endif
}
CDT_HD_INLINE double fsub(double a, double b) {
#if defined(__CUDA_ARCH__)
  return __dsub_rn(a, b);
#else
  return a - b;
#endif
}
CDT_HD_INLINE double fmul(double a, double b) {
#if defined(__CUDA_ARCH__)
  return __dmul_rn(a, b);
#else
  return a * b;
#endif
}
// Branch-free: incircle's error bound takes six of these of signs that vary at random, and a compare
// and jump per value cost more mispredictions than the arithmetic of the whole filter.
CDT_HD_INLINE double fabs_(double a) {
#if defined(__CUDA_ARCH__)
  return fabs(a);
#else
  return __builtin_fabs(a);
#endif
}

// --- error-free transformations --------------------------------------------------------------------

/// x + y == a + b exactly, with x = fl(a + b).
CDT_HD_INLINE void two_sum(double a, double b, double& x, double& y) {
  x = fadd(a, b);
  const double b_virtual = fsub(x, a);
  const double a_virtual = fsub(x, b_virtual);
  y = fadd(fsub(a, a_virtual), fsub(b, b_virtual));
}

/// x + y == a - b exactly, with x = fl(a - b).
CDT_HD_INLINE void two_diff(double a, double b, double& x, double& y) {
  x = fsub(a, b);
  const double b_virtual = fsub(a, x);
  const double a_virtual = fadd(x, b_virtual);
  y = fadd(fsub(a, a_virtual), fsub(b_virtual, b));
}

/// x + y == a * b exactly, with x = fl(a * b).
CDT_HD_INLINE void two_product(double a, double b, double& x, double& y) {
  x = fmul(a, b);
#if defined(__CUDA_ARCH__)
  y = __fma_rn(a, b, -x); // deliberate: one rounding of an exact product
#else
  // Dekker's split into two 26-bit halves (2^27 + 1 is the splitter).
  constexpr double splitter = 134217729.0;
  const double ca = fmul(splitter, a);
  const double a_hi = fsub(ca, fsub(ca, a));
  const double a_lo = fsub(a, a_hi);
  const double cb = fmul(splitter, b);
  const double b_hi = fsub(cb, fsub(cb, b));
  const double b_lo = fsub(b, b_hi);
  const double err1 = fsub(x, fmul(a_hi, b_hi));
  const double err2 = fsub(err1, fmul(a_lo, b_hi));
  const double err3 = fsub(err2, fmul(a_hi, b_lo));
  y = fsub(fmul(a_lo, b_lo), err3);
#endif
}

// --- expansions ------------------------------------------------------------------------------------

/// A sum of non-overlapping doubles, smallest magnitude first, zeros removed; capacity N.
template <int N>
struct Expansion {
  double t[N];
  int n = 0;
};

/// h = e + f (fast expansion sum with zero elimination); h has room for en + fn terms and may not
/// alias e or f. Returns the number of terms of h (at least one; a zero sum is the single term 0).
CDT_HD inline int sum_terms(const double* e, int en, const double* f, int fn, double* h) {
  int hn = 0;
  int ei = 0;
  int fi = 0;
  // The running sum q absorbs the next-smallest term of e and f each step.
  double q = 0.0;
  bool have_q = false;
  while (ei < en || fi < fn) {
    double next;
    if (fi >= fn || (ei < en && ((f[fi] > e[ei]) == (f[fi] > -e[ei])))) {
      next = e[ei++];
    } else {
      next = f[fi++];
    }
    if (!have_q) {
      q = next;
      have_q = true;
      continue;
    }
    double q_new;
    double hh;
    two_sum(q, next, q_new, hh);
    q = q_new;
    if (hh != 0.0) h[hn++] = hh;
  }
  if (q != 0.0 || hn == 0) h[hn++] = q;
  return hn;
}

/// h = e * b (scale expansion with zero elimination); h has room for 2 * en terms, no aliasing.
CDT_HD inline int scale_terms(const double* e, int en, double b, double* h) {
  int hn = 0;
  if (en == 0) return 0;
  double q;
  double hh;
  two_product(e[0], b, q, hh);
  if (hh != 0.0) h[hn++] = hh;
  for (int i = 1; i < en; ++i) {
    double product1;
    double product0;
    two_product(e[i], b, product1, product0);
    double sum;
    two_sum(q, product0, sum, hh);
    if (hh != 0.0) h[hn++] = hh;
    two_sum(product1, sum, q, hh);
    if (hh != 0.0) h[hn++] = hh;
  }
  if (q != 0.0 || hn == 0) h[hn++] = q;
  return hn;
}

/// h = e + f. Requires M + K <= N.
template <int N, int M, int K>
CDT_HD_INLINE void expansion_sum(const Expansion<M>& e, const Expansion<K>& f, Expansion<N>& h) {
  static_assert(M + K <= N, "expansion_sum: output capacity too small");
  h.n = sum_terms(e.t, e.n, f.t, f.n, h.t);
}

/// h = e * f. Requires 2 * M * K <= N.
template <int N, int M, int K>
CDT_HD void expansion_product(const Expansion<M>& e, const Expansion<K>& f, Expansion<N>& h) {
  static_assert(2 * M * K <= N, "expansion_product: output capacity too small");
  // h accumulates e * f_j term by term; each partial sum goes through a scratch buffer and is copied
  // back. (Selecting between two buffers by pointer instead was miscompiled by the device compiler.)
  double scratch[N];
  double part[2 * M];
  h.n = 0;
  for (int j = 0; j < f.n; ++j) {
    const int part_n = scale_terms(e.t, e.n, f.t[j], part);
    // After j terms h holds at most 2*M*j components, so the sum has room in N.
    const int sum_n = sum_terms(h.t, h.n, part, part_n, scratch);
    for (int i = 0; i < sum_n; ++i) h.t[i] = scratch[i];
    h.n = sum_n;
  }
}

template <int M>
CDT_HD_INLINE Expansion<M> negated(Expansion<M> e) {
  for (int i = 0; i < e.n; ++i) e.t[i] = -e.t[i];
  return e;
}

template <int M>
CDT_HD_INLINE int expansion_sign(const Expansion<M>& e) {
  const double top = e.n > 0 ? e.t[e.n - 1] : 0.0;
  return (top > 0.0) - (top < 0.0);
}

CDT_HD_INLINE Expansion<2> exact_diff(double a, double b) {
  Expansion<2> e;
  double x;
  double y;
  two_diff(a, b, x, y);
  e.n = 0;
  if (y != 0.0) e.t[e.n++] = y;
  if (x != 0.0 || e.n == 0) e.t[e.n++] = x;
  return e;
}

// --- exact integers --------------------------------------------------------------------------------
//
// incircle's exact paths' integers. A double is an integer significand times a power of two (Scaled).
// The wide accumulator's 192 additions go through 1 KiB of memory; on the device that is local memory,
// and one exact test on one thread took tens of microseconds, which a round of the flips waited for
// whenever one of its tests was undecided. The coordinates of the quadruples that reach the exact path
// are nearly always close in magnitude: all eight are then integer multiples of one power of two 2^low
// below 2^(low + 61) (small_integers), and the determinant, scaled by 2^(-4 low), is a polynomial in
// integers below 2^61 that four words in registers hold exactly (incircle_detail::small_sign). The sign
// is the same; quadruples of wider spans go to the wide accumulator. (orient2d's expansions are short;
// the same integer path inlined into the walks' kernels made them slower on the device.)

namespace integer_detail {

/// |v| = m * 2^e with an integer significand m < 2^53 (subnormals included).
struct Scaled {
  std::uint64_t m;
  int e;
  bool negative;
};

CDT_HD_INLINE Scaled scaled(double v) {
#if defined(__CUDA_ARCH__)
  const auto bits = static_cast<std::uint64_t>(__double_as_longlong(v));
#else
  const auto bits = std::bit_cast<std::uint64_t>(v);
#endif
  const auto biased = static_cast<int>((bits >> 52) & 0x7FF);
  const std::uint64_t fraction = bits & ((std::uint64_t{1} << 52) - 1);
  if (biased == 0) return {fraction, -1074, (bits >> 63) != 0};
  return {fraction | (std::uint64_t{1} << 52), biased - 1075, (bits >> 63) != 0};
}

/// hi * 2^64 + lo = a * b.
CDT_HD_INLINE void multiply_words(std::uint64_t a, std::uint64_t b, std::uint64_t& hi, std::uint64_t& lo) {
#if defined(__CUDA_ARCH__)
  lo = a * b;
  hi = __umul64hi(a, b);
#else
  __extension__ typedef unsigned __int128 Word2; // -Wpedantic: the compiler's 128-bit integer
  const Word2 product = static_cast<Word2>(a) * b;
  lo = static_cast<std::uint64_t>(product);
  hi = static_cast<std::uint64_t>(product >> 64);
#endif
}

/// sum += v; returns the carry out (0 or 1).
CDT_HD_INLINE std::uint64_t add_word(std::uint64_t& sum, std::uint64_t v) {
  sum += v;
  return sum < v ? 1u : 0u;
}

/// r[0, 4) = (a_hi * 2^64 + a_lo) * (b_hi * 2^64 + b_lo), for a product below 2^256.
CDT_HD_INLINE void multiply_two_words(std::uint64_t a_hi, std::uint64_t a_lo, std::uint64_t b_hi,
                                      std::uint64_t b_lo, std::uint64_t* r) {
  std::uint64_t h00, l00, h01, l01, h10, l10, h11, l11;
  multiply_words(a_lo, b_lo, h00, l00);
  multiply_words(a_lo, b_hi, h01, l01);
  multiply_words(a_hi, b_lo, h10, l10);
  multiply_words(a_hi, b_hi, h11, l11);
  r[0] = l00;
  r[1] = h00;
  const std::uint64_t carry2 = add_word(r[1], l01) + add_word(r[1], l10);
  r[2] = h01;
  const std::uint64_t carry3 = add_word(r[2], h10) + add_word(r[2], l11) + add_word(r[2], carry2);
  r[3] = h11 + carry3;
}

/// w += v + carry, or w -= v + carry (a borrow) when subtracting; returns the carry or borrow out.
CDT_HD_INLINE std::uint64_t add_with_carry(std::uint64_t& w, std::uint64_t v, std::uint64_t carry,
                                           bool subtract) {
  if (subtract) {
    const std::uint64_t before = w;
    w = before - v - carry;
    return (before < v || (before == v && carry != 0)) ? 1u : 0u;
  }
  return add_word(w, v) + add_word(w, carry);
}

/// The integer path's limit on log2 of the largest coordinate in units of the lowest set bit among them.
inline constexpr int kSmallSpan = 61;

CDT_HD_INLINE int leading_zeros(std::uint64_t v) {
#if defined(__CUDA_ARCH__)
  return __clzll(static_cast<long long>(v));
#else
  return std::countl_zero(v);
#endif
}
CDT_HD_INLINE int trailing_zeros(std::uint64_t v) {
#if defined(__CUDA_ARCH__)
  return __ffsll(static_cast<long long>(v)) - 1;
#else
  return std::countr_zero(v);
#endif
}

/// The N coordinates as integers in units of 2^low, the lowest set bit among them, when every one is
/// finite and below 2^(low + kSmallSpan) in magnitude; false otherwise (zeros fit any unit).
template <int N>
CDT_HD_INLINE bool small_integers(const double* v, std::int64_t* out) {
  int low = 1 << 20, high = -(1 << 20);
  Scaled s[N];
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
  for (int k = 0; k < N; ++k) {
    s[k] = scaled(v[k]);
    if (s[k].e == 972) return false; // infinity or NaN: the wider paths' preconditions, not this one's
    if (s[k].m == 0) continue;
    const int bottom = s[k].e + trailing_zeros(s[k].m);
    const int top = s[k].e + 64 - leading_zeros(s[k].m);
    low = bottom < low ? bottom : low;
    high = top > high ? top : high;
  }
  if (high - low > kSmallSpan) return false;
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
  for (int k = 0; k < N; ++k) {
    // s[k].e >= low - trailing_zeros(m): a right shift drops zeros only.
    const int shift = s[k].e - low;
    const std::uint64_t m = s[k].m == 0 ? 0 : shift >= 0 ? s[k].m << shift : s[k].m >> -shift;
    out[k] = s[k].negative ? -static_cast<std::int64_t>(m) : static_cast<std::int64_t>(m);
  }
  return true;
}

/// A two's-complement integer of 128 bits.
struct Int128 {
  std::uint64_t lo;
  std::uint64_t hi;
};

CDT_HD_INLINE Int128 multiply_signed(std::int64_t a, std::int64_t b) {
#if defined(__CUDA_ARCH__)
  return {static_cast<std::uint64_t>(a) * static_cast<std::uint64_t>(b),
          static_cast<std::uint64_t>(__mul64hi(a, b))};
#else
  __extension__ typedef __int128 Signed2; // -Wpedantic: the compiler's 128-bit integers
  __extension__ typedef unsigned __int128 Word2;
  const auto product = static_cast<Word2>(static_cast<Signed2>(a) * b);
  return {static_cast<std::uint64_t>(product), static_cast<std::uint64_t>(product >> 64)};
#endif
}

CDT_HD_INLINE Int128 add128(Int128 a, Int128 b) {
  const std::uint64_t lo = a.lo + b.lo;
  return {lo, a.hi + b.hi + (lo < a.lo ? 1u : 0u)};
}
CDT_HD_INLINE Int128 subtract128(Int128 a, Int128 b) {
  return {a.lo - b.lo, a.hi - b.hi - (a.lo < b.lo ? 1u : 0u)};
}
CDT_HD_INLINE bool negative128(Int128 a) { return (a.hi >> 63) != 0; }
CDT_HD_INLINE Int128 negate128(Int128 a) { return subtract128({0, 0}, a); }

/// sum += or -= a * b for a, b below 2^127 in magnitude (the magnitudes multiplied, the signs after),
/// in a four-word two's-complement sum.
CDT_HD_INLINE void add_product(std::uint64_t (&sum)[4], Int128 a, Int128 b) {
  const bool subtract = negative128(a) != negative128(b);
  if (negative128(a)) a = negate128(a);
  if (negative128(b)) b = negate128(b);
  std::uint64_t r[4];
  multiply_two_words(a.hi, a.lo, b.hi, b.lo, r);
  std::uint64_t carry = 0; // a borrow when subtracting
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
  for (int k = 0; k < 4; ++k) carry = add_with_carry(sum[k], r[k], carry, subtract);
}

} // namespace integer_detail

// --- predicates ------------------------------------------------------------------------------------

inline constexpr double kEpsilon = 1.1102230246251565e-16; // 2^-53, half an ulp of 1
inline constexpr double kOrientBound = (3.0 + 16.0 * kEpsilon) * kEpsilon;
inline constexpr double kIncircleBound = (10.0 + 96.0 * kEpsilon) * kEpsilon;

/// Exact sign of orient2d by expansion arithmetic, for any finite coordinates whose differences do not
/// overflow: +1 when a, b, c turn counter-clockwise.
CDT_HD inline int orient2d_exact(double ax, double ay, double bx, double by, double cx, double cy) {
  const Expansion<2> acx = exact_diff(ax, cx);
  const Expansion<2> acy = exact_diff(ay, cy);
  const Expansion<2> bcx = exact_diff(bx, cx);
  const Expansion<2> bcy = exact_diff(by, cy);
  Expansion<8> left;
  Expansion<8> right;
  expansion_product(acx, bcy, left);
  expansion_product(acy, bcx, right);
  Expansion<16> det;
  expansion_sum(left, negated(right), det);
  return expansion_sign(det);
}

/// What a filter returns when its error bound cannot decide the sign.
inline constexpr int kUndecided = 2;

/// orient2d's floating-point filter alone: the sign where the error bound decides it, else kUndecided.
CDT_HD_INLINE int orient2d_filter(double ax, double ay, double bx, double by, double cx, double cy) {
  const double det_left = fmul(fsub(ax, cx), fsub(by, cy));
  const double det_right = fmul(fsub(ay, cy), fsub(bx, cx));
  const double det = fsub(det_left, det_right);
  double det_sum;
  if (det_left > 0.0) {
    if (det_right <= 0.0) return (det > 0.0) - (det < 0.0);
    det_sum = fadd(det_left, det_right);
  } else if (det_left < 0.0) {
    if (det_right >= 0.0) return (det > 0.0) - (det < 0.0);
    det_sum = fsub(-det_left, det_right);
  } else {
    return (det > 0.0) - (det < 0.0);
  }
  const double bound = fmul(kOrientBound, det_sum);
  if (det >= bound) return 1;
  if (-det >= bound) return -1;
  return kUndecided;
}

/// Sign of the orientation of (a, b, c): +1 counter-clockwise, -1 clockwise, 0 collinear. Exact.
CDT_HD inline int orient2d(double ax, double ay, double bx, double by, double cx, double cy) {
  const int sign = orient2d_filter(ax, ay, bx, by, cx, cy);
  return sign != kUndecided ? sign : orient2d_exact(ax, ay, bx, by, cx, cy);
}

// --- incircle's exact fallback: products of four doubles in one fixed-point accumulator --------------
//
// Written in the coordinate differences, each an exact two-term expansion (two_diff), incircle's
// determinant is a sum of at most 192 products of four doubles. Each product is formed exactly in
// integers (four significands of 53 bits make at most 212) and added at its binary position to one
// two's-complement accumulator wide enough for any sum of such products of finite doubles: 132 words
// of 64 bits, 1 KiB. Expansion arithmetic needed expansions of up to 1536 doubles here, a 38 KB stack
// frame per thread on the device, which the driver reserves for every thread the device can hold
// (10 GB on the H200 machine) as soon as a kernel with the fallback runs.

namespace incircle_detail {

using integer_detail::add_with_carry;
using integer_detail::multiply_two_words;
using integer_detail::multiply_words;
using integer_detail::scaled;
using integer_detail::Scaled;

/// The accumulator's words: a product of four doubles is m * 2^e with m < 2^212 and e in
/// [4 * -1074, 4 * 971], so its bits lie below 212 + 4 * 971 + 4 * 1074 = 8392 counted from 2^-4296;
/// 192 of them need 8 bits more and the sign one: 8401 bits, 132 words.
inline constexpr int kWords = 132;
inline constexpr int kLowestExponent = 4 * -1074;

/// The exact product of two doubles: (hi * 2^64 + lo) * 2^e, below 2^106 * 2^e.
struct Product2 {
  std::uint64_t hi;
  std::uint64_t lo;
  int e;
  bool negative;
};

CDT_HD_INLINE Product2 product2(double a, double b, bool negate = false) {
  const Scaled x = scaled(a);
  const Scaled y = scaled(b);
  Product2 p;
  multiply_words(x.m, y.m, p.hi, p.lo);
  p.e = x.e + y.e;
  p.negative = (x.negative != y.negative) != negate;
  return p;
}

/// Adds p * q at its binary position. Carries and borrows past the top word are dropped, as
/// two's-complement arithmetic does; the sum itself always fits (kWords).
CDT_HD inline void accumulate(std::uint64_t* words, const Product2& p, const Product2& q) {
  if ((p.hi | p.lo) == 0 || (q.hi | q.lo) == 0) return;
  // 128 x 128 bits; the product is below 2^212, so the top word cannot overflow.
  std::uint64_t r[5];
  multiply_two_words(p.hi, p.lo, q.hi, q.lo, r);
  r[4] = 0;
  const int offset = p.e + q.e - kLowestExponent;
  const int first = offset >> 6;
  const int shift = offset & 63;
  if (shift != 0) {
    for (int k = 4; k > 0; --k) r[k] = (r[k] << shift) | (r[k - 1] >> (64 - shift));
    r[0] <<= shift;
  }
  const bool subtract = p.negative != q.negative;
  std::uint64_t carry = 0; // a borrow when subtracting
  int k = 0;
  for (; k < 5; ++k) carry = add_with_carry(words[first + k], r[k], carry, subtract);
  for (int i = first + k; carry != 0 && i < kWords; ++i) {
    if (subtract) {
      carry = words[i] == 0 ? 1u : 0u;
      --words[i];
    } else {
      ++words[i];
      carry = words[i] == 0 ? 1u : 0u;
    }
  }
}

} // namespace incircle_detail

/// Exact sign of incircle's determinant in the wide accumulator (see incircle_detail): exact for all
/// finite coordinates whose differences do not overflow.
CDT_HD_NOINLINE int incircle_exact_wide(double ax, double ay, double bx, double by, double cx, double cy,
                                        double dx, double dy) {
  using incircle_detail::accumulate;
  using incircle_detail::product2;
  using incircle_detail::Product2;
  // The differences to d, head and tail: diff[p][axis][k] for p = a, b, c.
  double diff[3][2][2];
  const double coords[3][2] = {{ax, ay}, {bx, by}, {cx, cy}};
  for (int p = 0; p < 3; ++p) {
    two_diff(coords[p][0], dx, diff[p][0][0], diff[p][0][1]);
    two_diff(coords[p][1], dy, diff[p][1][0], diff[p][1][1]);
  }
  // det = lift(a) * cross(b, c) + lift(b) * cross(c, a) + lift(c) * cross(a, b), with lift(p) =
  // px^2 + py^2 and cross(q, r) = qx * ry - rx * qy, each spelled out in the differences' terms. The
  // loops stay loops on the device (unroll 1), each term formed where it is added: the fallback is rare,
  // and the registers it would hold unrolled would be the kernel's for every thread.
  std::uint64_t words[incircle_detail::kWords];
  for (std::uint64_t& w : words) w = 0;
#if defined(__CUDA_ARCH__)
#pragma unroll 1
#endif
  for (int p = 0; p < 3; ++p) {
    const int q = p == 2 ? 0 : p + 1;
    const int r = q == 2 ? 0 : q + 1;
#if defined(__CUDA_ARCH__)
#pragma unroll 1
#endif
    for (int l = 0; l < 8; ++l) {
      const int axis = l >> 2;
      const Product2 lift = product2(diff[p][axis][(l >> 1) & 1], diff[p][axis][l & 1]);
#if defined(__CUDA_ARCH__)
#pragma unroll 1
#endif
      for (int c = 0; c < 8; ++c) {
        const int i = (c >> 1) & 1, j = c & 1;
        const Product2 cross =
            c < 4 ? product2(diff[q][0][i], diff[r][1][j]) : product2(diff[r][0][i], diff[q][1][j], true);
        accumulate(words, lift, cross);
      }
    }
  }
  if ((words[incircle_detail::kWords - 1] >> 63) != 0) return -1;
  for (const std::uint64_t w : words)
    if (w != 0) return 1;
  return 0;
}

namespace incircle_detail {

/// incircle's exact sign by the integer path (see integer_detail): true and the sign in `sign` when the
/// coordinates fit it (small_integers), false otherwise. The differences are below 2^62 in magnitude,
/// the lifts and crosses below 2^125, each lift times cross below 2^250 and their sum below 2^252.
CDT_HD_INLINE bool small_sign(double ax, double ay, double bx, double by, double cx, double cy, double dx,
                              double dy, int& sign) {
  using namespace integer_detail;
  const double coords[8] = {ax, ay, bx, by, cx, cy, dx, dy};
  std::int64_t v[8];
  if (!small_integers<8>(coords, v)) return false;
  const std::int64_t adx = v[0] - v[6], ady = v[1] - v[7];
  const std::int64_t bdx = v[2] - v[6], bdy = v[3] - v[7];
  const std::int64_t cdx = v[4] - v[6], cdy = v[5] - v[7];
  // det = lift(a) * cross(b, c) + lift(b) * cross(c, a) + lift(c) * cross(a, b), as in the wide path.
  const Int128 alift = add128(multiply_signed(adx, adx), multiply_signed(ady, ady));
  const Int128 blift = add128(multiply_signed(bdx, bdx), multiply_signed(bdy, bdy));
  const Int128 clift = add128(multiply_signed(cdx, cdx), multiply_signed(cdy, cdy));
  const Int128 bc = subtract128(multiply_signed(bdx, cdy), multiply_signed(cdx, bdy));
  const Int128 ca = subtract128(multiply_signed(cdx, ady), multiply_signed(adx, cdy));
  const Int128 ab = subtract128(multiply_signed(adx, bdy), multiply_signed(bdx, ady));
  std::uint64_t det[4] = {0, 0, 0, 0};
  add_product(det, alift, bc);
  add_product(det, blift, ca);
  add_product(det, clift, ab);
  if ((det[3] >> 63) != 0)
    sign = -1;
  else
    sign = (det[0] | det[1] | det[2] | det[3]) != 0 ? 1 : 0;
  return true;
}

} // namespace incircle_detail

/// Exact sign of incircle's determinant: the integer path where the coordinates fit it, else the wide
/// accumulator. Exact for all finite coordinates whose differences do not overflow.
CDT_HD_NOINLINE int incircle_exact(double ax, double ay, double bx, double by, double cx, double cy,
                                   double dx, double dy) {
  int sign;
  if (incircle_detail::small_sign(ax, ay, bx, by, cx, cy, dx, dy, sign)) return sign;
  return incircle_exact_wide(ax, ay, bx, by, cx, cy, dx, dy);
}

/// Sign of incircle: +1 when d lies strictly inside the circle through the counter-clockwise triangle
/// (a, b, c), -1 strictly outside, 0 on it (the sign flips for a clockwise triangle). Exact.
/// Whether v * scale (scale a power of two) is an integer of magnitude below 2^52.
CDT_HD_INLINE bool scaled_integer(double v, double scale) {
  const double t = fmul(v, scale);
  return fabs_(t) < 4503599627370496.0 && t == static_cast<double>(static_cast<long long>(t));
}

/// Whether incircle's floating-point determinant is exact: every coordinate times scale (a power of two)
/// is an integer below 2^52, so the differences are exact integers (in units of 1/scale), and each
/// difference is at most 5200 units, so that every product and sum of the determinant is an integer
/// below 12 * 5200^4 < 2^53, exact in double arithmetic. Pixel-lattice points (half-integers, scale 2)
/// are such coordinates; their cocircular quadruples are exactly where the filter cannot decide.
CDT_HD_INLINE bool incircle_is_exact_in_double(const double* c, const double* d, double scale) {
  constexpr double kLimit = 5200.0;
  for (int k = 0; k < 8; ++k)
    if (!scaled_integer(c[k], scale)) return false;
  for (int k = 0; k < 6; ++k)
    if (fabs_(fmul(d[k], scale)) > kLimit) return false;
  return true;
}

/// incircle's floating-point filter: its determinant, and the sign where the error bound decides it,
/// else kUndecided.
CDT_HD_INLINE int incircle_filter(double ax, double ay, double bx, double by, double cx, double cy, double dx,
                                  double dy, double& det) {
  const double adx = fsub(ax, dx);
  const double bdx = fsub(bx, dx);
  const double cdx = fsub(cx, dx);
  const double ady = fsub(ay, dy);
  const double bdy = fsub(by, dy);
  const double cdy = fsub(cy, dy);

  const double bdxcdy = fmul(bdx, cdy);
  const double cdxbdy = fmul(cdx, bdy);
  const double alift = fadd(fmul(adx, adx), fmul(ady, ady));
  const double cdxady = fmul(cdx, ady);
  const double adxcdy = fmul(adx, cdy);
  const double blift = fadd(fmul(bdx, bdx), fmul(bdy, bdy));
  const double adxbdy = fmul(adx, bdy);
  const double bdxady = fmul(bdx, ady);
  const double clift = fadd(fmul(cdx, cdx), fmul(cdy, cdy));

  det = fadd(fadd(fmul(alift, fsub(bdxcdy, cdxbdy)), fmul(blift, fsub(cdxady, adxcdy))),
             fmul(clift, fsub(adxbdy, bdxady)));
  const double permanent = fadd(
      fadd(fmul(fadd(fabs_(bdxcdy), fabs_(cdxbdy)), alift), fmul(fadd(fabs_(cdxady), fabs_(adxcdy)), blift)),
      fmul(fadd(fabs_(adxbdy), fabs_(bdxady)), clift));
  const double bound = fmul(kIncircleBound, permanent);
  if (det > bound) return 1;
  if (-det > bound) return -1;
  return kUndecided;
}

CDT_HD inline int incircle(double ax, double ay, double bx, double by, double cx, double cy, double dx,
                           double dy) {
  double det;
  const int sign = incircle_filter(ax, ay, bx, by, cx, cy, dx, dy, det);
  if (sign != kUndecided) return sign;
  // Undecided: degenerate or nearly so. On a fine lattice the determinant above was exact.
  const double coords[8] = {ax, ay, bx, by, cx, cy, dx, dy};
  const double diffs[6] = {fsub(ax, dx), fsub(ay, dy), fsub(bx, dx),
                           fsub(by, dy), fsub(cx, dx), fsub(cy, dy)};
  if (incircle_is_exact_in_double(coords, diffs, 2.0) || incircle_is_exact_in_double(coords, diffs, 16.0))
    return (det > 0.0) - (det < 0.0);
  return incircle_exact(ax, ay, bx, by, cx, cy, dx, dy);
}

/// Whether (ax, ay) comes before (bx, by) in lexicographic order: x first, then y.
CDT_HD_INLINE bool lexicographically_less(double ax, double ay, double bx, double by) {
  return ax < bx || (ax == bx && ay < by);
}

/// incircle with its zeros decided by a symbolic perturbation, so that among co-circular points one
/// triangulation is the Delaunay one (Edelsbrunner and Muecke's Simulation of Simplicity applied to
/// the lifting map). Each point's lift x^2 + y^2 is raised by eps^r, r its rank in lexicographic
/// order (the first point is raised the most), for an infinitesimal eps > 0. The determinant is linear
/// in each lift, so for four points on a circle its sign is that of the raised point's cofactor, which
/// is the orientation of the other three (never zero: no three distinct points of a circle are
/// collinear). One lifting for every quadruple: the flips it asks for end, and the constrained Delaunay
/// triangulation under it is unique, whatever order the flips ran in, on the host or on the device.
/// Nonzero for four distinct points with a, b, c not collinear; the same as incircle elsewhere.
CDT_HD inline int incircle_perturbed(double ax, double ay, double bx, double by, double cx, double cy,
                                     double dx, double dy) {
  const int sign = incircle(ax, ay, bx, by, cx, cy, dx, dy);
  if (sign != 0) return sign;
  // The first of the four in lexicographic order, and its cofactor's sign.
  int first = 0;
  double fx = ax;
  double fy = ay;
  if (lexicographically_less(bx, by, fx, fy)) first = 1, fx = bx, fy = by;
  if (lexicographically_less(cx, cy, fx, fy)) first = 2, fx = cx, fy = cy;
  if (lexicographically_less(dx, dy, fx, fy)) first = 3;
  switch (first) {
  case 0:
    return orient2d(dx, dy, bx, by, cx, cy);
  case 1:
    return orient2d(ax, ay, dx, dy, cx, cy);
  case 2:
    return orient2d(ax, ay, bx, by, dx, dy);
  default:
    return -orient2d(ax, ay, bx, by, cx, cy);
  }
}

} // namespace cdt::detail
