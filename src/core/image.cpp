// Image storage and the sRGB transfer function (see image.hpp).
#include <smoketrace/core/image.hpp>

#include <tbb/parallel_for.h>

#include <array>
#include <bit>
#include <cmath>
#include <stdexcept>
#include <string>

namespace smoketrace {

namespace {

void check_size(const char* what, int width, int height) {
    if (width < 0 || height < 0 || width > kMaxImageSide || height > kMaxImageSide)
        throw std::invalid_argument(std::string(what) + ": size " + std::to_string(width) + "x" +
                                    std::to_string(height) + " is outside [0, " + std::to_string(kMaxImageSide) + "]");
}

// IEC 61966-2-1 decoding (sRGB value in [0, 1] -> linear light), in double precision.
double srgb_decode(double s) {
    return s <= 0.04045 ? s / 12.92 : std::pow((s + 0.055) / 1.055, 2.4);
}

// thresholds[k - 1] = decode((k - 0.5) / 255) for k = 1..255: the linear value at which the nearest 8-bit
// code steps from k - 1 to k. The standard's two pieces meet at encoded 0.04045 (code 10.31), between the
// thresholds of codes 10 and 11, so decode is the exact inverse of encode at every threshold.
const std::array<double, 255>& srgb_thresholds() {
    static const std::array<double, 255> table = [] {
        std::array<double, 255> t{};
        for (int k = 1; k <= 255; ++k) t[std::size_t(k - 1)] = srgb_decode((k - 0.5) / 255.0);
        return t;
    }();
    return table;
}

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

const SrgbEncodeTable& srgb_encode_table() {
    static const SrgbEncodeTable table = [] {
        SrgbEncodeTable e;
        const auto& t = srgb_thresholds();
        for (std::size_t k = 0; k < 255; ++k) {
            float f = static_cast<float>(t[k]);
            if (double(f) < t[k]) f = std::nextafter(f, 2.0f);  // the least float >= t[k]
            e.first_bits[k] = std::bit_cast<std::uint32_t>(f);
        }
        e.first_bits[255] = kOneBits;  // values from 1 up never get here
        std::uint8_t code = 0;
        for (std::size_t b = 0; b < kBuckets; ++b) {
            const std::uint32_t lowest = kFirstBucketBits + (std::uint32_t(b) << kBucketShift);
            while (lowest >= e.first_bits[code]) ++code;
            e.base[b] = code;
        }
        return e;
    }();
    return table;
}

}  // namespace

ImageRgba::ImageRgba(int w, int h, glm::vec4 fill) : width(w), height(h) {
    check_size("ImageRgba", w, h);
    pixels.assign(std::size_t(w) * std::size_t(h), fill);
}

ImageRgba::ImageRgba(int w, int h, Uninitialized) : width(w), height(h) {
    check_size("ImageRgba", w, h);
    pixels.resize(std::size_t(w) * std::size_t(h));
}

Rgba8Image::Rgba8Image(int w, int h) : width(w), height(h) {
    check_size("Rgba8Image", w, h);
    pixels.assign(std::size_t(w) * std::size_t(h) * 4, 0);
}

std::uint8_t linear_to_srgb8(float value) noexcept {
    if (!(value > 0.0f)) return 0;  // also NaN and -0, whose sign bit would read as a huge code below
    const std::uint32_t bits = std::bit_cast<std::uint32_t>(value);
    if (bits < kFirstBucketBits) return 0;
    if (bits >= kOneBits) return 255;
    const SrgbEncodeTable& e = srgb_encode_table();
    unsigned code = e.base[(bits - kFirstBucketBits) >> kBucketShift];
    code += bits >= e.first_bits[code];          // the one threshold a bucket may hold, without a branch
    while (bits >= e.first_bits[code]) ++code;  // never taken with today's spacing; keeps it exact regardless
    return static_cast<std::uint8_t>(code);
}

double srgb8_to_linear(std::uint8_t code) noexcept {
    static const std::array<double, 256> table = [] {
        std::array<double, 256> t{};
        for (int k = 0; k < 256; ++k) t[std::size_t(k)] = srgb_decode(k / 255.0);
        return t;
    }();
    return table[code];
}

Rgba8Image to_srgb8(const ImageRgba& image) {
    Rgba8Image out;
    to_srgb8(image, 4, out.pixels);
    out.width = image.width;
    out.height = image.height;
    return out;
}

void to_srgb8(const ImageRgba& image, int channels, std::vector<std::uint8_t>& samples) {
    if (channels != 3 && channels != 4)
        throw std::invalid_argument("to_srgb8: " + std::to_string(channels) + " channels (3 or 4 expected)");
    const std::size_t c = std::size_t(channels);
    samples.resize(image.pixels.size() * c);
    // Each pixel on its own: the same bytes on any number of threads.
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, image.pixels.size(), 1 << 14),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t i = r.begin(); i < r.end(); ++i) {
                              const glm::vec4 p = image.pixels[i];
                              std::uint8_t* o = samples.data() + i * c;
                              o[0] = linear_to_srgb8(p.x);
                              o[1] = linear_to_srgb8(p.y);
                              o[2] = linear_to_srgb8(p.z);
                              if (c == 4) o[3] = unorm8(p.w);
                          }
                      });
}

}  // namespace smoketrace
