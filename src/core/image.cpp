// Image storage and the sRGB transfer function (see image.hpp).
#include <smoketrace/core/image.hpp>
#include <smoketrace/core/simd/dispatch.hpp>

#include "srgb_encode.hpp"

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

}  // namespace

const detail::SrgbEncodeTable& detail::srgb_encode_table() {
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
    return detail::srgb8_code(detail::srgb_encode_table(), value);
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
    samples.resize(image.pixels.size() * std::size_t(channels));
    simd::at_active_level([&]<simd::Level L> { detail::to_srgb8_at_level<L>(image, channels, samples.data()); });
}

}  // namespace smoketrace
