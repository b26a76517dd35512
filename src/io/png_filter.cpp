// The PNG writer's Paeth filter (png_filter.hpp): a kernel source, compiled once per kernel level.
#include "png_filter.hpp"

#include <cstdlib>

namespace smoketrace {

namespace {

// Paeth's predictor (PNG specification, 9.4): the neighbour closest to left + up − upper-left.
std::uint8_t paeth(int left, int up, int upper_left) {
    const int p = left + up - upper_left;
    const int pl = std::abs(p - left), pu = std::abs(p - up), pul = std::abs(p - upper_left);
    if (pl <= pu && pl <= pul) return std::uint8_t(left);
    return std::uint8_t(pu <= pul ? up : upper_left);
}

}  // namespace

template <simd::Level L>
void detail::paeth_filter_rows_at_level(const std::uint8_t* data, std::size_t stride, std::size_t height,
                                        std::size_t channels, std::uint8_t* rows) {
    static_assert(L == simd::kCompiledLevel);
    const std::size_t c = channels;
    for (std::size_t y = 0; y < height; ++y) {
        const std::uint8_t* row = data + y * stride;
        const std::uint8_t* above = y > 0 ? row - stride : nullptr;
        std::uint8_t* out = rows + y * (stride + 1);
        out[0] = 4;  // Paeth
        // Missing neighbours count as 0 (left of the first pixel, above the first row). The first pixel
        // separately, so that the loop over the rest has no such cases and vectorises.
        for (std::size_t i = 0; i < c; ++i) out[1 + i] = std::uint8_t(row[i] - paeth(0, above ? above[i] : 0, 0));
        if (above) {
            for (std::size_t i = c; i < stride; ++i)
                out[1 + i] = std::uint8_t(row[i] - paeth(row[i - c], above[i], above[i - c]));
        } else {
            for (std::size_t i = c; i < stride; ++i) out[1 + i] = std::uint8_t(row[i] - paeth(row[i - c], 0, 0));
        }
    }
}

// This copy's filter (core/simd/dispatch.hpp); the writer in png_io.cpp runs it.
template void detail::paeth_filter_rows_at_level<simd::kCompiledLevel>(const std::uint8_t*, std::size_t, std::size_t,
                                                                       std::size_t, std::uint8_t*);

}  // namespace smoketrace
