#pragma once
// Lanes of floats and doubles for the bundle kernels (bundle_traversal.hpp's box test,
// ray_sphere_bundle.hpp's sphere test): the widest registers the build targets, with just the operations
// those kernels use, each one instruction. A kernel is written once over these types; with AVX-512 a
// register holds 16 floats or 8 doubles, with AVX2 8 or 4, and without AVX2 there are no lanes
// (SMOKETRACE_SIMD_LANES is not defined) and the kernels fall back to their scalar loops.
//
// Every operation is the IEEE operation of each lane, in the order the kernel writes it (the build
// disables FMA contraction, CMakeLists.txt), so a kernel gives every lane bit for bit what the scalar
// code computes. max / min are maxps / minps: where either operand is NaN they return the second.
//
// With AVX-512, the conversions and sqrt use their maskz forms with every lane set: the plain forms trip
// GCC 12's false -Wmaybe-uninitialized on their undefined pass-through operand (GCC bug 105593); they
// compile to the same instructions.
#if defined(__AVX512F__) && defined(__AVX512DQ__)
#define SMOKETRACE_SIMD_LANES 512
#elif defined(__AVX2__)
#define SMOKETRACE_SIMD_LANES 256
#endif

#if defined(SMOKETRACE_SIMD_LANES)
#include <immintrin.h>

namespace smoketrace::simd {

#if SMOKETRACE_SIMD_LANES == 512
inline constexpr unsigned kFloatLanes = 16;
inline constexpr unsigned kDoubleLanes = 8;
struct Floats {
    __m512 v;
};
struct Doubles {
    __m512d v;
};
struct DoubleMask {  // a comparison's result, lane by lane
    __mmask8 k;
};

[[gnu::always_inline]] inline Floats load(const float* p) { return {_mm512_load_ps(p)}; }  // 64-byte aligned
[[gnu::always_inline]] inline Floats broadcast(float x) { return {_mm512_set1_ps(x)}; }
[[gnu::always_inline]] inline Floats operator-(Floats a, Floats b) { return {_mm512_sub_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats operator*(Floats a, Floats b) { return {_mm512_mul_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats max(Floats a, Floats b) {
    return {_mm512_maskz_max_ps(__mmask16(0xFFFF), a.v, b.v)};
}
[[gnu::always_inline]] inline Floats min(Floats a, Floats b) {
    return {_mm512_maskz_min_ps(__mmask16(0xFFFF), a.v, b.v)};
}
// Bit i set where a_i <= b_i (false for NaN).
[[gnu::always_inline]] inline unsigned less_equal_bits(Floats a, Floats b) {
    return unsigned(_mm512_cmp_ps_mask(a.v, b.v, _CMP_LE_OQ));
}

// kDoubleLanes floats from p (aligned to their size), each widened exactly to double.
[[gnu::always_inline]] inline Doubles widen(const float* p) {
    return {_mm512_maskz_cvtps_pd(__mmask8(0xFF), _mm256_load_ps(p))};
}
[[gnu::always_inline]] inline Doubles broadcast(double x) { return {_mm512_set1_pd(x)}; }
[[gnu::always_inline]] inline Doubles operator+(Doubles a, Doubles b) { return {_mm512_add_pd(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles operator-(Doubles a, Doubles b) { return {_mm512_sub_pd(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles operator*(Doubles a, Doubles b) { return {_mm512_mul_pd(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles operator/(Doubles a, Doubles b) { return {_mm512_div_pd(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles sqrt(Doubles a) { return {_mm512_maskz_sqrt_pd(__mmask8(0xFF), a.v)}; }
[[gnu::always_inline]] inline Doubles operator-(Doubles a) { return {_mm512_xor_pd(a.v, _mm512_set1_pd(-0.0))}; }
[[gnu::always_inline]] inline Doubles abs(Doubles a) { return {_mm512_andnot_pd(_mm512_set1_pd(-0.0), a.v)}; }
// |magnitude| with the sign bit of `sign`.
[[gnu::always_inline]] inline Doubles copysign(Doubles magnitude, Doubles sign) {
    const __m512d s = _mm512_set1_pd(-0.0);
    return {_mm512_or_pd(_mm512_andnot_pd(s, magnitude.v), _mm512_and_pd(s, sign.v))};
}
[[gnu::always_inline]] inline DoubleMask operator>(Doubles a, Doubles b) {
    return {_mm512_cmp_pd_mask(a.v, b.v, _CMP_GT_OQ)};
}
[[gnu::always_inline]] inline DoubleMask operator<(Doubles a, Doubles b) {
    return {_mm512_cmp_pd_mask(a.v, b.v, _CMP_LT_OQ)};
}
[[gnu::always_inline]] inline DoubleMask operator&(DoubleMask a, DoubleMask b) { return {__mmask8(a.k & b.k)}; }
[[gnu::always_inline]] inline unsigned bits(DoubleMask m) { return m.k; }
// Lane by lane: `if_set` where m is set, else `if_clear`.
[[gnu::always_inline]] inline Doubles select(DoubleMask m, Doubles if_set, Doubles if_clear) {
    return {_mm512_mask_blend_pd(m.k, if_clear.v, if_set.v)};
}
[[gnu::always_inline]] inline void store(double* p, Doubles a) { _mm512_store_pd(p, a.v); }  // 64-byte aligned
// Bit i set where t_i, rounded to float (to nearest, as static_cast<float>), lies in [lo_i, hi_i].
[[gnu::always_inline]] inline unsigned in_float_range_bits(Doubles t, const float* lo, const float* hi) {
    const __m256 tf = _mm512_maskz_cvtpd_ps(__mmask8(0xFF), t.v);
    return unsigned(_mm256_movemask_ps(_mm256_and_ps(_mm256_cmp_ps(tf, _mm256_load_ps(lo), _CMP_GE_OQ),
                                                     _mm256_cmp_ps(tf, _mm256_load_ps(hi), _CMP_LE_OQ))));
}

#else  // AVX2
inline constexpr unsigned kFloatLanes = 8;
inline constexpr unsigned kDoubleLanes = 4;
struct Floats {
    __m256 v;
};
struct Doubles {
    __m256d v;
};
struct DoubleMask {  // all ones in a lane where the comparison holds
    __m256d m;
};

[[gnu::always_inline]] inline Floats load(const float* p) { return {_mm256_load_ps(p)}; }  // 32-byte aligned
[[gnu::always_inline]] inline Floats broadcast(float x) { return {_mm256_set1_ps(x)}; }
[[gnu::always_inline]] inline Floats operator-(Floats a, Floats b) { return {_mm256_sub_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats operator*(Floats a, Floats b) { return {_mm256_mul_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats max(Floats a, Floats b) { return {_mm256_max_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats min(Floats a, Floats b) { return {_mm256_min_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline unsigned less_equal_bits(Floats a, Floats b) {
    return unsigned(_mm256_movemask_ps(_mm256_cmp_ps(a.v, b.v, _CMP_LE_OQ)));
}

[[gnu::always_inline]] inline Doubles widen(const float* p) { return {_mm256_cvtps_pd(_mm_load_ps(p))}; }
[[gnu::always_inline]] inline Doubles broadcast(double x) { return {_mm256_set1_pd(x)}; }
[[gnu::always_inline]] inline Doubles operator+(Doubles a, Doubles b) { return {_mm256_add_pd(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles operator-(Doubles a, Doubles b) { return {_mm256_sub_pd(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles operator*(Doubles a, Doubles b) { return {_mm256_mul_pd(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles operator/(Doubles a, Doubles b) { return {_mm256_div_pd(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles sqrt(Doubles a) { return {_mm256_sqrt_pd(a.v)}; }
[[gnu::always_inline]] inline Doubles operator-(Doubles a) { return {_mm256_xor_pd(a.v, _mm256_set1_pd(-0.0))}; }
[[gnu::always_inline]] inline Doubles abs(Doubles a) { return {_mm256_andnot_pd(_mm256_set1_pd(-0.0), a.v)}; }
[[gnu::always_inline]] inline Doubles copysign(Doubles magnitude, Doubles sign) {
    const __m256d s = _mm256_set1_pd(-0.0);
    return {_mm256_or_pd(_mm256_andnot_pd(s, magnitude.v), _mm256_and_pd(s, sign.v))};
}
[[gnu::always_inline]] inline DoubleMask operator>(Doubles a, Doubles b) {
    return {_mm256_cmp_pd(a.v, b.v, _CMP_GT_OQ)};
}
[[gnu::always_inline]] inline DoubleMask operator<(Doubles a, Doubles b) {
    return {_mm256_cmp_pd(a.v, b.v, _CMP_LT_OQ)};
}
[[gnu::always_inline]] inline DoubleMask operator&(DoubleMask a, DoubleMask b) { return {_mm256_and_pd(a.m, b.m)}; }
[[gnu::always_inline]] inline unsigned bits(DoubleMask m) { return unsigned(_mm256_movemask_pd(m.m)); }
[[gnu::always_inline]] inline Doubles select(DoubleMask m, Doubles if_set, Doubles if_clear) {
    return {_mm256_blendv_pd(if_clear.v, if_set.v, m.m)};
}
[[gnu::always_inline]] inline void store(double* p, Doubles a) { _mm256_store_pd(p, a.v); }  // 32-byte aligned
[[gnu::always_inline]] inline unsigned in_float_range_bits(Doubles t, const float* lo, const float* hi) {
    const __m128 tf = _mm256_cvtpd_ps(t.v);
    return unsigned(_mm_movemask_ps(
        _mm_and_ps(_mm_cmp_ps(tf, _mm_load_ps(lo), _CMP_GE_OQ), _mm_cmp_ps(tf, _mm_load_ps(hi), _CMP_LE_OQ))));
}
#endif

}  // namespace smoketrace::simd
#endif  // SMOKETRACE_SIMD_LANES
