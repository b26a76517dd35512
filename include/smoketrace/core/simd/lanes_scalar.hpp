#pragma once
// The lanes types and their operations, lane by lane in plain C++: the definition every instruction-set
// file (lanes_sse2.hpp, lanes_avx2.hpp, lanes_avx512.hpp) must match bit for bit (tests/test_simd_lanes.cpp),
// and the code a width without instructions runs: Lanes<float, 1> is the scalar twin that a kernel written
// over lanes compiles to on a build without AVX2. Include lanes.hpp, not this file.
//
// Lanes<T, N>: N values of T (float, double, std::uint32_t, std::uint8_t). Mask<T, N>: a comparison's
// result over them, a bit per lane. Every operation is the IEEE operation of each lane, in the order the
// kernel writes it (the build disables FMA contraction, CMakeLists.txt). max / min follow the x86
// instructions: max(a, b) = a > b ? a : b, so where either is NaN they return b.
#include <cmath>
#include <concepts>
#include <cstdint>

namespace smoketrace::simd {

template <class T, unsigned N>
struct Mask {
    static_assert(N >= 1 && N <= 32);
    unsigned lanes;  // bit i: lane i

    // The mask whose lane i is bit i of `bits` (bits above lane N − 1 ignored).
    [[gnu::always_inline]] static Mask from_bits(unsigned bits) {
        return {N == 32 ? bits : bits & ((1u << (N % 32)) - 1u)};
    }
};

template <class T, unsigned N>
struct Lanes {
    static_assert(N >= 1 && N <= 32);
    T lane[N];

    // N values from p: load() wants p aligned to the register size (for the instruction-set types),
    // loadu() does not.
    [[gnu::always_inline]] static Lanes load(const T* p) {
        Lanes r;
        for (unsigned i = 0; i < N; ++i) r.lane[i] = p[i];
        return r;
    }
    [[gnu::always_inline]] static Lanes loadu(const T* p) { return load(p); }
    [[gnu::always_inline]] static Lanes broadcast(T x) {
        Lanes r;
        for (unsigned i = 0; i < N; ++i) r.lane[i] = x;
        return r;
    }
    // Doubles: N floats from p (aligned to their size), each widened exactly.
    [[gnu::always_inline]] static Lanes widen(const float* p)
        requires std::same_as<T, double>
    {
        Lanes r;
        for (unsigned i = 0; i < N; ++i) r.lane[i] = static_cast<double>(p[i]);
        return r;
    }
    // Bytes: the four bytes of `word`, lane i from bits 8i … 8i + 7.
    [[gnu::always_inline]] static Lanes from_word(std::uint32_t word)
        requires(std::same_as<T, std::uint8_t> && N == 4)
    {
        Lanes r;
        for (unsigned i = 0; i < N; ++i) r.lane[i] = static_cast<std::uint8_t>(word >> (8 * i));
        return r;
    }
};

template <unsigned N> using Floats = Lanes<float, N>;
template <unsigned N> using Doubles = Lanes<double, N>;
template <unsigned N> using UInts = Lanes<std::uint32_t, N>;
template <unsigned N> using Bytes = Lanes<std::uint8_t, N>;

namespace scalar {
// Applies f to each lane of the arguments (all Lanes<T, N>) and returns the results as lanes.
template <class T, unsigned N, class F, class... More>
[[gnu::always_inline]] inline auto each(F f, const Lanes<T, N>& a, const More&... more) {
    Lanes<decltype(f(a.lane[0], more.lane[0]...)), N> r;
    for (unsigned i = 0; i < N; ++i) r.lane[i] = f(a.lane[i], more.lane[i]...);
    return r;
}
template <class T, unsigned N, class F>
[[gnu::always_inline]] inline Mask<T, N> where(F holds, const Lanes<T, N>& a, const Lanes<T, N>& b) {
    unsigned bits = 0;
    for (unsigned i = 0; i < N; ++i) bits |= unsigned(holds(a.lane[i], b.lane[i])) << i;
    return {bits};
}
}  // namespace scalar

template <class T, unsigned N>
[[gnu::always_inline]] inline void store(T* p, const Lanes<T, N>& a) {
    for (unsigned i = 0; i < N; ++i) p[i] = a.lane[i];
}

// The lanes of `a` selected by `lanes` (bit i: lane i; bits above lane N − 1 ignored), stored in lane order to
// p[0], p[1], …, and zeros after them up to p[N − 1]: N values written, p unaligned. For packing the lanes a
// kernel needs side by side. (Through store() and load(), so that it serves the instruction-set types without
// a compress instruction too: AVX2's.)
template <class T, unsigned N>
[[gnu::always_inline]] inline void store_compressed(T* p, const Lanes<T, N>& a, unsigned lanes) {
    alignas(64) T in[N];
    store(in, a);
    unsigned j = 0;
    for (unsigned i = 0; i < N; ++i)
        if ((lanes >> i) & 1u) p[j++] = in[i];
    for (; j < N; ++j) p[j] = T(0);
}

template <class T, unsigned N>
[[gnu::always_inline]] inline Lanes<T, N> operator+(const Lanes<T, N>& a, const Lanes<T, N>& b) {
    return scalar::each([](T x, T y) -> T { return T(x + y); }, a, b);
}
template <class T, unsigned N>
[[gnu::always_inline]] inline Lanes<T, N> operator-(const Lanes<T, N>& a, const Lanes<T, N>& b) {
    return scalar::each([](T x, T y) -> T { return T(x - y); }, a, b);
}
template <class T, unsigned N>
[[gnu::always_inline]] inline Lanes<T, N> operator*(const Lanes<T, N>& a, const Lanes<T, N>& b) {
    return scalar::each([](T x, T y) -> T { return T(x * y); }, a, b);
}
template <class T, unsigned N>
[[gnu::always_inline]] inline Lanes<T, N> operator/(const Lanes<T, N>& a, const Lanes<T, N>& b) {
    return scalar::each([](T x, T y) -> T { return T(x / y); }, a, b);
}
template <std::floating_point T, unsigned N>
[[gnu::always_inline]] inline Lanes<T, N> operator-(const Lanes<T, N>& a) {  // flips the sign bit, NaN too
    return scalar::each([](T x) -> T { return -x; }, a);
}
template <std::floating_point T, unsigned N>
[[gnu::always_inline]] inline Lanes<T, N> max(const Lanes<T, N>& a, const Lanes<T, N>& b) {
    return scalar::each([](T x, T y) -> T { return x > y ? x : y; }, a, b);
}
template <std::floating_point T, unsigned N>
[[gnu::always_inline]] inline Lanes<T, N> min(const Lanes<T, N>& a, const Lanes<T, N>& b) {
    return scalar::each([](T x, T y) -> T { return x < y ? x : y; }, a, b);
}
template <std::floating_point T, unsigned N>
[[gnu::always_inline]] inline Lanes<T, N> sqrt(const Lanes<T, N>& a) {
    return scalar::each([](T x) -> T { return std::sqrt(x); }, a);
}
template <std::floating_point T, unsigned N>
[[gnu::always_inline]] inline Lanes<T, N> abs(const Lanes<T, N>& a) {
    return scalar::each([](T x) -> T { return std::fabs(x); }, a);
}
// |magnitude| with the sign bit of `sign`.
template <std::floating_point T, unsigned N>
[[gnu::always_inline]] inline Lanes<T, N> copysign(const Lanes<T, N>& magnitude, const Lanes<T, N>& sign) {
    return scalar::each([](T m, T s) -> T { return std::copysign(m, s); }, magnitude, sign);
}
// a + b in the lanes of m, a elsewhere.
template <class T, unsigned N>
[[gnu::always_inline]] inline Lanes<T, N> masked_add(const Lanes<T, N>& a, Mask<T, N> m, const Lanes<T, N>& b) {
    Lanes<T, N> r;
    for (unsigned i = 0; i < N; ++i) r.lane[i] = T(a.lane[i] + ((m.lanes >> i) & 1u ? b.lane[i] : T(0)));
    return r;
}

// Comparisons: false where either lane is NaN (ordered). differs(a, b): a < b or a > b, so false where
// either is NaN (where a != b would be true).
template <class T, unsigned N>
[[gnu::always_inline]] inline Mask<T, N> operator<(const Lanes<T, N>& a, const Lanes<T, N>& b) {
    return scalar::where([](T x, T y) { return x < y; }, a, b);
}
template <class T, unsigned N>
[[gnu::always_inline]] inline Mask<T, N> operator>(const Lanes<T, N>& a, const Lanes<T, N>& b) {
    return scalar::where([](T x, T y) { return x > y; }, a, b);
}
template <class T, unsigned N>
[[gnu::always_inline]] inline Mask<T, N> operator<=(const Lanes<T, N>& a, const Lanes<T, N>& b) {
    return scalar::where([](T x, T y) { return x <= y; }, a, b);
}
template <class T, unsigned N>
[[gnu::always_inline]] inline Mask<T, N> operator>=(const Lanes<T, N>& a, const Lanes<T, N>& b) {
    return scalar::where([](T x, T y) { return x >= y; }, a, b);
}
template <class T, unsigned N>
[[gnu::always_inline]] inline Mask<T, N> operator==(const Lanes<T, N>& a, const Lanes<T, N>& b) {
    return scalar::where([](T x, T y) { return x == y; }, a, b);
}
template <std::integral T, unsigned N>  // (for floats see differs())
[[gnu::always_inline]] inline Mask<T, N> operator!=(const Lanes<T, N>& a, const Lanes<T, N>& b) {
    return scalar::where([](T x, T y) { return x != y; }, a, b);
}
template <std::floating_point T, unsigned N>
[[gnu::always_inline]] inline Mask<T, N> differs(const Lanes<T, N>& a, const Lanes<T, N>& b) {
    return scalar::where([](T x, T y) { return x < y || x > y; }, a, b);
}

template <class T, unsigned N>
[[gnu::always_inline]] inline Mask<T, N> operator&(Mask<T, N> a, Mask<T, N> b) {
    return {a.lanes & b.lanes};
}
template <class T, unsigned N>
[[gnu::always_inline]] inline Mask<T, N> operator|(Mask<T, N> a, Mask<T, N> b) {
    return {a.lanes | b.lanes};
}
// Bit i set where lane i of m is.
template <class T, unsigned N>
[[gnu::always_inline]] inline unsigned bits(Mask<T, N> m) {
    return m.lanes;
}
// Lane by lane: `if_set` where m is set, else `if_clear`.
template <class T, unsigned N>
[[gnu::always_inline]] inline Lanes<T, N> select(Mask<T, N> m, const Lanes<T, N>& if_set, const Lanes<T, N>& if_clear) {
    Lanes<T, N> r;
    for (unsigned i = 0; i < N; ++i) r.lane[i] = (m.lanes >> i) & 1u ? if_set.lane[i] : if_clear.lane[i];
    return r;
}

// Each double rounded to float (to nearest, as static_cast<float>). (The results of the conversions go
// through memory: the other type may hold N lanes in a register of an instruction set.)
template <unsigned N>
[[gnu::always_inline]] inline Floats<N> narrow(const Doubles<N>& a) {
    alignas(64) float r[N];
    for (unsigned i = 0; i < N; ++i) r[i] = static_cast<float>(a.lane[i]);
    return Floats<N>::load(r);
}
// Lanes 0 … N/2 − 1 (widen_low) or N/2 … N − 1 (widen_high), widened exactly to double.
template <unsigned N>
    requires(N % 2 == 0)
[[gnu::always_inline]] inline Doubles<N / 2> widen_low(const Floats<N>& a) {
    alignas(64) double r[N / 2];
    for (unsigned i = 0; i < N / 2; ++i) r[i] = static_cast<double>(a.lane[i]);
    return Doubles<N / 2>::load(r);
}
template <unsigned N>
    requires(N % 2 == 0)
[[gnu::always_inline]] inline Doubles<N / 2> widen_high(const Floats<N>& a) {
    alignas(64) double r[N / 2];
    for (unsigned i = 0; i < N / 2; ++i) r[i] = static_cast<double>(a.lane[N / 2 + i]);
    return Doubles<N / 2>::load(r);
}

}  // namespace smoketrace::simd
