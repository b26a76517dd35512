// Image storage and the sRGB transfer function (see image.hpp).
#include <smoketrace/image.hpp>

#if defined(__linux__)
#include <sys/mman.h>
#endif

#include <algorithm>
#include <array>
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

ImageRgba::ImageRgba(int w, int h, glm::vec4 fill) : width(w), height(h) {
    check_size("ImageRgba", w, h);
    pixels.assign(std::size_t(w) * std::size_t(h), fill);
}

ImageRgba::ImageRgba(int w, int h, Uninitialized) : width(w), height(h) {
    check_size("ImageRgba", w, h);
    pixels.resize(std::size_t(w) * std::size_t(h));
}

void advise_huge_pages([[maybe_unused]] void* p, [[maybe_unused]] std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    // Only whole 2 MB pages inside the buffer; advice is a hint, so a failure changes nothing.
    if (bytes >= PixelAllocator<char>::kAlignment) (void)::madvise(p, bytes, MADV_HUGEPAGE);
#endif
}

Rgba8Image::Rgba8Image(int w, int h) : width(w), height(h) {
    check_size("Rgba8Image", w, h);
    pixels.assign(std::size_t(w) * std::size_t(h) * 4, 0);
}

std::uint8_t linear_to_srgb8(float value) noexcept {
    if (!(value > 0.0f)) return 0;  // also NaN
    const auto& t = srgb_thresholds();
    // Code = number of thresholds at or below the value (8 comparisons).
    return static_cast<std::uint8_t>(std::upper_bound(t.begin(), t.end(), double(value)) - t.begin());
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
    Rgba8Image out(image.width, image.height);
    for (std::size_t i = 0; i < image.pixels.size(); ++i) {
        const glm::vec4 p = image.pixels[i];
        std::uint8_t* o = out.pixels.data() + i * 4;
        o[0] = linear_to_srgb8(p.x);
        o[1] = linear_to_srgb8(p.y);
        o[2] = linear_to_srgb8(p.z);
        o[3] = unorm8(p.w);
    }
    return out;
}

}  // namespace smoketrace
