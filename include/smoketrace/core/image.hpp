#pragma once
// Images in memory: linear-light float RGBA (what the renderer computes) and 8-bit RGBA (what PNG files
// and textures hold), with the conversions between them. Rows are stored top row first, the order PNG uses.
#include <smoketrace/core/huge_page_allocator.hpp>

#include <glm/vec4.hpp>

#include <cassert>
#include <cstddef>
#include <cstdint>
#include <new>
#include <utility>
#include <vector>

namespace smoketrace {

// Largest width or height accepted anywhere an image is made or read: bounds the pixel count so that
// width·height·4 bytes never overflows and a corrupt header cannot ask for gigabytes.
inline constexpr int kMaxImageSide = 16384;
// Largest pixel count: 2^26 pixels of RGBA float are 1 GiB, the most a render may take.
inline constexpr std::uint64_t kMaxImagePixels = std::uint64_t{1} << 26;

// Allocator of the float image's pixels. A 1024² frame is 16 MB: with 4 KB pages that is 4,096 page
// faults on first touch, which cost tens of milliseconds in a virtual machine. The buffer is aligned
// to 2 MB and advised as huge pages (Linux; elsewhere a no-op), and vector::resize leaves the pixels
// uninitialised (default-initialised glm::vec4), so a renderer that writes every pixel touches each
// page once, inside its parallel loop.
template <class T>
struct PixelAllocator {
    using value_type = T;
    PixelAllocator() = default;
    template <class U>
    PixelAllocator(const PixelAllocator<U>&) {}
    T* allocate(std::size_t n);
    void deallocate(T* p, std::size_t n) { ::operator delete(p, alignment_for(n * sizeof(T))); }
    template <class U, class... Args>
    void construct(U* p, Args&&... args) {
        if constexpr (sizeof...(Args) == 0)
            ::new (static_cast<void*>(p)) U;  // default-initialise: no zeroing pass
        else
            ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
    template <class U>
    bool operator==(const PixelAllocator<U>&) const { return true; }

    static constexpr std::size_t kAlignment = kHugePageBytes;
    // Small images (tests, textures' neighbours) keep a cache-line alignment and waste nothing.
    static std::align_val_t alignment_for(std::size_t bytes) {
        return std::align_val_t{bytes >= kAlignment ? kAlignment : std::size_t{64}};
    }
};

template <class T>
T* PixelAllocator<T>::allocate(std::size_t n) {
    const std::size_t bytes = n * sizeof(T);
    void* p = ::operator new(bytes, alignment_for(bytes));
    advise_huge_pages(p, bytes);
    return static_cast<T*>(p);
}

// Linear-light RGBA, one glm::vec4 per pixel, row-major, top row first. Alpha is straight (not
// premultiplied) coverage.
struct ImageRgba {
    int width = 0;
    int height = 0;
    std::vector<glm::vec4, PixelAllocator<glm::vec4>> pixels;

    ImageRgba() = default;
    // Throws std::invalid_argument unless 0 <= width, height <= kMaxImageSide.
    ImageRgba(int width, int height, glm::vec4 fill = glm::vec4(0.0f));
    // The same size with the pixels left unset, for a writer that sets every one of them.
    struct Uninitialized {};
    ImageRgba(int width, int height, Uninitialized);

    [[nodiscard]] glm::vec4& at(int x, int y) {
        assert(x >= 0 && x < width && y >= 0 && y < height);
        return pixels[std::size_t(y) * std::size_t(width) + std::size_t(x)];
    }
    [[nodiscard]] const glm::vec4& at(int x, int y) const {
        assert(x >= 0 && x < width && y >= 0 && y < height);
        return pixels[std::size_t(y) * std::size_t(width) + std::size_t(x)];
    }
};

// 8-bit RGBA, four bytes per pixel (R, G, B, A), row-major, top row first. What it encodes (sRGB colour
// or linear data such as the six-way light maps) is up to its producer.
struct Rgba8Image {
    int width = 0;
    int height = 0;
    std::vector<std::uint8_t> pixels;  // width·height·4 bytes

    Rgba8Image() = default;
    // Zero-filled. Throws std::invalid_argument unless 0 <= width, height <= kMaxImageSide.
    Rgba8Image(int width, int height);

    [[nodiscard]] std::uint8_t* texel(int x, int y) {
        assert(x >= 0 && x < width && y >= 0 && y < height);
        return pixels.data() + (std::size_t(y) * std::size_t(width) + std::size_t(x)) * 4;
    }
    [[nodiscard]] const std::uint8_t* texel(int x, int y) const {
        assert(x >= 0 && x < width && y >= 0 && y < height);
        return pixels.data() + (std::size_t(y) * std::size_t(width) + std::size_t(x)) * 4;
    }
};

// Linear value in [0, 1] -> nearest 8-bit code, round half up: for data stored linearly (alpha, light
// maps). Values below 0 (and NaN) give 0, values above 1 give 255.
[[nodiscard]] inline std::uint8_t unorm8(float value) noexcept {
    // Written as "value > 0" so that NaN, which fails every comparison, lands on 0.
    const float clamped = value > 0.0f ? (value < 1.0f ? value : 1.0f) : 0.0f;
    return static_cast<std::uint8_t>(clamped * 255.0f + 0.5f);
}

// The sRGB transfer function (IEC 61966-2-1): linear light -> nearest 8-bit sRGB code. Exact: the result
// is round(255 · encode(clamp(value, 0, 1))) evaluated in exact arithmetic, found by comparing `value`
// with the 255 decision thresholds decode((k - 0.5) / 255) precomputed in double precision, so it does
// not depend on the rounding of a float pow() and is the same on every thread and every run.
// NaN and values <= 0 give 0, values >= 1 give 255. 0.5 gives 188.
[[nodiscard]] std::uint8_t linear_to_srgb8(float value) noexcept;

// The inverse: 8-bit sRGB code -> linear light, in double precision (a table lookup).
[[nodiscard]] double srgb8_to_linear(std::uint8_t code) noexcept;

// Linear image -> 8-bit: RGB through the sRGB transfer function, alpha stored linearly (it is coverage,
// not light). Non-finite values must have been rejected by the caller (see write_png_srgb).
[[nodiscard]] Rgba8Image to_srgb8(const ImageRgba& image);

// The same into `samples`, resized to width·height·channels: `channels` 4 gives RGBA as above, 3 drops
// alpha (RGB). Parallel over pixels, the same bytes on any number of threads. A caller that keeps
// `samples` from frame to frame (PngWriter) reuses its memory: fresh pages cost a fault each on first
// touch, about as much as the encoding itself for a 1024² frame.
void to_srgb8(const ImageRgba& image, int channels, std::vector<std::uint8_t>& samples);

}  // namespace smoketrace
