// Six-way lighting textures: validation and atlas re-layout (see sixway_texture.hpp); files: io/sixway_files.
#include <smoketrace/render/sixway_texture.hpp>

#include <algorithm>
#include <stdexcept>
#include <string>

namespace smoketrace {

namespace {

std::string grid_text(SixwayAtlasGrid g) {
    return std::to_string(g.frames) + " frames in " + std::to_string(g.columns) + " columns x " +
           std::to_string(g.rows) + " rows";
}

}  // namespace

std::string sixway_grid_problem(SixwayAtlasGrid g) {
    if (g.frames < 1 || g.frames > kSixwayMaxFrames)
        return "frames must be in [1, " + std::to_string(kSixwayMaxFrames) + "], got " + std::to_string(g.frames);
    if (g.columns < 1 || g.rows < 1 || g.columns > kMaxImageSide || g.rows > kMaxImageSide)
        return "columns and rows must be in [1, " + std::to_string(kMaxImageSide) + "], got " +
               std::to_string(g.columns) + " x " + std::to_string(g.rows);
    if (g.frames > g.columns * g.rows) return grid_text(g) + ": more frames than tiles";
    return {};
}

SixwayAtlasGrid sixway_grid_for_frames(int frames) {
    if (frames < 1 || frames > kSixwayMaxFrames)
        throw std::invalid_argument("six-way atlas: frames must be in [1, " + std::to_string(kSixwayMaxFrames) +
                                    "], got " + std::to_string(frames));
    int columns = 1;
    while (columns * columns < frames) ++columns;  // ceil(sqrt(frames)) without floating point
    return {frames, columns, (frames + columns - 1) / columns};
}

SixwayTexture::SixwayTexture(const Rgba8Image& positive, const Rgba8Image& negative, SixwayAtlasGrid grid) {
    if (const std::string problem = sixway_grid_problem(grid); !problem.empty())
        throw std::invalid_argument("six-way texture: " + problem);
    if (positive.width != negative.width || positive.height != negative.height)
        throw std::invalid_argument("six-way texture: the positive atlas is " + std::to_string(positive.width) + "x" +
                                    std::to_string(positive.height) + " but the negative one is " +
                                    std::to_string(negative.width) + "x" + std::to_string(negative.height));
    const auto bytes_of = [](const Rgba8Image& im) { return std::size_t(im.width) * std::size_t(im.height) * 4; };
    if (positive.pixels.size() != bytes_of(positive) || negative.pixels.size() != bytes_of(negative))
        throw std::invalid_argument("six-way texture: pixel buffer size does not match the image size");
    if (positive.width < grid.columns || positive.height < grid.rows || positive.width % grid.columns != 0 ||
        positive.height % grid.rows != 0)
        throw std::invalid_argument("six-way texture: atlas size " + std::to_string(positive.width) + "x" +
                                    std::to_string(positive.height) + " does not divide into " + grid_text(grid));
    grid_ = grid;
    tile_width_ = positive.width / grid.columns;
    tile_height_ = positive.height / grid.rows;
    tile_texels_ = std::size_t(tile_width_) * std::size_t(tile_height_);
    texels_.resize(tile_texels_ * std::size_t(grid.frames));
    alpha_.resize(texels_.size());
    alpha_support_.assign(std::size_t(grid.frames), AlphaSupport{tile_width_, -1, tile_height_, -1});
    for (int f = 0; f < grid.frames; ++f) {
        const int x0 = (f % grid.columns) * tile_width_, y0 = (f / grid.columns) * tile_height_;
        for (int y = 0; y < tile_height_; ++y)
            for (int x = 0; x < tile_width_; ++x) {
                Texel& t = texels_[std::size_t(f) * tile_texels_ + std::size_t(y) * std::size_t(tile_width_) + std::size_t(x)];
                const std::uint8_t* p = positive.texel(x0 + x, y0 + y);
                const std::uint8_t* n = negative.texel(x0 + x, y0 + y);
                for (int c = 0; c < 4; ++c) {
                    t.pos[c] = p[c];
                    t.neg[c] = n[c];
                }
                alpha_[std::size_t(&t - texels_.data())] = p[3];
                if (p[3] != 0) {
                    AlphaSupport& a = alpha_support_[std::size_t(f)];
                    a.x_lo = std::min(a.x_lo, x);
                    a.x_hi = std::max(a.x_hi, x);
                    a.y_lo = std::min(a.y_lo, y);
                    a.y_hi = std::max(a.y_hi, y);
                }
            }
    }
}

}  // namespace smoketrace
