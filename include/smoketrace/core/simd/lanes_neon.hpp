#pragma once
// The NEON lanes (AArch64's Advanced SIMD, every 64-bit Arm CPU): four floats, two doubles, four 32-bit
// integers in a 128-bit register, and four bytes in the low lanes of a 64-bit one. Each operation is one
// instruction (or a few) with the bits of its definition in lanes_scalar.hpp; masks are all ones in a lane
// where set. Include lanes.hpp, not this file.
//
// Two of NEON's instructions do not have those bits, and are not used: FMAX / FMIN return the NaN where
// either operand is one (and order +0 above −0), where the definition's max(a, b) = a > b ? a : b returns
// b: max and min are a comparison and a bit select. The fused multiply-adds (vfmaq) round once where the
// definition rounds twice.
#include <smoketrace/core/simd/isa.hpp>
#include <smoketrace/core/simd/lanes_scalar.hpp>

#if defined(SMOKETRACE_SIMD_NEON)
#include <arm_neon.h>

namespace smoketrace::simd {

// Four floats.
template <>
struct Mask<float, 4> {
    uint32x4_t m;
};

template <>
struct Lanes<float, 4> {
    float32x4_t v;
    [[gnu::always_inline]] static Lanes load(const float* p) { return {vld1q_f32(p)}; }
    [[gnu::always_inline]] static Lanes loadu(const float* p) { return {vld1q_f32(p)}; }
    [[gnu::always_inline]] static Lanes broadcast(float x) { return {vdupq_n_f32(x)}; }
};

[[gnu::always_inline]] inline void store(float* p, Floats<4> a) { vst1q_f32(p, a.v); }
[[gnu::always_inline]] inline Floats<4> operator+(Floats<4> a, Floats<4> b) { return {vaddq_f32(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats<4> operator-(Floats<4> a, Floats<4> b) { return {vsubq_f32(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats<4> operator*(Floats<4> a, Floats<4> b) { return {vmulq_f32(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats<4> operator/(Floats<4> a, Floats<4> b) { return {vdivq_f32(a.v, b.v)}; }
[[gnu::always_inline]] inline Floats<4> abs(Floats<4> a) { return {vabsq_f32(a.v)}; }
[[gnu::always_inline]] inline Floats<4> max(Floats<4> a, Floats<4> b) {
    return {vbslq_f32(vcgtq_f32(a.v, b.v), a.v, b.v)};
}
[[gnu::always_inline]] inline Floats<4> min(Floats<4> a, Floats<4> b) {
    return {vbslq_f32(vcltq_f32(a.v, b.v), a.v, b.v)};
}
[[gnu::always_inline]] inline Mask<float, 4> operator<(Floats<4> a, Floats<4> b) { return {vcltq_f32(a.v, b.v)}; }
[[gnu::always_inline]] inline Mask<float, 4> operator>(Floats<4> a, Floats<4> b) { return {vcgtq_f32(a.v, b.v)}; }
[[gnu::always_inline]] inline Mask<float, 4> operator<=(Floats<4> a, Floats<4> b) { return {vcleq_f32(a.v, b.v)}; }
[[gnu::always_inline]] inline Mask<float, 4> operator>=(Floats<4> a, Floats<4> b) { return {vcgeq_f32(a.v, b.v)}; }
[[gnu::always_inline]] inline Mask<float, 4> differs(Floats<4> a, Floats<4> b) {  // ordered and unequal
    return {vorrq_u32(vcltq_f32(a.v, b.v), vcgtq_f32(a.v, b.v))};
}
[[gnu::always_inline]] inline Mask<float, 4> operator&(Mask<float, 4> a, Mask<float, 4> b) {
    return {vandq_u32(a.m, b.m)};
}
[[gnu::always_inline]] inline Mask<float, 4> operator|(Mask<float, 4> a, Mask<float, 4> b) {
    return {vorrq_u32(a.m, b.m)};
}
[[gnu::always_inline]] inline unsigned bits(Mask<float, 4> m) {  // lane i's bit kept, the four added
    const uint32x4_t bit = {1, 2, 4, 8};
    return vaddvq_u32(vandq_u32(m.m, bit));
}

// Two doubles.
template <>
struct Mask<double, 2> {
    uint64x2_t m;
    [[gnu::always_inline]] static Mask from_bits(unsigned bits) {  // lane i tests bit i
        const uint64x2_t bit = {1, 2};
        return {vtstq_u64(vdupq_n_u64(bits), bit)};
    }
};

template <>
struct Lanes<double, 2> {
    float64x2_t v;
    [[gnu::always_inline]] static Lanes load(const double* p) { return {vld1q_f64(p)}; }
    [[gnu::always_inline]] static Lanes broadcast(double x) { return {vdupq_n_f64(x)}; }
    [[gnu::always_inline]] static Lanes widen(const float* p) { return {vcvt_f64_f32(vld1_f32(p))}; }
};

[[gnu::always_inline]] inline void store(double* p, Doubles<2> a) { vst1q_f64(p, a.v); }
[[gnu::always_inline]] inline Doubles<2> operator+(Doubles<2> a, Doubles<2> b) { return {vaddq_f64(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles<2> operator-(Doubles<2> a, Doubles<2> b) { return {vsubq_f64(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles<2> operator*(Doubles<2> a, Doubles<2> b) { return {vmulq_f64(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles<2> operator/(Doubles<2> a, Doubles<2> b) { return {vdivq_f64(a.v, b.v)}; }
[[gnu::always_inline]] inline Doubles<2> operator-(Doubles<2> a) { return {vnegq_f64(a.v)}; }  // the sign bit, NaN too
[[gnu::always_inline]] inline Doubles<2> sqrt(Doubles<2> a) { return {vsqrtq_f64(a.v)}; }
[[gnu::always_inline]] inline Doubles<2> max(Doubles<2> a, Doubles<2> b) {
    return {vbslq_f64(vcgtq_f64(a.v, b.v), a.v, b.v)};
}
[[gnu::always_inline]] inline Doubles<2> abs(Doubles<2> a) { return {vabsq_f64(a.v)}; }
[[gnu::always_inline]] inline Doubles<2> copysign(Doubles<2> magnitude, Doubles<2> sign) {
    return {vbslq_f64(vdupq_n_u64(0x8000'0000'0000'0000u), sign.v, magnitude.v)};
}
[[gnu::always_inline]] inline Mask<double, 2> operator<(Doubles<2> a, Doubles<2> b) { return {vcltq_f64(a.v, b.v)}; }
[[gnu::always_inline]] inline Mask<double, 2> operator>(Doubles<2> a, Doubles<2> b) { return {vcgtq_f64(a.v, b.v)}; }
[[gnu::always_inline]] inline Mask<double, 2> operator&(Mask<double, 2> a, Mask<double, 2> b) {
    return {vandq_u64(a.m, b.m)};
}
[[gnu::always_inline]] inline Mask<double, 2> operator|(Mask<double, 2> a, Mask<double, 2> b) {
    return {vorrq_u64(a.m, b.m)};
}
[[gnu::always_inline]] inline unsigned bits(Mask<double, 2> m) {
    const uint64x2_t bit = {1, 2};
    return unsigned(vaddvq_u64(vandq_u64(m.m, bit)));
}
[[gnu::always_inline]] inline Doubles<2> select(Mask<double, 2> m, Doubles<2> if_set, Doubles<2> if_clear) {
    return {vbslq_f64(m.m, if_set.v, if_clear.v)};
}

// Two floats have no register of their own here (the plain C++ lanes): the conversion goes through memory.
[[gnu::always_inline]] inline Floats<2> narrow(Doubles<2> a) {
    Floats<2> r;
    vst1_f32(r.lane, vcvt_f32_f64(a.v));
    return r;
}
[[gnu::always_inline]] inline Doubles<2> widen_low(Floats<4> a) { return {vcvt_f64_f32(vget_low_f32(a.v))}; }
[[gnu::always_inline]] inline Doubles<2> widen_high(Floats<4> a) { return {vcvt_high_f64_f32(a.v)}; }

// Four 32-bit unsigned integers.
template <>
struct Mask<std::uint32_t, 4> {
    uint32x4_t m;
    [[gnu::always_inline]] static Mask from_bits(unsigned bits) {  // lane i tests bit i
        const uint32x4_t bit = {1, 2, 4, 8};
        return {vtstq_u32(vdupq_n_u32(bits), bit)};
    }
};

template <>
struct Lanes<std::uint32_t, 4> {
    uint32x4_t v;
    [[gnu::always_inline]] static Lanes load(const std::uint32_t* p) { return {vld1q_u32(p)}; }
    [[gnu::always_inline]] static Lanes broadcast(std::uint32_t x) { return {vdupq_n_u32(x)}; }
};

[[gnu::always_inline]] inline void store(std::uint32_t* p, UInts<4> a) { vst1q_u32(p, a.v); }
[[gnu::always_inline]] inline UInts<4> masked_add(UInts<4> a, Mask<std::uint32_t, 4> m, UInts<4> b) {
    return {vaddq_u32(a.v, vandq_u32(m.m, b.v))};
}

// Four bytes.
template <>
struct Lanes<std::uint8_t, 4> {
    uint8x8_t v;  // lanes 0–3 (the four above are not part of it)
    [[gnu::always_inline]] static Lanes from_word(std::uint32_t word) {
        return {vreinterpret_u8_u32(vdup_n_u32(word))};
    }
    [[gnu::always_inline]] static Lanes broadcast(std::uint8_t x) { return {vdup_n_u8(x)}; }
};

// The masks of four bytes stay the generic bit set (Mask<std::uint8_t, 4>::lanes), as with SSE2: the
// comparison keeps bit i of lane i (zero above lane 3) and adds the lanes.
[[gnu::always_inline]] inline Mask<std::uint8_t, 4> operator==(Bytes<4> a, Bytes<4> b) {
    const uint8x8_t bit = {1, 2, 4, 8, 0, 0, 0, 0};
    return {unsigned(vaddv_u8(vand_u8(vceq_u8(a.v, b.v), bit)))};
}
[[gnu::always_inline]] inline Mask<std::uint8_t, 4> operator!=(Bytes<4> a, Bytes<4> b) {
    const uint8x8_t bit = {1, 2, 4, 8, 0, 0, 0, 0};
    return {unsigned(vaddv_u8(vand_u8(vmvn_u8(vceq_u8(a.v, b.v)), bit)))};
}

}  // namespace smoketrace::simd
#endif  // SMOKETRACE_SIMD_NEON
