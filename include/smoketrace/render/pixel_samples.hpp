#pragma once
// Where the samples of a pixel lie, for anti-aliasing: n points in the pixel's unit square [0, 1)², the
// same n points in every pixel, averaged with equal weights (a box filter) by the view pass.
//
// Sample i of n sits at x = (i + 0.5)/n, y = (π(i) + 0.5)/n, where π ranks the base-2 radical inverses of
// 0 … n − 1. So every column and every row of the n × n grid holds exactly one sample (N-rooks), a
// straight edge is resolved to about 1/n of a pixel across it; for n a power of two the points are the
// Hammersley set moved to the centres of its cells (n = 4 is the rotated grid), stratified in every
// power-of-two grid shape with n cells (1 × n, 2 × n/2, …). n = 1 is the pixel's centre, the classic image.
//
// No random jitter: the pattern is a fixed function of n, so an image has no noise and is the same bytes
// on every run and for any thread count. The price is the same pattern in every pixel, which can alias
// against detail as fine as the sample spacing; smoke is soft and the scene's edges are straight.
#include <smoketrace/smoke/scene_description.hpp>

#include <glm/vec2.hpp>

#include <array>
#include <cstddef>

namespace smoketrace {

// Sample i of n (0 <= i < n, 1 <= n <= kMaxSpp) as an offset from the pixel's top-left corner, y down as in
// the image, in [0, 1)². n = 1 gives (0.5, 0.5) exactly. Throws std::invalid_argument outside those ranges.
// O(n) per call: PixelSamples tabulates it once per image.
[[nodiscard]] glm::vec2 subpixel_offset(int i, int n);

// The n offsets of one image's pixels, computed once: a fixed-capacity table, so that the per-pixel loop
// only reads it and allocates nothing. Throws std::invalid_argument unless 1 <= n <= kMaxSpp.
class PixelSamples {
public:
    explicit PixelSamples(int n);

    [[nodiscard]] int count() const { return count_; }
    [[nodiscard]] glm::vec2 operator[](int i) const { return offsets_[std::size_t(i)]; }

private:
    std::array<glm::vec2, kMaxSpp> offsets_{};
    int count_;
};

}  // namespace smoketrace
