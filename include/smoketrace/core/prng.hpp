#pragma once
// smoketrace's own pseudo-random number generator: PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast
// Space-Efficient Statistically Good Algorithms for Random Number Generation"; the XSH-RR output
// function over a 64-bit LCG, exactly as the reference pcg32_random_r / pcg32_srandom_r).
//
// Why our own, and why no std::uniform_real_distribution: the standard fixes the engines
// (std::mt19937 …) bit for bit but not the distributions. libstdc++, libc++ and MSVC turn the same engine
// output into different floats (different bit counts consumed, different scaling, and
// generate_canonical may even return 1.0). A scene generated from a seed must be the same particles on
// every platform and compiler, so we map bits to floats ourselves with integer operations and one exact
// multiplication by a power of two.
#include <cstdint>

namespace smoketrace {

class Pcg32 {
public:
    // The stream selects one of 2^63 independent sequences for the same seed (the reference's initseq).
    // 54 is the reference demo's stream; any value is fine.
    static constexpr std::uint64_t kDefaultStream = 54u;

    // pcg32_srandom_r(seed, stream): Pcg32(42, 54) yields 0xa15c02b7, 0x7b47f409, … as the reference demo.
    explicit constexpr Pcg32(std::uint64_t seed, std::uint64_t stream = kDefaultStream)
        : state_(0u), increment_((stream << 1u) | 1u) {
        next_u32();
        state_ += seed;
        next_u32();
    }

    // 32 uniformly distributed bits.
    constexpr std::uint32_t next_u32() {
        const std::uint64_t old = state_;
        state_ = old * kMultiplier + increment_;
        const auto xorshifted = static_cast<std::uint32_t>(((old >> 18u) ^ old) >> 27u);
        const auto rotation = static_cast<std::uint32_t>(old >> 59u);
        return (xorshifted >> rotation) | (xorshifted << ((32u - rotation) & 31u));
    }

    // A float in [0, 1): the top 24 bits (a float's significand width) times 2^-24. Both steps are exact,
    // so the result is the same bits on every IEEE-754 platform, and 1.0 is never returned.
    constexpr float uniform01() {
        return static_cast<float>(next_u32() >> 8u) * kTwoToMinus24;
    }

    // An integer in [0, n), n > 0: the 32 bits scaled by n (Lemire's multiply-shift). Bias below n/2^32, and
    // no loop, so a sequence of draws is the same on every platform; for shuffles and test inputs.
    constexpr std::uint32_t below(std::uint32_t n) {
        return static_cast<std::uint32_t>((std::uint64_t{next_u32()} * n) >> 32u);
    }

    // a + (b − a)·u, u = uniform01(). Two correctly rounded float operations (the build disables FMA
    // contraction), hence bit-exact everywhere. Rounding may return b itself, so the range is [a, b].
    constexpr float uniform(float a, float b) { return a + (b - a) * uniform01(); }

private:
    static constexpr std::uint64_t kMultiplier = 6364136223846793005u;  // the reference LCG multiplier
    static constexpr float kTwoToMinus24 = 1.0f / 16777216.0f;           // exact: a power of two

    std::uint64_t state_;
    std::uint64_t increment_;  // always odd
};

}  // namespace smoketrace
