// sin and cos of every joint angle, two at a time. One glibc sincos call per joint was 35 % of
// forward kinematics (perf): each call reduces its argument with branches and returns through
// memory, and the calls do not overlap. Joint angles are small (|q| ≲ 2π), where fdlibm's
// medium-range reduction and its kernels need no branch, so both lanes of a 2-wide vector (SSE2 on
// x86-64, without -march) run them side by side: the same formulas as glibc's and fdlibm's, within
// 1 ulp of the true value. Outside the range (|q| ≥ 2^19, ±∞, NaN) the pair goes to glibc.
#pragma once

#include <cmath>
#include <cstdint>

#include "core/lie/types.hpp"

namespace chasles {

/// sin θ and cos θ from one call: glibc's sincos shares the argument reduction. (GCC merges a sin
/// and a cos of the same θ into it only where it sees both in one block.)
CHASLES_ALWAYS_INLINE void sin_cos(double theta, double& s, double& c) {
#if defined(__GLIBC__)
  ::sincos(theta, &s, &c);
#else
  s = std::sin(theta);
  c = std::cos(theta);
#endif
}

namespace detail {

// GCC/Clang vector extensions: two lanes, one SSE2 register on x86-64, plain scalars elsewhere.
using Double2 = double __attribute__((vector_size(16)));
using Int2 = int64_t __attribute__((vector_size(16)));

// The same bits seen as the other type (GCC and Clang reinterpret a cast between vector types of
// one size).
CHASLES_ALWAYS_INLINE Int2 bits_of(Double2 x) { return (Int2)x; }
CHASLES_ALWAYS_INLINE Double2 double_of(Int2 x) { return (Double2)x; }

// The largest |θ| the branch-free reduction takes: below 2^19, n = round(θ 2/π) < 2^20, so n times
// the 33-bit head of π/2 is exact (fdlibm's medium case).
inline constexpr double kSinCosReductionLimit = 524288.0;

// The constants in pairs, read through a pointer the compiler cannot see through: a pair of a
// constant it knows GCC builds at every use from a scalar load and a shuffle (SSE2 has no
// broadcast), about 40 instructions per pair of angles; a pair it must load it loads whole, or
// takes as the operand of the multiplication (FK 5 % fewer instructions).
struct SinCosConstants {
  // fdlibm's __kernel_sin and __kernel_cos (FreeBSD k_sin.c, k_cos.c): degree 13 and 14.
  Double2 S1, S2, S3, S4, S5, S6, C1, C2, C3, C4, C5, C6;
  Double2 two_over_pi, pio2_head, pio2_mid, pio2_tail, round, half, one;
};

#define CHASLES_PAIR(x) \
  { x, x }
alignas(16) inline constexpr SinCosConstants kSinCosConstants = {
    CHASLES_PAIR(-1.66666666666666324348e-01), CHASLES_PAIR(8.33333333332248946124e-03),
    CHASLES_PAIR(-1.98412698298579493134e-04), CHASLES_PAIR(2.75573137070700676789e-06),
    CHASLES_PAIR(-2.50507602534068634195e-08), CHASLES_PAIR(1.58969099521155010221e-10),
    CHASLES_PAIR(4.16666666666666019037e-02),  CHASLES_PAIR(-1.38888888888741095749e-03),
    CHASLES_PAIR(2.48015872894767294178e-05),  CHASLES_PAIR(-2.75573143513906633035e-07),
    CHASLES_PAIR(2.08757232129817482790e-09),  CHASLES_PAIR(-1.13596475577881948265e-11),
    CHASLES_PAIR(6.36619772367581382433e-01),  // 2/π
    CHASLES_PAIR(1.57079632673412561417e+00),  // π/2's first 33 bits
    CHASLES_PAIR(6.07710050630396597660e-11),  // its next 33
    CHASLES_PAIR(2.02226624879595063154e-21),  // the rest, to 53 bits
    CHASLES_PAIR(6755399441055744.0),          // 1.5 · 2^52
    CHASLES_PAIR(0.5),
    CHASLES_PAIR(1.0)};
#undef CHASLES_PAIR

CHASLES_ALWAYS_INLINE const SinCosConstants& sin_cos_constants() {
  const SinCosConstants* k = &kSinCosConstants;
  asm("" : "+r"(k));  // hides the values, not the loads
  return *k;
}

// sin(x + y) and cos(x + y) for |x + y| ≤ π/4, y a tail below ulp(x).
CHASLES_ALWAYS_INLINE Double2 kernel_sin(const SinCosConstants& k, Double2 x, Double2 y) {
  const Double2 z = x * x;
  const Double2 v = z * x;
  const Double2 r = k.S2 + z * (k.S3 + z * (k.S4 + z * (k.S5 + z * k.S6)));
  return x - ((z * (k.half * y - v * r) - y) - v * k.S1);
}

CHASLES_ALWAYS_INLINE Double2 kernel_cos(const SinCosConstants& k, Double2 x, Double2 y) {
  const Double2 z = x * x;
  const Double2 r = z * (k.C1 + z * (k.C2 + z * (k.C3 + z * (k.C4 + z * (k.C5 + z * k.C6)))));
  const Double2 hz = k.half * z;
  const Double2 w = k.one - hz;
  // 1 − z/2 rounded, and what the rounding lost, so that the sum keeps the last bit.
  return w + (((k.one - w) - hz) + (z * r - x * y));
}

// sin and cos of both lanes of θ, each |θ| < kSinCosReductionLimit.
CHASLES_ALWAYS_INLINE void sin_cos_reduced(Double2 theta, Double2& s, Double2& c) {
  // n = round(θ 2/π), by adding and taking away 1.5·2^52 (round to nearest; n's low bits are then
  // the low bits of the sum's mantissa), and r = θ − n π/2 with π/2 in three parts (33 + 33 + 53
  // bits), as fdlibm's __ieee754_rem_pio2 for |θ| < 2^20 π/2: the first two products are exact,
  // the first difference too (Sterbenz), and the second difference's rounding error goes into the
  // tail.
  const SinCosConstants& k = sin_cos_constants();
  const Double2 shifted = theta * k.two_over_pi + k.round;
  const Double2 n = shifted - k.round;
  const Int2 quadrant = bits_of(shifted);
  const Double2 r1 = theta - n * k.pio2_head;
  const Double2 w1 = n * k.pio2_mid;
  const Double2 r2 = r1 - w1;
  const Double2 w2 = n * k.pio2_tail - ((r1 - r2) - w1);
  // r + y = r2 − w2 as a head and a tail below half its ulp, as the kernels take it.
  const Double2 r = r2 - w2;
  const Double2 y = (r2 - r) - w2;
  const Double2 sin_r = kernel_sin(k, r, y);
  const Double2 cos_r = kernel_cos(k, r, y);
  // θ = r + n π/2: quadrant 0 (s, c), 1 (c, −s), 2 (−s, −c), 3 (−c, s).
  // The mask of odd quadrants from 32-bit lanes (SSE2 compares 64-bit lanes only by emulation,
  // which GCC writes as branches): each low half compared, then copied into its high half.
  using Int4 = int32_t __attribute__((vector_size(16)));
  const Int4 odd_low = ((Int4)quadrant & Int4{1, 0, 1, 0}) != Int4{0, 0, 0, 0};
#if defined(__clang__)
  const Int2 odd = (Int2)__builtin_shufflevector(odd_low, odd_low, 0, 0, 2, 2);
#else
  const Int2 odd = (Int2)__builtin_shuffle(odd_low, Int4{0, 0, 2, 2});
#endif
  const Int2 s_abs = (odd & bits_of(cos_r)) | (~odd & bits_of(sin_r));
  const Int2 c_abs = (odd & bits_of(sin_r)) | (~odd & bits_of(cos_r));
  const Int2 s_sign = (quadrant & 2) << 62;
  const Int2 c_sign = ((quadrant + 1) & 2) << 62;
  s = double_of(s_abs ^ s_sign);
  c = double_of(c_abs ^ c_sign);
}

}  // namespace detail

/// s_i = sin θ_i and c_i = cos θ_i for i < n, two at a time; the same values as sin_cos within
/// 1 ulp.
CHASLES_ALWAYS_INLINE void sin_cos(const double* theta, int n, double* s, double* c) {
  for (int i = 0; i < n; i += 2) {
    const bool pair = i + 1 < n;
    const double a = theta[i], b = pair ? theta[i + 1] : 0.0;
    if (!(std::abs(a) < detail::kSinCosReductionLimit && std::abs(b) < detail::kSinCosReductionLimit)) {
      sin_cos(a, s[i], c[i]);
      if (pair) sin_cos(b, s[i + 1], c[i + 1]);
      continue;
    }
    detail::Double2 s2, c2;
    detail::sin_cos_reduced(detail::Double2{a, b}, s2, c2);
    s[i] = s2[0];
    c[i] = c2[0];
    if (pair) {
      s[i + 1] = s2[1];
      c[i + 1] = c2[1];
    }
  }
}

}  // namespace chasles
