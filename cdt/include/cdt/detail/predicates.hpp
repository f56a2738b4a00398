#pragma once
// Exact geometric predicates orient2d and incircle for double coordinates.
//
// A floating-point filter with a proven error bound answers almost every call; when it cannot decide,
// the determinant is evaluated exactly with floating-point expansion arithmetic (sums of
// non-overlapping doubles, after Shewchuk, "Adaptive Precision Floating-Point Arithmetic and Fast
// Robust Geometric Predicates", 1997). The same code runs on the host and on the device.
//
// Error-free transformations need every operation rounded exactly once, so fused multiply-add must
// not be introduced by the compiler: on the device the arithmetic goes through the __d*_rn
// intrinsics, which are never contracted; on the host the cdt target compiles with
// -ffp-contract=off (see cdt/CMakeLists.txt). The one deliberate fma is the device's two-product.
//
// Preconditions: finite coordinates whose magnitude stays below about 1e60 (no overflow of the
// fourth powers in incircle) and differences that do not underflow.

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

// --- predicates ------------------------------------------------------------------------------------

inline constexpr double kEpsilon = 1.1102230246251565e-16; // 2^-53, half an ulp of 1
inline constexpr double kOrientBound = (3.0 + 16.0 * kEpsilon) * kEpsilon;
inline constexpr double kIncircleBound = (10.0 + 96.0 * kEpsilon) * kEpsilon;

/// Exact sign of orient2d by expansion arithmetic: +1 when a, b, c turn counter-clockwise.
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

/// Sign of the orientation of (a, b, c): +1 counter-clockwise, -1 clockwise, 0 collinear. Exact.
CDT_HD inline int orient2d(double ax, double ay, double bx, double by, double cx, double cy) {
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
  return orient2d_exact(ax, ay, bx, by, cx, cy);
}

/// Exact sign of incircle by expansion arithmetic.
CDT_HD inline int incircle_exact(double ax, double ay, double bx, double by, double cx, double cy, double dx,
                                 double dy) {
  const Expansion<2> adx = exact_diff(ax, dx);
  const Expansion<2> ady = exact_diff(ay, dy);
  const Expansion<2> bdx = exact_diff(bx, dx);
  const Expansion<2> bdy = exact_diff(by, dy);
  const Expansion<2> cdx = exact_diff(cx, dx);
  const Expansion<2> cdy = exact_diff(cy, dy);

  // Cross terms (each at most 16 components) and lifts (each at most 16 components).
  const auto cross = [](const Expansion<2>& px, const Expansion<2>& py, const Expansion<2>& qx,
                        const Expansion<2>& qy, Expansion<16>& out) {
    Expansion<8> l;
    Expansion<8> r;
    expansion_product(px, qy, l);
    expansion_product(qx, py, r);
    expansion_sum(l, negated(r), out);
  };
  const auto lift = [](const Expansion<2>& px, const Expansion<2>& py, Expansion<16>& out) {
    Expansion<8> xx;
    Expansion<8> yy;
    expansion_product(px, px, xx);
    expansion_product(py, py, yy);
    expansion_sum(xx, yy, out);
  };
  Expansion<16> bc;
  Expansion<16> ca;
  Expansion<16> ab;
  cross(bdx, bdy, cdx, cdy, bc);
  cross(cdx, cdy, adx, ady, ca);
  cross(adx, ady, bdx, bdy, ab);
  Expansion<16> alift;
  Expansion<16> blift;
  Expansion<16> clift;
  lift(adx, ady, alift);
  lift(bdx, bdy, blift);
  lift(cdx, cdy, clift);

  Expansion<512> ta;
  Expansion<512> tb;
  Expansion<512> tc;
  expansion_product(alift, bc, ta);
  expansion_product(blift, ca, tb);
  expansion_product(clift, ab, tc);
  Expansion<1024> tab;
  expansion_sum(ta, tb, tab);
  Expansion<1536> det;
  expansion_sum(tab, tc, det);
  return expansion_sign(det);
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

CDT_HD inline int incircle(double ax, double ay, double bx, double by, double cx, double cy, double dx,
                           double dy) {
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

  const double det = fadd(fadd(fmul(alift, fsub(bdxcdy, cdxbdy)), fmul(blift, fsub(cdxady, adxcdy))),
                          fmul(clift, fsub(adxbdy, bdxady)));
  const double permanent = fadd(
      fadd(fmul(fadd(fabs_(bdxcdy), fabs_(cdxbdy)), alift), fmul(fadd(fabs_(cdxady), fabs_(adxcdy)), blift)),
      fmul(fadd(fabs_(adxbdy), fabs_(bdxady)), clift));
  const double bound = fmul(kIncircleBound, permanent);
  if (det > bound) return 1;
  if (-det > bound) return -1;
  // Undecided: degenerate or nearly so. On a fine lattice the determinant above was exact.
  const double coords[8] = {ax, ay, bx, by, cx, cy, dx, dy};
  const double diffs[6] = {adx, ady, bdx, bdy, cdx, cdy};
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
