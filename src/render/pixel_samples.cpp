#include <smoketrace/render/pixel_samples.hpp>

#include <cstdint>
#include <stdexcept>
#include <string>

namespace smoketrace {
namespace {

// The base-2 radical inverse of i as a 32-bit fixed-point fraction: its bits mirrored about the binary
// point. Ranking these integers ranks the radical inverses, with no rounding to think about.
std::uint32_t radical_inverse_bits(std::uint32_t i) {
    std::uint32_t r = 0;
    for (int b = 0; b < 32; ++b, i >>= 1) r = (r << 1) | (i & 1u);
    return r;
}

void check_count(int n) {
    if (n < 1 || n > kMaxSpp)
        throw std::invalid_argument("pixel samples: the count must be in [1, " + std::to_string(kMaxSpp) + "] (got " +
                                    std::to_string(n) + ")");
}

}  // namespace

glm::vec2 subpixel_offset(int i, int n) {
    check_count(n);
    if (i < 0 || i >= n)
        throw std::invalid_argument("pixel samples: sample " + std::to_string(i) + " of " + std::to_string(n) +
                                    " does not exist");
    // π(i): how many of 0 … n − 1 have a smaller radical inverse (they are distinct, so π is a permutation).
    const std::uint32_t own = radical_inverse_bits(std::uint32_t(i));
    int rank = 0;
    for (int j = 0; j < n; ++j) rank += radical_inverse_bits(std::uint32_t(j)) < own ? 1 : 0;
    // (k + 0.5)/n <= 1 − 1/(2n) rounds to a float below 1 for every n <= kMaxSpp, so the point stays inside.
    return {(float(i) + 0.5f) / float(n), (float(rank) + 0.5f) / float(n)};
}

PixelSamples::PixelSamples(int n) : count_(n) {
    check_count(n);
    for (int i = 0; i < n; ++i) offsets_[std::size_t(i)] = subpixel_offset(i, n);
}

}  // namespace smoketrace
