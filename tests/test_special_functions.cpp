// exp_negative() and erf() over lanes (core/simd/special_functions.hpp) against std::exp and std::erf in
// double, over their whole ranges, and every width against width 1 bit for bit.
#include <smoketrace/core/prng.hpp>
#include <smoketrace/core/simd/special_functions.hpp>

#include <catch2/catch.hpp>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

using namespace smoketrace;

namespace {

template <unsigned N, class F>
std::vector<double> at_width(const std::vector<double>& x, F f) {
    std::vector<double> y(x.size());
    alignas(64) double in[N], out[N];
    for (std::size_t i = 0; i < x.size(); i += N) {
        for (unsigned k = 0; k < N; ++k) in[k] = i + k < x.size() ? x[i + k] : 0.0;
        simd::store(out, f(simd::Doubles<N>::load(in)));
        for (unsigned k = 0; k < N && i + k < x.size(); ++k) y[i + k] = out[k];
    }
    return y;
}

bool same_bits(double a, double b) { return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b); }

// Every erf input worth asking: a dense grid over [0, 6] (beyond, erf is 1 to 2·10^-17), every 2^42-nd double
// bit pattern of both signs (all magnitudes, subnormals to the largest), and the special values.
std::vector<double> erf_inputs() {
    std::vector<double> x;
    for (int i = 0; i <= 6'000'000; ++i) x.push_back(i * 1e-6);
    for (std::uint64_t bits = 0; bits < (std::uint64_t(0x7FF) << 52); bits += std::uint64_t(1) << 42) {
        x.push_back(std::bit_cast<double>(bits));
        x.push_back(-std::bit_cast<double>(bits));
    }
    using L = std::numeric_limits<double>;
    for (const double v : {0.0, -0.0, L::min(), L::denorm_min(), L::max(), -L::max(), L::infinity(), -L::infinity()})
        x.push_back(v);
    Pcg32 rng(33);
    for (int i = 0; i < 200'000; ++i) x.push_back((double(rng.next_u32()) / 4294967296.0 - 0.5) * 12.0);
    return x;
}

}  // namespace

TEST_CASE("special functions: erf is within kErfMaxError of std::erf everywhere", "[simd][kernel]") {
    const std::vector<double> x = erf_inputs();
    const std::vector<double> y = at_width<1>(x, [](auto v) { return simd::erf(v); });
    double worst = 0.0, worst_at = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) {
        const double e = std::abs(y[i] - std::erf(x[i]));
        if (!(e <= worst)) worst = e, worst_at = x[i];
    }
    INFO("largest error " << worst << " at x = " << worst_at);
    CHECK(worst <= simd::kErfMaxError);
    // Odd exactly, and 0 → ±1e-9 (the polynomial's coefficients sum to 1 - 1e-9), ±∞ → ±1, NaN → NaN.
    const std::vector<double> specials = {0.5, -0.5, std::numeric_limits<double>::infinity(),
                                          -std::numeric_limits<double>::infinity(),
                                          std::numeric_limits<double>::quiet_NaN()};
    const std::vector<double> s = at_width<1>(specials, [](auto v) { return simd::erf(v); });
    CHECK(s[0] == -s[1]);
    CHECK(s[2] == 1.0);
    CHECK(s[3] == -1.0);
    CHECK(std::isnan(s[4]));
}

TEST_CASE("special functions: erf at every width gives width 1's bits", "[simd][kernel]") {
    const std::vector<double> x = erf_inputs();
    const std::vector<double> one = at_width<1>(x, [](auto v) { return simd::erf(v); });
    auto check = [&](const std::vector<double>& wide, unsigned width) {
        std::size_t differ = 0;
        for (std::size_t i = 0; i < x.size(); ++i)
            differ += !(same_bits(wide[i], one[i]) || (std::isnan(wide[i]) && std::isnan(one[i])));
        INFO("width " << width);
        CHECK(differ == 0);
    };
    check(at_width<2>(x, [](auto v) { return simd::erf(v); }), 2);
    check(at_width<4>(x, [](auto v) { return simd::erf(v); }), 4);
    check(at_width<8>(x, [](auto v) { return simd::erf(v); }), 8);
}

TEST_CASE("special functions: exp_negative is within its relative error of std::exp on its range", "[simd][kernel]") {
    std::vector<double> x;
    for (int i = 0; i <= 1'600'000; ++i) x.push_back(i * 1e-5);
    x.push_back(simd::kExpNegativeMax);
    const std::vector<double> one = at_width<1>(x, [](auto v) { return simd::exp_negative(v); });
    double worst = 0.0, worst_at = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) {
        const double e = std::abs(one[i] - std::exp(-x[i])) / std::exp(-x[i]);
        if (!(e <= worst)) worst = e, worst_at = x[i];
    }
    INFO("largest relative error " << worst << " at x = " << worst_at);
    CHECK(worst <= simd::kExpNegativeMaxError);
    for (const auto& wide : {at_width<4>(x, [](auto v) { return simd::exp_negative(v); }),
                             at_width<8>(x, [](auto v) { return simd::exp_negative(v); })}) {
        std::size_t differ = 0;
        for (std::size_t i = 0; i < x.size(); ++i) differ += !same_bits(wide[i], one[i]);
        CHECK(differ == 0);
    }
}
