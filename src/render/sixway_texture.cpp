// Six-way lighting textures: validation, atlas re-layout and the sidecar loader (see sixway_texture.hpp).
#include <smoketrace/render/sixway_texture.hpp>

#include <smoketrace/io/png_io.hpp>

#include <nlohmann/json.hpp>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

namespace smoketrace {

namespace fs = std::filesystem;

namespace {

std::string grid_text(SixwayAtlasGrid g) {
    return std::to_string(g.frames) + " frames in " + std::to_string(g.columns) + " columns x " +
           std::to_string(g.rows) + " rows";
}

// Empty when the grid is usable, else what is wrong with it.
std::string grid_problem(SixwayAtlasGrid g) {
    if (g.frames < 1 || g.frames > kSixwayMaxFrames)
        return "frames must be in [1, " + std::to_string(kSixwayMaxFrames) + "], got " + std::to_string(g.frames);
    if (g.columns < 1 || g.rows < 1 || g.columns > kMaxImageSide || g.rows > kMaxImageSide)
        return "columns and rows must be in [1, " + std::to_string(kMaxImageSide) + "], got " +
               std::to_string(g.columns) + " x " + std::to_string(g.rows);
    if (g.frames > g.columns * g.rows) return grid_text(g) + ": more frames than tiles";
    return {};
}

[[noreturn]] void layout_error(const fs::path& file, const std::string& pointer, const std::string& problem) {
    throw std::runtime_error("'" + file.string() + "': " + pointer + ": " + problem);
}

int read_int(const nlohmann::json& doc, const fs::path& file, const char* key, int min, int max) {
    const std::string pointer = std::string("/") + key;
    if (!doc.contains(key)) layout_error(file, pointer, "missing");
    const nlohmann::json& j = doc.at(key);
    if (!j.is_number_integer() || j.get<long long>() < min || j.get<long long>() > max)
        layout_error(file, pointer, "must be an integer in [" + std::to_string(min) + ", " + std::to_string(max) +
                                        "], got " + j.dump());
    return int(j.get<long long>());
}

std::string read_file_name(const nlohmann::json& doc, const fs::path& file, const char* key) {
    const std::string pointer = std::string("/") + key;
    if (!doc.contains(key)) layout_error(file, pointer, "missing");
    const nlohmann::json& j = doc.at(key);
    if (!j.is_string() || j.get<std::string>().empty()) layout_error(file, pointer, "must be a non-empty file name");
    return j.get<std::string>();
}

}  // namespace

SixwayAtlasGrid sixway_grid_for_frames(int frames) {
    if (frames < 1 || frames > kSixwayMaxFrames)
        throw std::invalid_argument("six-way atlas: frames must be in [1, " + std::to_string(kSixwayMaxFrames) +
                                    "], got " + std::to_string(frames));
    int columns = 1;
    while (columns * columns < frames) ++columns;  // ceil(sqrt(frames)) without floating point
    return {frames, columns, (frames + columns - 1) / columns};
}

SixwayTexture::SixwayTexture(const Rgba8Image& positive, const Rgba8Image& negative, SixwayAtlasGrid grid) {
    if (const std::string problem = grid_problem(grid); !problem.empty())
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
            }
    }
}

SixwayTexture SixwayTexture::load(const fs::path& positive_png, const fs::path& negative_png, SixwayAtlasGrid grid) {
    if (const std::string problem = grid_problem(grid); !problem.empty())
        throw std::runtime_error("six-way texture '" + positive_png.string() + "': " + problem);
    const Rgba8Image positive = read_png_rgba8(positive_png);
    const Rgba8Image negative = read_png_rgba8(negative_png, positive.width, positive.height);
    if (positive.width % grid.columns != 0 || positive.height % grid.rows != 0 || positive.width < grid.columns ||
        positive.height < grid.rows)
        throw std::runtime_error("six-way texture '" + positive_png.string() + "': size " +
                                 std::to_string(positive.width) + "x" + std::to_string(positive.height) +
                                 " does not divide into " + grid_text(grid));
    return SixwayTexture(positive, negative, grid);
}

SixwayLayout read_sixway_layout(const fs::path& layout_json) {
    std::ifstream in(layout_json, std::ios::binary);
    if (!in) throw std::runtime_error("cannot read '" + layout_json.string() + "': " + std::strerror(errno));
    std::stringstream text;
    text << in.rdbuf();
    nlohmann::json doc;
    try {
        doc = nlohmann::json::parse(text.str());
    } catch (const nlohmann::json::parse_error& e) {
        throw std::runtime_error("'" + layout_json.string() + "': not valid JSON: " + e.what());
    }
    if (!doc.is_object()) layout_error(layout_json, "(document root)", "must be an object");
    if (!doc.contains("format") || doc.at("format") != kSixwayFormatName)
        layout_error(layout_json, "/format", "must be \"" + std::string(kSixwayFormatName) + "\"");
    read_int(doc, layout_json, "version", kSixwayFormatVersion, kSixwayFormatVersion);
    SixwayAtlasGrid grid;
    grid.frames = read_int(doc, layout_json, "frames", 1, kSixwayMaxFrames);
    grid.columns = read_int(doc, layout_json, "columns", 1, kMaxImageSide);
    grid.rows = read_int(doc, layout_json, "rows", 1, kMaxImageSide);
    if (const std::string problem = grid_problem(grid); !problem.empty())
        layout_error(layout_json, "/frames", problem);
    const fs::path folder = layout_json.parent_path();
    return {grid, folder / read_file_name(doc, layout_json, "positive"),
            folder / read_file_name(doc, layout_json, "negative")};
}

SixwayTexture SixwayTexture::load(const fs::path& layout_json) {
    const SixwayLayout layout = read_sixway_layout(layout_json);
    return load(layout.positive, layout.negative, layout.grid);
}

}  // namespace smoketrace
