#pragma once
// The AVX2 lanes (x86-64-v3): eight floats, four doubles, eight 32-bit integers in a 256-bit register.
// Each operation is one instruction (or a few) with the bits of its definition in lanes_scalar.hpp; masks
// are all ones in a lane where set. Include lanes.hpp, not this file.
#include <smoketrace/core/simd/isa.hpp>
#include <smoketrace/core/simd/lanes_scalar.hpp>
#include <smoketrace/core/simd/lanes_sse2.hpp>

#if defined(SMOKETRACE_SIMD_AVX2)
#include <immintrin.h>

namespace smoketrace::simd {

// Eight floats.
template <>
struct Mask<float, 8> {
    __m256 m;
};

template <>
struct Lanes<float, 8> {
    __m256 v;
    [[gnu::always_inline]] static Lanes load(const float* p) { return {_mm256_load_ps(p)}; }  // 32-byte aligned
    [[gnu::always_inline]] static Lanes loadu(const float* p) { return {_mm256_loadu_ps(p)}; }
    [[gnu::always_inline]] static Lanes broadcast(float x) { return {_mm256_set1_ps(x)}; }
};

[[gnu::always_inline]] inline void store(float* p, Floats<8> a) { _mm256_store_ps(p, a.v); }  // 32-byte aligned
[[gnu::always_inline]] inline Floats<8> operator+(Floats<8> a, Floats<8> b) { return {_mm256_add_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats<8> operator-(Floats<8> a, Floats<8> b) { return {_mm256_sub_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats<8> operator*(Floats<8> a, Floats<8> b) { return {_mm256_mul_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats<8> operator/(Floats<8> a, Floats<8> b) { return {_mm256_div_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats<8> abs(Floats<8> a) { return {_mm256_andnot_ps(_mm256_set1_ps(-0.0f), a.v)}; }
[[gnu::always_inline]] inline Floats<8> max(Floats<8> a, Floats<8> b) { return {_mm256_max_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats<8> min(Floats<8> a, Floats<8> b) { return {_mm256_min_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Mask<float, 8> operator<(Floats<8> a, Floats<8> b) {
    return {_mm256_cmp_ps(a.v, b.v, _CMP_LT_OQ)};
}
[[gnu::always_inline]] inline Mask<float, 8> operator>(Floats<8> a, Floats<8> b) {
    return {_mm256_cmp_ps(a.v, b.v, _CMP_GT_OQ)};
}
[[gnu::always_inline]] inline Mask<float, 8> operator<=(Floats<8> a, Floats<8> b) {
    return {_mm256_cmp_ps(a.v, b.v, _CMP_LE_OQ)};
}
[[gnu::always_inline]] inline Mask<float, 8> operator>=(Floats<8> a, Floats<8> b) {
    return {_mm256_cmp_ps(a.v, b.v, _CMP_GE_OQ)};
}
[[gnu::always_inline]] inline Mask<float, 8> differs(Floats<8> a, Floats<8> b) {
    return {_mm256_cmp_ps(a.v, b.v, _CMP_NEQ_OQ)};
}
[[gnu::always_inline]] inline Mask<float, 8> operator&(Mask<float, 8> a, Mask<float, 8> b) {
    return {_mm256_and_ps(a.m, b.m)};
}
[[gnu::always_inline]] inline Mask<float, 8> operator|(Mask<float, 8> a, Mask<float, 8> b) {
    return {_mm256_or_ps(a.m, b.m)};
}
[[gnu::always_inline]] inline unsigned bits(Mask<float, 8> m) { return unsigned(_mm256_movemask_ps(m.m)); }

// Four doubles.
template <>
struct Mask<double, 4> {
    __m256d m;
    [[gnu::always_inline]] static Mask from_bits(unsigned bits) {  // lane i tests bit i
        const __m256i bit = _mm256_setr_epi64x(1, 2, 4, 8);
        return {_mm256_castsi256_pd(_mm256_cmpeq_epi64(_mm256_and_si256(_mm256_set1_epi64x(bits), bit), bit))};
    }
};

template <>
struct Lanes<double, 4> {
    __m256d v;
    [[gnu::always_inline]] static Lanes load(const double* p) { return {_mm256_load_pd(p)}; }  // 32-byte aligned
    [[gnu::always_inline]] static Lanes broadcast(double x) { return {_mm256_set1_pd(x)}; }
    [[gnu::always_inline]] static Lanes widen(const float* p) {  // 16-byte aligned
        return {_mm256_cvtps_pd(_mm_load_ps(p))};
    }
};

[[gnu::always_inline]] inline void store(double* p, Doubles<4> a) { _mm256_store_pd(p, a.v); }  // 32-byte aligned
[[gnu::always_inline]] inline Doubles<4> operator+(Doubles<4> a, Doubles<4> b) { return {_mm256_add_pd(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles<4> operator-(Doubles<4> a, Doubles<4> b) { return {_mm256_sub_pd(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles<4> operator*(Doubles<4> a, Doubles<4> b) { return {_mm256_mul_pd(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles<4> operator/(Doubles<4> a, Doubles<4> b) { return {_mm256_div_pd(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles<4> operator-(Doubles<4> a) { return {_mm256_xor_pd(a.v, _mm256_set1_pd(-0.0))}; }
[[gnu::always_inline]] inline Doubles<4> sqrt(Doubles<4> a) { return {_mm256_sqrt_pd(a.v)}; }
[[gnu::always_inline]] inline Doubles<4> max(Doubles<4> a, Doubles<4> b) { return {_mm256_max_pd(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles<4> abs(Doubles<4> a) { return {_mm256_andnot_pd(_mm256_set1_pd(-0.0), a.v)}; }
[[gnu::always_inline]] inline Doubles<4> copysign(Doubles<4> magnitude, Doubles<4> sign) {
    const __m256d s = _mm256_set1_pd(-0.0);
    return {_mm256_or_pd(_mm256_andnot_pd(s, magnitude.v), _mm256_and_pd(s, sign.v))};
}
[[gnu::always_inline]] inline Mask<double, 4> operator<(Doubles<4> a, Doubles<4> b) {
    return {_mm256_cmp_pd(a.v, b.v, _CMP_LT_OQ)};
}
[[gnu::always_inline]] inline Mask<double, 4> operator>(Doubles<4> a, Doubles<4> b) {
    return {_mm256_cmp_pd(a.v, b.v, _CMP_GT_OQ)};
}
[[gnu::always_inline]] inline Mask<double, 4> operator&(Mask<double, 4> a, Mask<double, 4> b) {
    return {_mm256_and_pd(a.m, b.m)};
}
[[gnu::always_inline]] inline Mask<double, 4> operator|(Mask<double, 4> a, Mask<double, 4> b) {
    return {_mm256_or_pd(a.m, b.m)};
}
[[gnu::always_inline]] inline unsigned bits(Mask<double, 4> m) { return unsigned(_mm256_movemask_pd(m.m)); }
[[gnu::always_inline]] inline Doubles<4> select(Mask<double, 4> m, Doubles<4> if_set, Doubles<4> if_clear) {
    return {_mm256_blendv_pd(if_clear.v, if_set.v, m.m)};
}

[[gnu::always_inline]] inline Floats<4> narrow(Doubles<4> a) { return {_mm256_cvtpd_ps(a.v)}; }
[[gnu::always_inline]] inline Doubles<4> widen_low(Floats<8> a) {
    return {_mm256_cvtps_pd(_mm256_castps256_ps128(a.v))};
}
[[gnu::always_inline]] inline Doubles<4> widen_high(Floats<8> a) {
    return {_mm256_cvtps_pd(_mm256_extractf128_ps(a.v, 1))};
}

// Eight 32-bit unsigned integers.
template <>
struct Mask<std::uint32_t, 8> {
    __m256i m;
    [[gnu::always_inline]] static Mask from_bits(unsigned bits) {  // lane i tests bit i
        const __m256i bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        return {_mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(int(bits)), bit), bit)};
    }
};

template <>
struct Lanes<std::uint32_t, 8> {
    __m256i v;
    [[gnu::always_inline]] static Lanes load(const std::uint32_t* p) {  // 32-byte aligned
        return {_mm256_load_si256(reinterpret_cast<const __m256i*>(p))};
    }
    [[gnu::always_inline]] static Lanes broadcast(std::uint32_t x) { return {_mm256_set1_epi32(int(x))}; }
};

[[gnu::always_inline]] inline void store(std::uint32_t* p, UInts<8> a) {  // 32-byte aligned
    _mm256_store_si256(reinterpret_cast<__m256i*>(p), a.v);
}
[[gnu::always_inline]] inline UInts<8> masked_add(UInts<8> a, Mask<std::uint32_t, 8> m, UInts<8> b) {
    return {_mm256_add_epi32(a.v, _mm256_and_si256(m.m, b.v))};
}

}  // namespace smoketrace::simd
#endif  // SMOKETRACE_SIMD_AVX2
