#pragma once
// The two transcendental functions the smooth density kernels integrate with (smoke/density_kernel.hpp),
// written once over Doubles<N> (lanes.hpp) from the lanes' IEEE operations alone, so that every width gives
// the bits of width 1, its scalar twin (docs/simd.md):
//
//   exp_negative(x) = e^{−x} for 0 <= x <= kExpNegativeMax, relative error below kExpNegativeMaxError;
//   erf(x), every double x,                                absolute error below kErfMaxError.
//
// Both are polynomials and one division: no table, no integer tricks on the exponent bits (the lanes have
// none), no branch on the data.
#include <smoketrace/core/simd/lanes.hpp>

namespace smoketrace::simd {

// e^{−x} = (e^{−x/64})^64: the degree-10 Taylor polynomial of e^{−y} at y = x/64 <= 1/4 (remainder below
// y^11/11! = 6·10^-15 relative), squared six times (each doubles the relative error: 64 · 6·10^-15, plus the
// roundings, ~64 · 2^-52 · a few). x outside [0, kExpNegativeMax] is the caller's to avoid.
inline constexpr double kExpNegativeMax = 16.0;
inline constexpr double kExpNegativeMaxError = 1e-12;  // relative; measured 4.9·10^-13 (test_special_functions.cpp)

template <unsigned N>
[[gnu::always_inline]] inline Doubles<N> exp_negative(const Doubles<N>& x) {
    using D = Doubles<N>;
    const D y = x * D::broadcast(1.0 / 64.0);  // exact: a power of two
    // Horner, 1/0! − y (1/1! − y (1/2! − …)): at y <= 1/4 the terms fall by 4k, so the alternating sum
    // cancels little (its value is >= e^{-1/4} = 0.78).
    constexpr double kInverseFactorials[] = {1.0,        1.0,          1.0 / 2,     1.0 / 6,
                                             1.0 / 24,   1.0 / 120,    1.0 / 720,   1.0 / 5040,
                                             1.0 / 40320, 1.0 / 362880, 1.0 / 3628800};  // 1/k!, k = 0 … 10
    D p = D::broadcast(kInverseFactorials[10]);
    for (int k = 9; k >= 0; --k) p = D::broadcast(kInverseFactorials[k]) - y * p;
    for (int k = 0; k < 6; ++k) p = p * p;
    return p;
}

// erf by Abramowitz & Stegun 7.1.26 (Hastings' approximation), |error| <= 1.5·10^-7 for x >= 0:
//     erf(x) = 1 − (a1 t + a2 t² + a3 t³ + a4 t⁴ + a5 t⁵) e^{−x²},  t = 1 / (1 + p x),
// odd by construction (computed at |x|, the sign put back), so erf(s) − erf(−s) is exactly 2 erf(s). Beyond
// |x| = 4 the factor e^{−x²} is taken at 16 (1 − erf(4) = 1.5·10^-8, and the polynomial there is below 0.07:
// the error stays under 10^-8), which keeps exp_negative() in its range for every x, infinities included;
// a NaN gives a NaN.
inline constexpr double kErfMaxError = 1.5e-7;  // absolute; A&S's bound; measured 1.39·10^-7 (at x = 0.045)

// A&S 7.1.26's polynomial P(t) = a1 t + … + a5 t⁵ at t = 1 / (1 + p|x|): erf(|x|) = 1 − P · e^{−x²}. Apart
// from erf(), so that a caller whose e^{−x²} is a product it knows (the Gaussian kernel's) need not take it.
template <unsigned N>
[[gnu::always_inline]] inline Doubles<N> erf_tail_polynomial(const Doubles<N>& x) {
    using D = Doubles<N>;
    const D one = D::broadcast(1.0);
    const D t = one / (one + D::broadcast(0.3275911) * abs(x));
    D poly = D::broadcast(1.061405429);
    poly = poly * t + D::broadcast(-1.453152027);
    poly = poly * t + D::broadcast(1.421413741);
    poly = poly * t + D::broadcast(-0.284496736);
    poly = poly * t + D::broadcast(0.254829592);
    return poly * t;
}

template <unsigned N>
[[gnu::always_inline]] inline Doubles<N> erf(const Doubles<N>& x) {
    using D = Doubles<N>;
    const D x2 = x * x;
    const D capped = select(x2 > D::broadcast(kExpNegativeMax), D::broadcast(kExpNegativeMax), x2);
    return copysign(D::broadcast(1.0) - erf_tail_polynomial(x) * exp_negative(capped), x);
}

}  // namespace smoketrace::simd
