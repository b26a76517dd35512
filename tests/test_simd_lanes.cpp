// The lanes types (core/simd/lanes.hpp): every operation at every width against the same operation at
// width 1, lane by lane. Width 1 is always the plain C++ definition (lanes_scalar.hpp); the widths the
// build's instruction sets hold are their instructions (lanes_sse2.hpp: 4 floats; lanes_avx2.hpp: 8
// floats, 4 doubles, 8 integers; lanes_avx512.hpp: 16 floats, 8 doubles, 16 integers; lanes_neon.hpp: 4
// floats, 2 doubles, 4 integers, 4 bytes), so each build checks the files it compiles. Bit for bit, with
// one allowance: a NaN result only has to be a NaN (the definition's operand order, which decides which NaN
// comes out, is the compiler's to choose in scalar code; no kernel lets a NaN reach its result).
#include <smoketrace/core/prng.hpp>
#include <smoketrace/core/simd/lanes.hpp>

#include <catch2/catch.hpp>

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>

using namespace smoketrace;
using simd::Lanes;

namespace {

template <class T>
T random_value(Pcg32& rng) {
    if constexpr (std::is_floating_point_v<T>) {
        using L = std::numeric_limits<T>;
        const T special[] = {T(0),       -T(0),         T(1),          T(-1),         T(0.5),      T(3),
                             L::infinity(), -L::infinity(), L::quiet_NaN(), -L::quiet_NaN(), L::denorm_min(),
                             -L::denorm_min(), L::max(),      L::min(),      -L::max()};
        if (rng.below(2) == 0) return special[rng.below(std::uint32_t(std::size(special)))];
        if constexpr (sizeof(T) == 4) {
            return std::bit_cast<float>(rng.next_u32());
        } else {
            return std::bit_cast<double>(std::uint64_t(rng.next_u32()) << 32 | rng.next_u32());
        }
    } else if constexpr (sizeof(T) == 1) {
        return rng.below(3) == 0 ? T(0) : T(rng.next_u32());
    } else {
        return T(rng.next_u32());
    }
}

template <class T>
bool same(T a, T b) {
    if constexpr (std::is_floating_point_v<T>) {
        if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b);
        if constexpr (sizeof(T) == 4) {
            return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b);
        } else {
            return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
        }
    } else {
        return a == b;
    }
}

template <class T, unsigned N>
std::array<T, N> lanes_of(const Lanes<T, N>& x) {
    alignas(64) T out[N];
    store(out, x);
    std::array<T, N> a;
    for (unsigned i = 0; i < N; ++i) a[i] = out[i];
    return a;
}

// op(x, y) at width N against op on each lane at width 1: x and y hold N random values of T each.
// Results that are lanes are compared lane by lane, masks bit by bit.
template <class T, unsigned N>
struct Checker {
    alignas(64) T a[N];
    alignas(64) T b[N];

    void refill(Pcg32& rng) {
        for (unsigned i = 0; i < N; ++i) {
            a[i] = random_value<T>(rng);
            b[i] = rng.below(8) == 0 ? a[i] : random_value<T>(rng);  // equal lanes for the comparisons
        }
    }

    template <class Op>
    void check(const char* what, Op op) const {
        INFO(what << ", " << N << " lanes");
        const auto wide = op(Lanes<T, N>::load(a), Lanes<T, N>::load(b));
        if constexpr (requires { bits(wide); }) {
            unsigned expected = 0;
            for (unsigned i = 0; i < N; ++i)
                expected |= bits(op(Lanes<T, 1>::load(a + i), Lanes<T, 1>::load(b + i))) << i;
            CHECK(bits(wide) == expected);
        } else {
            const auto got = lanes_of(wide);
            for (unsigned i = 0; i < N; ++i) {
                const auto expected = lanes_of(op(Lanes<T, 1>::load(a + i), Lanes<T, 1>::load(b + i)))[0];
                INFO("lane " << i << ": " << got[i] << " vs " << expected);
                CHECK(same(got[i], expected));
            }
        }
    }
};

template <unsigned N>
void check_floats(Pcg32& rng) {
    Checker<float, N> c;
    for (int round = 0; round < 1000; ++round) {
        c.refill(rng);
        c.check("load, store", [](auto x, auto) { return x; });
        c.check("broadcast", [](auto x, auto) { return decltype(x)::broadcast(-2.5f); });
        c.check("+", [](auto x, auto y) { return x + y; });
        c.check("-", [](auto x, auto y) { return x - y; });
        c.check("*", [](auto x, auto y) { return x * y; });
        c.check("/", [](auto x, auto y) { return x / y; });
        c.check("abs", [](auto x, auto) { return abs(x); });
        c.check("max", [](auto x, auto y) { return max(x, y); });
        c.check("min", [](auto x, auto y) { return min(x, y); });
        c.check("<", [](auto x, auto y) { return x < y; });
        c.check(">", [](auto x, auto y) { return x > y; });
        c.check("<=", [](auto x, auto y) { return x <= y; });
        c.check(">=", [](auto x, auto y) { return x >= y; });
        c.check("differs", [](auto x, auto y) { return differs(x, y); });
        c.check("&", [](auto x, auto y) { return (x < y) & (x >= decltype(x)::broadcast(0.0f)); });
        c.check("|", [](auto x, auto y) { return (x < y) | (x > y); });
    }
    // loadu from an address that is not aligned to the register.
    alignas(64) float buffer[N + 1];
    for (float& x : buffer) x = random_value<float>(rng);
    const auto got = lanes_of(simd::Floats<N>::loadu(buffer + 1));
    for (unsigned i = 0; i < N; ++i) CHECK(same(got[i], buffer[1 + i]));
}

template <unsigned N>
void check_doubles(Pcg32& rng) {
    Checker<double, N> c;
    for (int round = 0; round < 1000; ++round) {
        c.refill(rng);
        c.check("load, store", [](auto x, auto) { return x; });
        c.check("broadcast", [](auto x, auto) { return decltype(x)::broadcast(-2.5); });
        c.check("+", [](auto x, auto y) { return x + y; });
        c.check("-", [](auto x, auto y) { return x - y; });
        c.check("*", [](auto x, auto y) { return x * y; });
        c.check("/", [](auto x, auto y) { return x / y; });
        c.check("unary -", [](auto x, auto) { return -x; });
        c.check("sqrt", [](auto x, auto) { return sqrt(x); });
        c.check("max", [](auto x, auto y) { return max(x, y); });
        c.check("abs", [](auto x, auto) { return abs(x); });
        c.check("copysign", [](auto x, auto y) { return copysign(x, y); });
        c.check("<", [](auto x, auto y) { return x < y; });
        c.check(">", [](auto x, auto y) { return x > y; });
        c.check("&", [](auto x, auto y) { return (x < y) & (x > decltype(x)::broadcast(0.0)); });
        c.check("|", [](auto x, auto y) { return (x < y) | (x > y); });
        c.check("select", [](auto x, auto y) { return select(x > y, x, y); });
        c.check("narrow", [](auto x, auto) { return narrow(x); });
        // A mask from bits (those above lane N − 1 ignored), through select() and bits().
        const unsigned lane_bits = rng.next_u32();
        const auto mask = simd::Mask<double, N>::from_bits(lane_bits);
        CHECK(bits(mask) == (lane_bits & ((1u << N) - 1u)));
        const auto got = lanes_of(select(mask, simd::Doubles<N>::load(c.a), simd::Doubles<N>::load(c.b)));
        for (unsigned i = 0; i < N; ++i) CHECK(same(got[i], (lane_bits >> i) & 1u ? c.a[i] : c.b[i]));
    }
    // widen: N floats, each exactly.
    alignas(64) float f[N];
    for (int round = 0; round < 1000; ++round) {
        for (float& x : f) x = random_value<float>(rng);
        const auto got = lanes_of(simd::Doubles<N>::widen(f));
        for (unsigned i = 0; i < N; ++i) CHECK(same(got[i], static_cast<double>(f[i])));
    }
}

// widen_low / widen_high of 2N floats: each lane exactly.
template <unsigned N>
void check_float_halves(Pcg32& rng) {
    alignas(64) float f[2 * N];
    for (int round = 0; round < 1000; ++round) {
        for (float& x : f) x = random_value<float>(rng);
        const auto x = simd::Floats<2 * N>::load(f);
        const auto low = lanes_of(widen_low(x)), high = lanes_of(widen_high(x));
        for (unsigned i = 0; i < N; ++i) {
            CHECK(same(low[i], static_cast<double>(f[i])));
            CHECK(same(high[i], static_cast<double>(f[N + i])));
        }
    }
}

// store_compressed: the selected lanes in lane order, then zeros, N values from an unaligned place and no more;
// bits of the lane set above lane N − 1 ignored.
template <class T, unsigned N>
void check_store_compressed(Pcg32& rng) {
    alignas(64) T a[N];
    for (int round = 0; round < 1000; ++round) {
        for (T& x : a) x = random_value<T>(rng);
        const unsigned lanes = rng.below(4) == 0 ? ~0u : rng.next_u32();
        T out[N + 2];
        out[0] = out[N + 1] = T(7);
        store_compressed(out + 1, Lanes<T, N>::load(a), lanes);
        INFO("store_compressed, " << N << " lanes, set " << lanes);
        unsigned j = 0;
        for (unsigned i = 0; i < N; ++i)
            if ((lanes >> i) & 1u) CHECK(same(out[1 + j++], a[i]));
        for (; j < N; ++j) CHECK(same(out[1 + j], T(0)));
        CHECK(out[0] == T(7));
        CHECK(out[N + 1] == T(7));
    }
}

template <unsigned N>
void check_uints(Pcg32& rng) {
    using Mask = simd::Mask<std::uint32_t, N>;
    Checker<std::uint32_t, N> c;
    for (int round = 0; round < 1000; ++round) {
        c.refill(rng);
        const unsigned lane_bits = rng.next_u32();
        c.check("load, store", [](auto x, auto) { return x; });
        c.check("broadcast", [](auto x, auto) { return decltype(x)::broadcast(0xFFFF'FFFEu); });
        // Bits above the lanes are ignored: the register's lanes take bits 0 … N − 1.
        const auto got = lanes_of(masked_add(simd::UInts<N>::load(c.a), Mask::from_bits(lane_bits),
                                             simd::UInts<N>::load(c.b)));
        for (unsigned i = 0; i < N; ++i) {
            const auto one = simd::Mask<std::uint32_t, 1>::from_bits((lane_bits >> i) & 1u);
            const auto expected =
                lanes_of(masked_add(simd::UInts<1>::load(c.a + i), one, simd::UInts<1>::load(c.b + i)))[0];
            INFO("masked_add, lane " << i);
            CHECK(got[i] == expected);
        }
    }
}

}  // namespace

TEST_CASE("simd lanes: floats at every width give the scalar lanes' bits", "[simd]") {
    Pcg32 rng(61);
    check_floats<4>(rng);
    check_floats<8>(rng);
    check_floats<16>(rng);
    check_float_halves<2>(rng);
    check_float_halves<4>(rng);
    check_store_compressed<float, 1>(rng);
    check_store_compressed<float, 4>(rng);
    check_store_compressed<float, 8>(rng);
    check_store_compressed<float, 16>(rng);
}

TEST_CASE("simd lanes: doubles at every width give the scalar lanes' bits", "[simd]") {
    Pcg32 rng(62);
    check_doubles<2>(rng);
    check_doubles<4>(rng);
    check_doubles<8>(rng);
}

TEST_CASE("simd lanes: 32-bit integers at every width give the scalar lanes' bits", "[simd]") {
    Pcg32 rng(63);
    check_uints<4>(rng);
    check_uints<8>(rng);
    check_uints<16>(rng);
    check_store_compressed<std::uint32_t, 1>(rng);
    check_store_compressed<std::uint32_t, 4>(rng);
    check_store_compressed<std::uint32_t, 8>(rng);
    check_store_compressed<std::uint32_t, 16>(rng);
}

TEST_CASE("simd lanes: four bytes compare like the scalar lanes", "[simd]") {
    Pcg32 rng(64);
    using Bytes = simd::Bytes<4>;
    for (int round = 0; round < 10000; ++round) {
        std::uint32_t word = rng.next_u32();
        for (int i = 0; i < 4; ++i)
            if (rng.below(3) == 0) word &= ~(0xFFu << (8 * i));  // zero bytes are what admitted_children() looks for
        const auto x = std::uint8_t(rng.below(2) == 0 ? 0u : rng.next_u32());
        unsigned expected = 0;
        for (unsigned i = 0; i < 4; ++i) {
            using One = simd::Bytes<1>;
            expected |= bits(One::broadcast(std::uint8_t(word >> (8 * i))) == One::broadcast(x)) << i;
        }
        INFO("word " << word << ", byte " << unsigned(x));
        CHECK(bits(Bytes::from_word(word) == Bytes::broadcast(x)) == expected);
    }
}
