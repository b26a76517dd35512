#pragma once
// The sRGB encoder's table and lookup (image.hpp's linear_to_srgb8() and to_srgb8()): the table is built
// once, in image.cpp; the lookup is inline, so that linear_to_srgb8() and the image loop, a kernel compiled
// in srgb_encode.cpp once per kernel level (core/simd/dispatch.hpp), share it.
#include <smoketrace/core/image.hpp>
#include <smoketrace/core/simd/level.hpp>

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>

namespace smoketrace::detail {

// The thresholds as float bit patterns, for a search without doubles or branches that mispredict.
// A float v reaches threshold t (double(v) >= t) exactly when v >= the least float >= t, and positive
// floats order as their bits do; so code(v) = #{k : bits(v) >= first_bits[k]}.
//
// Below 2^-13 every value is code 0 (the first threshold is 1.5e-4), from 1 up code 255 (the last is
// 0.9955). In between, `base` maps a float's exponent and top 8 mantissa bits (a bucket 1/256 of an
// octave wide) to the code at the bucket's lower end; at most one threshold falls inside a bucket (they
// are at least 0.9 % apart, a bucket at most 0.4 % wide), so one comparison finishes the job.
constexpr std::uint32_t kFirstBucketBits = 0x39000000u;  // 2^-13
constexpr std::uint32_t kOneBits = 0x3F800000u;          // 1.0f
constexpr int kBucketShift = 15;                          // 23 mantissa bits - 8 kept
constexpr std::size_t kBuckets = (kOneBits - kFirstBucketBits) >> kBucketShift;

struct SrgbEncodeTable {
    std::array<std::uint32_t, 256> first_bits{};  // [k]: least float bits of code k + 1; [255]: never reached
    std::array<std::uint8_t, kBuckets> base{};
};

// The table, built on first use (thread-safe).
const SrgbEncodeTable& srgb_encode_table();

// linear_to_srgb8(value) from the table.
inline std::uint8_t srgb8_code(const SrgbEncodeTable& e, float value) noexcept {
    if (!(value > 0.0f)) return 0;  // also NaN and -0, whose sign bit would read as a huge code below
    const std::uint32_t bits = std::bit_cast<std::uint32_t>(value);
    if (bits < kFirstBucketBits) return 0;
    if (bits >= kOneBits) return 255;
    unsigned code = e.base[(bits - kFirstBucketBits) >> kBucketShift];
    code += bits >= e.first_bits[code];          // the one threshold a bucket may hold, without a branch
    while (bits >= e.first_bits[code]) ++code;  // never taken with today's spacing; keeps it exact regardless
    return static_cast<std::uint8_t>(code);
}

// to_srgb8(image, channels, ...) into `samples` (image.pixels.size() · channels bytes; channels 3 or 4).
template <simd::Level L>
void to_srgb8_at_level(const ImageRgba& image, int channels, std::uint8_t* samples);

}  // namespace smoketrace::detail
