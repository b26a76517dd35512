#pragma once
// Six-way lighting textures at render time (thesis 4.2.2, 4.3.5; method.md "Six-way lighting").
//
// Two RGBA flipbook atlases. Positive: R = lit from the right (+x), G = from the top (+y), B = from the
// front (+z, the viewer's side), A = alpha. Negative: R = left (-x), G = bottom (-y), B = back (-z),
// A = alpha again (so each file views as the puff on its own; sample() uses the positive one's).
// The channels are DATA stored linearly in 8 bits (value = code / 255), not sRGB colour: a light-map
// value is the fraction of the light's radiance the smoke sends toward the viewer per unit of alpha, so
// the shaded colour is light_map · light colour · alpha (thesis 4.3.5). They are straight, not
// premultiplied by alpha.
//
// Atlas layout: frame f occupies the tile at column f % columns, row f / columns, row 0 at the top of the
// image; every tile has the same size (atlas width / columns) x (atlas height / rows). The grid is not
// stored in the PNGs: it comes with them in a JSON sidecar (kSixwayLayoutFile, written by the baker):
//   { "format": "smoketrace-sixway", "version": 1, "frames": 16, "columns": 4, "rows": 4,
//     "positive": "sixway_pos.png", "negative": "sixway_neg.png", "bake": { ...settings... } }
// PNG names are relative to the sidecar's folder; "bake" records how the textures were made.
//
// Tile coordinates: uv in [0, 1]², u to the right (+x), v UP (+y), i.e. the billboard's tangent space.
// uv (0, 0) is the bottom-left corner of the tile as seen in the image.
#include <smoketrace/core/image.hpp>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <cassert>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace smoketrace {

inline constexpr std::string_view kSixwayPositiveFile = "sixway_pos.png";
inline constexpr std::string_view kSixwayNegativeFile = "sixway_neg.png";
inline constexpr std::string_view kSixwayLayoutFile = "sixway.json";
inline constexpr std::string_view kSixwayFormatName = "smoketrace-sixway";
inline constexpr int kSixwayFormatVersion = 1;
// Upper bound on flipbook frames (the thesis used 128); catches a corrupt or mistyped sidecar.
inline constexpr int kSixwayMaxFrames = 4096;

// How the frames of a flipbook are laid out in an atlas (see above).
struct SixwayAtlasGrid {
    int frames = 0;
    int columns = 0;
    int rows = 0;
};

// The near-square grid the baker uses: columns = ceil(sqrt(frames)), rows = ceil(frames / columns)
// (16 -> 4x4, 128 -> 12x11). Throws std::invalid_argument unless 1 <= frames <= kSixwayMaxFrames.
[[nodiscard]] SixwayAtlasGrid sixway_grid_for_frames(int frames);

// One filtered look-up: light-map values (linear, [0, 1]) and alpha.
struct SixwaySample {
    glm::vec3 pos{0.0f};  // lit from +x, +y, +z
    glm::vec3 neg{0.0f};  // lit from -x, -y, -z
    float alpha = 0.0f;
};

// Empty when the grid is usable (1 <= frames <= columns·rows, frames <= kSixwayMaxFrames, columns and rows
// in [1, kMaxImageSide]), else what is wrong with it.
[[nodiscard]] std::string sixway_grid_problem(SixwayAtlasGrid grid);

class SixwayTexture {
    // Both textures' bytes for one texel side by side: a bilinear look-up touches 4 of these, 32 bytes.
    struct Texel {
        std::uint8_t pos[4];
        std::uint8_t neg[4];
    };

public:
    SixwayTexture() = default;
    // From atlases in memory. Throws std::invalid_argument unless both have the same size, the grid is
    // valid (1 <= frames <= columns·rows, frames <= kSixwayMaxFrames) and the size divides by the grid.
    SixwayTexture(const Rgba8Image& positive, const Rgba8Image& negative, SixwayAtlasGrid grid);

    // Files: load_sixway_texture() (io/sixway_files.hpp).

    [[nodiscard]] int frame_count() const { return grid_.frames; }
    [[nodiscard]] SixwayAtlasGrid grid() const { return grid_; }
    [[nodiscard]] int tile_width() const { return tile_width_; }
    [[nodiscard]] int tile_height() const { return tile_height_; }

    // Bilinear look-up in frame `frame` (0 <= frame < frame_count(); the caller wraps its animation
    // clock). Texel centres sit at uv = ((x + 0.5) / tile_width, 1 - (y + 0.5) / tile_height) for image
    // row y of the tile. Coordinates are clamped to the outermost texel centres of the tile, so a look-up
    // never reads a neighbouring frame, and uv outside [0, 1]² (or NaN) repeats the tile's edge; whether
    // a point is on the billboard at all is the caller's test. Allocation-free.
    [[nodiscard]] SixwaySample sample(glm::vec2 uv, int frame) const noexcept;

    // The unfiltered texel at column x, image row y (0 = top) of a frame's tile.
    [[nodiscard]] SixwaySample texel(int x, int y, int frame) const noexcept;

    // sample() in two halves, for a renderer that needs a layer's colour only when the layer is seen: the
    // four texels and weights of a look-up, then its alpha and its six-way light map (sixway_light_map()
    // of the sample, computed from the three channels the light picks rather than all eight). Each gives
    // the bits sample() and sixway_light_map(sample(), l) would. alpha() reads a plane of alpha bytes kept
    // beside the texels, an eighth of their size: a renderer asks every layer it meets for its opacity and
    // few of them for their colour, so that plane is what stays in the cache.
    struct Footprint {
        std::size_t i00, i10, i01, i11;  // texel indices
        float w00, w10, w01, w11;
        bool clear;  // all four texels have alpha 0 (outside the frame's puff): alpha() is 0 unread
    };
    [[nodiscard]] Footprint footprint(glm::vec2 uv, int frame) const noexcept;
    [[nodiscard]] float alpha(const Footprint& f) const noexcept;
    [[nodiscard]] float light_map(const Footprint& f, glm::vec3 light_tangent) const noexcept;

private:
    [[nodiscard]] const Texel& at(int x, int y, int frame) const noexcept {
        return texels_[index(x, y, frame)];
    }
    [[nodiscard]] std::size_t index(int x, int y, int frame) const noexcept {
        assert(frame >= 0 && frame < grid_.frames && x >= 0 && x < tile_width_ && y >= 0 && y < tile_height_);
        return std::size_t(frame) * tile_texels_ + std::size_t(y) * std::size_t(tile_width_) + std::size_t(x);
    }
    static glm::vec4 unpack(const std::uint8_t* c) noexcept {
        return {float(c[0]), float(c[1]), float(c[2]), float(c[3])};
    }

    SixwayAtlasGrid grid_{};
    int tile_width_ = 0;
    int tile_height_ = 0;
    std::size_t tile_texels_ = 0;
    // Frame-major (each tile contiguous, rows top first): a look-up stays within one small block.
    std::vector<Texel> texels_;
    std::vector<std::uint8_t> alpha_;  // texels_[i].pos[3] at [i]
    // Per frame, the texel rectangle holding every texel of nonzero alpha (empty: lo > hi): most of a
    // billboard's quad lies outside its puff, and there a look-up need not touch the texture at all.
    struct AlphaSupport {
        int x_lo, x_hi, y_lo, y_hi;
    };
    std::vector<AlphaSupport> alpha_support_;
};

inline SixwaySample SixwayTexture::texel(int x, int y, int frame) const noexcept {
    const Texel& t = at(x, y, frame);
    constexpr float kScale = 1.0f / 255.0f;
    return {glm::vec3(t.pos[0], t.pos[1], t.pos[2]) * kScale, glm::vec3(t.neg[0], t.neg[1], t.neg[2]) * kScale,
            float(t.pos[3]) * kScale};
}

inline SixwayTexture::Footprint SixwayTexture::footprint(glm::vec2 uv, int frame) const noexcept {
    // Continuous texel coordinates with texel centres at integers; v grows up, image rows go down.
    float x = uv.x * float(tile_width_) - 0.5f;
    float y = (1.0f - uv.y) * float(tile_height_) - 0.5f;
    // Clamp to the outermost texel centres. "x > 0" is false for NaN, which therefore becomes 0.
    const float max_x = float(tile_width_ - 1), max_y = float(tile_height_ - 1);
    x = x > 0.0f ? (x < max_x ? x : max_x) : 0.0f;
    y = y > 0.0f ? (y < max_y ? y : max_y) : 0.0f;
    const int x0 = int(x), y0 = int(y);  // x, y >= 0: truncation is floor
    const int x1 = x0 + (x0 < tile_width_ - 1 ? 1 : 0);
    const int y1 = y0 + (y0 < tile_height_ - 1 ? 1 : 0);
    const float fx = x - float(x0), fy = y - float(y0);
    const AlphaSupport& a = alpha_support_[std::size_t(frame)];
    return {index(x0, y0, frame), index(x1, y0, frame), index(x0, y1, frame), index(x1, y1, frame),
            (1.0f - fx) * (1.0f - fy), fx * (1.0f - fy), (1.0f - fx) * fy, fx * fy,
            x1 < a.x_lo || x0 > a.x_hi || y1 < a.y_lo || y0 > a.y_hi};
}

inline SixwaySample SixwayTexture::sample(glm::vec2 uv, int frame) const noexcept {
    const Footprint f = footprint(uv, frame);
    const Texel &t00 = texels_[f.i00], &t10 = texels_[f.i10], &t01 = texels_[f.i01], &t11 = texels_[f.i11];
    constexpr float kScale = 1.0f / 255.0f;
    const glm::vec4 p =
        (unpack(t00.pos) * f.w00 + unpack(t10.pos) * f.w10 + unpack(t01.pos) * f.w01 + unpack(t11.pos) * f.w11) *
        kScale;
    const glm::vec4 n =
        (unpack(t00.neg) * f.w00 + unpack(t10.neg) * f.w10 + unpack(t01.neg) * f.w01 + unpack(t11.neg) * f.w11) *
        kScale;
    return {glm::vec3(p), glm::vec3(n), p.w};
}

inline float SixwayTexture::alpha(const Footprint& f) const noexcept {
    // sample()'s alpha lane: the same products and sums in the same order, which for four zero texels and
    // weights >= 0 is +0.
    if (f.clear) return 0.0f;
    constexpr float kScale = 1.0f / 255.0f;
    return (float(alpha_[f.i00]) * f.w00 + float(alpha_[f.i10]) * f.w10 + float(alpha_[f.i01]) * f.w01 +
            float(alpha_[f.i11]) * f.w11) * kScale;
}

// The six-way light map of thesis 4.3.5 (textures of 4.2.2): per tangent axis, the positive texture's
// channel when the light lies on that axis's positive side, else the negative one's, weighted by the
// squared direction cosine, so the weights sum to 1 for a unit direction:
//     lightMap = h·lx² + v·ly² + d·lz².
// `light_tangent` is the unit direction TOWARD the light in the billboard's tangent space (x right, y up,
// z toward the viewer); a light shining from the right has lx > 0 and picks the positive R channel.
// The thesis compares with "> 0"; a zero component has zero weight, so the choice there is immaterial.
[[nodiscard]] inline float sixway_light_map(const SixwaySample& s, glm::vec3 light_tangent) noexcept {
    const glm::vec3& l = light_tangent;
    const float h = l.x > 0.0f ? s.pos.x : s.neg.x;
    const float v = l.y > 0.0f ? s.pos.y : s.neg.y;
    const float d = l.z > 0.0f ? s.pos.z : s.neg.z;
    return h * l.x * l.x + v * l.y * l.y + d * l.z * l.z;
}

inline float SixwayTexture::light_map(const Footprint& f, glm::vec3 light_tangent) const noexcept {
    // sixway_light_map(sample(uv), l): each picked channel filtered as sample() filters it, then weighted.
    const glm::vec3& l = light_tangent;
    constexpr float kScale = 1.0f / 255.0f;
    const Texel &t00 = texels_[f.i00], &t10 = texels_[f.i10], &t01 = texels_[f.i01], &t11 = texels_[f.i11];
    auto filtered = [&](bool positive, int k) {
        auto c = [positive, k](const Texel& t) { return float(positive ? t.pos[k] : t.neg[k]); };
        return (c(t00) * f.w00 + c(t10) * f.w10 + c(t01) * f.w01 + c(t11) * f.w11) * kScale;
    };
    const float h = filtered(l.x > 0.0f, 0), v = filtered(l.y > 0.0f, 1), d = filtered(l.z > 0.0f, 2);
    return h * l.x * l.x + v * l.y * l.y + d * l.z * l.z;
}

}  // namespace smoketrace
