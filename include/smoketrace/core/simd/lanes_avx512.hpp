#pragma once
// The AVX-512 lanes (F and DQ): sixteen floats, eight doubles, sixteen 32-bit integers in a 512-bit
// register; masks are mask registers, a bit per lane. Each operation is one instruction (or a few) with
// the bits of its definition in lanes_scalar.hpp. Include lanes.hpp, not this file.
//
// The conversions, sqrt, max and min use their maskz forms with every lane set: the plain forms trip
// GCC 12's false -Wmaybe-uninitialized on their undefined pass-through operand (GCC bug 105593); they
// compile to the same instructions.
#include <smoketrace/core/simd/isa.hpp>
#include <smoketrace/core/simd/lanes_avx2.hpp>
#include <smoketrace/core/simd/lanes_scalar.hpp>

#if defined(SMOKETRACE_SIMD_AVX512)
#include <immintrin.h>

namespace smoketrace::simd {

// Sixteen floats.
template <>
struct Mask<float, 16> {
    __mmask16 k;
};

template <>
struct Lanes<float, 16> {
    __m512 v;
    [[gnu::always_inline]] static Lanes load(const float* p) { return {_mm512_load_ps(p)}; }  // 64-byte aligned
    [[gnu::always_inline]] static Lanes loadu(const float* p) { return {_mm512_loadu_ps(p)}; }
    [[gnu::always_inline]] static Lanes broadcast(float x) { return {_mm512_set1_ps(x)}; }
};

[[gnu::always_inline]] inline void store(float* p, Floats<16> a) { _mm512_store_ps(p, a.v); }  // 64-byte aligned
[[gnu::always_inline]] inline void store_compressed(float* p, Floats<16> a, unsigned lanes) {
    // The register form and a plain store: the memory form of vcompressps is microcoded on Zen 4.
    _mm512_storeu_ps(p, _mm512_maskz_compress_ps(__mmask16(lanes), a.v));
}
[[gnu::always_inline]] inline Floats<16> operator+(Floats<16> a, Floats<16> b) { return {_mm512_add_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats<16> operator-(Floats<16> a, Floats<16> b) { return {_mm512_sub_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats<16> operator*(Floats<16> a, Floats<16> b) { return {_mm512_mul_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats<16> operator/(Floats<16> a, Floats<16> b) { return {_mm512_div_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats<16> abs(Floats<16> a) { return {_mm512_abs_ps(a.v)}; }
[[gnu::always_inline]] inline Floats<16> max(Floats<16> a, Floats<16> b) {
    return {_mm512_maskz_max_ps(__mmask16(0xFFFF), a.v, b.v)};
}
[[gnu::always_inline]] inline Floats<16> min(Floats<16> a, Floats<16> b) {
    return {_mm512_maskz_min_ps(__mmask16(0xFFFF), a.v, b.v)};
}
[[gnu::always_inline]] inline Mask<float, 16> operator<(Floats<16> a, Floats<16> b) {
    return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_LT_OQ)};
}
[[gnu::always_inline]] inline Mask<float, 16> operator>(Floats<16> a, Floats<16> b) {
    return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_GT_OQ)};
}
[[gnu::always_inline]] inline Mask<float, 16> operator<=(Floats<16> a, Floats<16> b) {
    return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_LE_OQ)};
}
[[gnu::always_inline]] inline Mask<float, 16> operator>=(Floats<16> a, Floats<16> b) {
    return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_GE_OQ)};
}
[[gnu::always_inline]] inline Mask<float, 16> differs(Floats<16> a, Floats<16> b) {
    return {_mm512_cmp_ps_mask(a.v, b.v, _CMP_NEQ_OQ)};
}
[[gnu::always_inline]] inline Mask<float, 16> operator&(Mask<float, 16> a, Mask<float, 16> b) {
    return {__mmask16(a.k & b.k)};
}
[[gnu::always_inline]] inline Mask<float, 16> operator|(Mask<float, 16> a, Mask<float, 16> b) {
    return {__mmask16(a.k | b.k)};
}
[[gnu::always_inline]] inline unsigned bits(Mask<float, 16> m) { return m.k; }

// Eight doubles.
template <>
struct Mask<double, 8> {
    __mmask8 k;
    [[gnu::always_inline]] static Mask from_bits(unsigned bits) { return {__mmask8(bits)}; }
};

template <>
struct Lanes<double, 8> {
    __m512d v;
    [[gnu::always_inline]] static Lanes load(const double* p) { return {_mm512_load_pd(p)}; }  // 64-byte aligned
    [[gnu::always_inline]] static Lanes broadcast(double x) { return {_mm512_set1_pd(x)}; }
    [[gnu::always_inline]] static Lanes widen(const float* p) {  // 32-byte aligned
        return {_mm512_maskz_cvtps_pd(__mmask8(0xFF), _mm256_load_ps(p))};
    }
};

[[gnu::always_inline]] inline void store(double* p, Doubles<8> a) { _mm512_store_pd(p, a.v); }  // 64-byte aligned
[[gnu::always_inline]] inline Doubles<8> operator+(Doubles<8> a, Doubles<8> b) { return {_mm512_add_pd(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles<8> operator-(Doubles<8> a, Doubles<8> b) { return {_mm512_sub_pd(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles<8> operator*(Doubles<8> a, Doubles<8> b) { return {_mm512_mul_pd(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles<8> operator/(Doubles<8> a, Doubles<8> b) { return {_mm512_div_pd(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles<8> operator-(Doubles<8> a) { return {_mm512_xor_pd(a.v, _mm512_set1_pd(-0.0))}; }
[[gnu::always_inline]] inline Doubles<8> sqrt(Doubles<8> a) { return {_mm512_maskz_sqrt_pd(__mmask8(0xFF), a.v)}; }
[[gnu::always_inline]] inline Doubles<8> max(Doubles<8> a, Doubles<8> b) {
    return {_mm512_maskz_max_pd(__mmask8(0xFF), a.v, b.v)};
}
[[gnu::always_inline]] inline Doubles<8> abs(Doubles<8> a) { return {_mm512_andnot_pd(_mm512_set1_pd(-0.0), a.v)}; }
[[gnu::always_inline]] inline Doubles<8> copysign(Doubles<8> magnitude, Doubles<8> sign) {
    const __m512d s = _mm512_set1_pd(-0.0);
    return {_mm512_or_pd(_mm512_andnot_pd(s, magnitude.v), _mm512_and_pd(s, sign.v))};
}
[[gnu::always_inline]] inline Mask<double, 8> operator<(Doubles<8> a, Doubles<8> b) {
    return {_mm512_cmp_pd_mask(a.v, b.v, _CMP_LT_OQ)};
}
[[gnu::always_inline]] inline Mask<double, 8> operator>(Doubles<8> a, Doubles<8> b) {
    return {_mm512_cmp_pd_mask(a.v, b.v, _CMP_GT_OQ)};
}
[[gnu::always_inline]] inline Mask<double, 8> operator&(Mask<double, 8> a, Mask<double, 8> b) {
    return {__mmask8(a.k & b.k)};
}
[[gnu::always_inline]] inline Mask<double, 8> operator|(Mask<double, 8> a, Mask<double, 8> b) {
    return {__mmask8(a.k | b.k)};
}
[[gnu::always_inline]] inline unsigned bits(Mask<double, 8> m) { return m.k; }
[[gnu::always_inline]] inline Doubles<8> select(Mask<double, 8> m, Doubles<8> if_set, Doubles<8> if_clear) {
    return {_mm512_mask_blend_pd(m.k, if_clear.v, if_set.v)};
}

[[gnu::always_inline]] inline Floats<8> narrow(Doubles<8> a) { return {_mm512_maskz_cvtpd_ps(__mmask8(0xFF), a.v)}; }

// Sixteen 32-bit unsigned integers.
template <>
struct Mask<std::uint32_t, 16> {
    __mmask16 k;
    [[gnu::always_inline]] static Mask from_bits(unsigned bits) { return {__mmask16(bits)}; }
};

template <>
struct Lanes<std::uint32_t, 16> {
    __m512i v;
    [[gnu::always_inline]] static Lanes load(const std::uint32_t* p) {  // 64-byte aligned
        return {_mm512_load_si512(p)};
    }
    [[gnu::always_inline]] static Lanes broadcast(std::uint32_t x) { return {_mm512_set1_epi32(int(x))}; }
};

[[gnu::always_inline]] inline void store(std::uint32_t* p, UInts<16> a) {  // 64-byte aligned
    _mm512_store_si512(p, a.v);
}
[[gnu::always_inline]] inline void store_compressed(std::uint32_t* p, UInts<16> a, unsigned lanes) {
    _mm512_storeu_si512(p, _mm512_maskz_compress_epi32(__mmask16(lanes), a.v));
}
[[gnu::always_inline]] inline UInts<16> masked_add(UInts<16> a, Mask<std::uint32_t, 16> m, UInts<16> b) {
    return {_mm512_mask_add_epi32(a.v, m.k, a.v, b.v)};
}

}  // namespace smoketrace::simd
#endif  // SMOKETRACE_SIMD_AVX512
