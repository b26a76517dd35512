#pragma once
// The SSE2 lanes (every x86-64): four floats, and four bytes in the low lanes of a register. Each
// operation is one instruction (or two) with the bits of its definition in lanes_scalar.hpp. Include
// lanes.hpp, not this file.
#include <smoketrace/core/simd/isa.hpp>
#include <smoketrace/core/simd/lanes_scalar.hpp>

#if defined(SMOKETRACE_SIMD_SSE2)
#include <immintrin.h>

namespace smoketrace::simd {

template <>
struct Mask<float, 4> {
    __m128 m;  // all ones in a lane where it is set
};

template <>
struct Lanes<float, 4> {
    __m128 v;
    [[gnu::always_inline]] static Lanes load(const float* p) { return {_mm_load_ps(p)}; }  // 16-byte aligned
    [[gnu::always_inline]] static Lanes loadu(const float* p) { return {_mm_loadu_ps(p)}; }
    [[gnu::always_inline]] static Lanes broadcast(float x) { return {_mm_set1_ps(x)}; }
};

[[gnu::always_inline]] inline void store(float* p, Floats<4> a) { _mm_store_ps(p, a.v); }  // 16-byte aligned
[[gnu::always_inline]] inline Floats<4> operator+(Floats<4> a, Floats<4> b) { return {_mm_add_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats<4> operator-(Floats<4> a, Floats<4> b) { return {_mm_sub_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats<4> operator*(Floats<4> a, Floats<4> b) { return {_mm_mul_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats<4> operator/(Floats<4> a, Floats<4> b) { return {_mm_div_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats<4> abs(Floats<4> a) { return {_mm_andnot_ps(_mm_set1_ps(-0.0f), a.v)}; }
[[gnu::always_inline]] inline Floats<4> max(Floats<4> a, Floats<4> b) { return {_mm_max_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats<4> min(Floats<4> a, Floats<4> b) { return {_mm_min_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Mask<float, 4> operator<(Floats<4> a, Floats<4> b) { return {_mm_cmplt_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Mask<float, 4> operator>(Floats<4> a, Floats<4> b) { return {_mm_cmpgt_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Mask<float, 4> operator<=(Floats<4> a, Floats<4> b) { return {_mm_cmple_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Mask<float, 4> operator>=(Floats<4> a, Floats<4> b) { return {_mm_cmpge_ps(a.v, b.v)}; }
[[gnu::always_inline]] inline Mask<float, 4> differs(Floats<4> a, Floats<4> b) {  // ordered and unequal
    return {_mm_and_ps(_mm_cmpord_ps(a.v, b.v), _mm_cmpneq_ps(a.v, b.v))};
}
[[gnu::always_inline]] inline Mask<float, 4> operator&(Mask<float, 4> a, Mask<float, 4> b) {
    return {_mm_and_ps(a.m, b.m)};
}
[[gnu::always_inline]] inline Mask<float, 4> operator|(Mask<float, 4> a, Mask<float, 4> b) {
    return {_mm_or_ps(a.m, b.m)};
}
[[gnu::always_inline]] inline unsigned bits(Mask<float, 4> m) { return unsigned(_mm_movemask_ps(m.m)); }
// Two doubles are the plain C++ lanes here: the halves go through memory (so that every width compiles).
[[gnu::always_inline]] inline Doubles<2> widen_low(Floats<4> a) {
    alignas(16) float f[4];
    store(f, a);
    return Doubles<2>::widen(f);
}
[[gnu::always_inline]] inline Doubles<2> widen_high(Floats<4> a) {
    alignas(16) float f[4];
    store(f, a);
    return Doubles<2>::widen(f + 2);
}

template <>
struct Lanes<std::uint8_t, 4> {
    __m128i v;  // lanes 0–3 (the twelve above are not part of it)
    [[gnu::always_inline]] static Lanes from_word(std::uint32_t word) { return {_mm_cvtsi32_si128(int(word))}; }
    [[gnu::always_inline]] static Lanes broadcast(std::uint8_t x) { return {_mm_set1_epi8(char(x))}; }
};

// The masks of four bytes stay the generic bit set (Mask<std::uint8_t, 4>::lanes): the comparison moves
// its four lanes' bits out of the register at once.
[[gnu::always_inline]] inline Mask<std::uint8_t, 4> operator==(Bytes<4> a, Bytes<4> b) {
    return {unsigned(_mm_movemask_epi8(_mm_cmpeq_epi8(a.v, b.v))) & 0xFu};
}
[[gnu::always_inline]] inline Mask<std::uint8_t, 4> operator!=(Bytes<4> a, Bytes<4> b) {
    return {~unsigned(_mm_movemask_epi8(_mm_cmpeq_epi8(a.v, b.v))) & 0xFu};
}

}  // namespace smoketrace::simd
#endif  // SMOKETRACE_SIMD_SSE2
