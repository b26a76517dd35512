// Six-way lighting textures as files: the two atlas PNGs and their JSON sidecar (see sixway_files.hpp).
#include <smoketrace/io/sixway_files.hpp>

#include <smoketrace/io/json_text_file.hpp>
#include <smoketrace/io/output_path.hpp>
#include <smoketrace/io/png_io.hpp>

#include <nlohmann/json.hpp>

#include <charconv>
#include <cstdlib>
#include <ostream>
#include <stdexcept>
#include <string>

namespace smoketrace {

namespace fs = std::filesystem;

namespace {

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

// A float as the shortest decimal that reads back as the same float, so the sidecar says 0.68, not
// 0.6800000071525574 (nlohmann prints the double the float widens to).
double shortest_decimal(float value) {
    char buffer[32];
    const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
    return std::strtod(std::string(buffer, result.ptr).c_str(), nullptr);
}

}  // namespace

SixwayTexture load_sixway_texture(const fs::path& positive_png, const fs::path& negative_png, SixwayAtlasGrid grid) {
    if (const std::string problem = sixway_grid_problem(grid); !problem.empty())
        throw std::runtime_error("six-way texture '" + positive_png.string() + "': " + problem);
    const Rgba8Image positive = read_png_rgba8_at_most(positive_png, kMaxSixwayAtlasSide, kMaxSixwayAtlasSide);
    const Rgba8Image negative = read_png_rgba8(negative_png, positive.width, positive.height);
    try {
        return SixwayTexture(positive, negative, grid);
    } catch (const std::invalid_argument& e) {  // the atlas size does not divide into the grid
        throw std::runtime_error("'" + positive_png.string() + "': " + e.what());
    }
}

SixwayLayout read_sixway_layout(const fs::path& layout_json) {
    JsonText text;
    try {
        text = read_json_object_text(layout_json, kMaxSixwayLayoutBytes);
    } catch (const JsonTextFileError& e) {
        throw std::runtime_error("cannot read '" + layout_json.string() + "': " + e.what());
    }
    nlohmann::json doc;
    try {
        doc = nlohmann::json::parse(text.view());
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
    if (const std::string problem = sixway_grid_problem(grid); !problem.empty())
        layout_error(layout_json, "/frames", problem);
    const fs::path folder = layout_json.parent_path();
    return {grid, folder / read_file_name(doc, layout_json, "positive"),
            folder / read_file_name(doc, layout_json, "negative")};
}

SixwayBakeSettings read_sixway_bake_settings(const fs::path& layout_json) {
    const SixwayLayout layout = read_sixway_layout(layout_json);  // the format, version and grid checked first
    const nlohmann::json doc = nlohmann::json::parse(read_json_object_text(layout_json, kMaxSixwayLayoutBytes).view());
    if (!doc.contains("bake") || !doc.at("bake").is_object())
        layout_error(layout_json, "/bake", "missing: the ground truth needs the puff the textures were baked from "
                                           "(bake them again with smoketrace bake-sixway)");
    const nlohmann::json& b = doc.at("bake");
    SixwayBakeSettings s;
    s.frames = layout.grid.frames;
    auto integer = [&](const char* key, int& out) {
        if (!b.contains(key)) layout_error(layout_json, std::string("/bake/") + key, "missing");
        const nlohmann::json& j = b.at(key);
        if (!j.is_number_integer()) layout_error(layout_json, std::string("/bake/") + key, "must be an integer, got " + j.dump());
        const long long v = j.get<long long>();
        if (v < -2147483647LL || v > 4294967295LL) layout_error(layout_json, std::string("/bake/") + key, "out of range: " + j.dump());
        out = int(v);
    };
    auto number = [&](const char* key, float& out) {
        if (!b.contains(key)) layout_error(layout_json, std::string("/bake/") + key, "missing");
        const nlohmann::json& j = b.at(key);
        if (!j.is_number()) layout_error(layout_json, std::string("/bake/") + key, "must be a number, got " + j.dump());
        out = j.get<float>();
    };
    integer("tile", s.tile);
    integer("depth_samples", s.depth_samples);
    if (!b.contains("seed") || !b.at("seed").is_number_unsigned() || b.at("seed").get<unsigned long long>() > 0xFFFFFFFFull)
        layout_error(layout_json, "/bake/seed", "must be an integer in [0, 4294967295]");
    s.seed = std::uint32_t(b.at("seed").get<unsigned long long>());
    number("radius", s.radius);
    number("noise_amplitude", s.noise_amplitude);
    number("noise_frequency", s.noise_frequency);
    integer("noise_octaves", s.noise_octaves);
    number("edge_softness", s.edge_softness);
    number("extinction", s.extinction);
    number("drift", s.drift);
    integer("scattering_octaves", s.scattering_octaves);
    number("scattering_octave_weight", s.scattering_octave_weight);
    try {
        validate(s);
    } catch (const std::invalid_argument& e) {
        layout_error(layout_json, "/bake", e.what());
    }
    return s;
}

SixwayTexture load_sixway_texture(const fs::path& layout_json) {
    const SixwayLayout layout = read_sixway_layout(layout_json);
    return load_sixway_texture(layout.positive, layout.negative, layout.grid);
}

void write_sixway_bake(const std::filesystem::path& folder, const SixwayBake& bake) {
    // Encoded first, in writers of their own, so that nothing is written before every file's bytes exist.
    PngWriter positive_writer, negative_writer;
    const std::string& positive = positive_writer.encode_rgba8(folder / kSixwayPositiveFile, bake.positive);
    const std::string& negative = negative_writer.encode_rgba8(folder / kSixwayNegativeFile, bake.negative);
    const SixwayBakeSettings& s = bake.settings;
    nlohmann::ordered_json doc;
    doc["format"] = kSixwayFormatName;
    doc["version"] = kSixwayFormatVersion;
    doc["frames"] = bake.grid.frames;
    doc["columns"] = bake.grid.columns;
    doc["rows"] = bake.grid.rows;
    doc["positive"] = kSixwayPositiveFile;
    doc["negative"] = kSixwayNegativeFile;
    doc["encoding"] = "linear 8-bit light-map data (not sRGB), straight alpha; positive RGB = lit from +x, +y, +z, "
                      "negative RGB = lit from -x, -y, -z (tangent space: x right, y up, z toward the viewer)";
    doc["bake"] = {{"tile", s.tile},
                   {"depth_samples", s.depth_samples},
                   {"seed", s.seed},
                   {"radius", shortest_decimal(s.radius)},
                   {"noise_amplitude", shortest_decimal(s.noise_amplitude)},
                   {"noise_frequency", shortest_decimal(s.noise_frequency)},
                   {"noise_octaves", s.noise_octaves},
                   {"edge_softness", shortest_decimal(s.edge_softness)},
                   {"extinction", shortest_decimal(s.extinction)},
                   {"drift", shortest_decimal(s.drift)},
                   {"scattering_octaves", s.scattering_octaves},
                   {"scattering_octave_weight", shortest_decimal(s.scattering_octave_weight)}};
    const std::string text = doc.dump(2) + "\n";
    auto bytes = [](const std::string& b) {
        return [&b](std::ostream& out) { out.write(b.data(), std::streamsize(b.size())); };
    };
    // A sidecar from one bake with an atlas from another would be read without complaint: all or none.
    const GroupOutput files[] = {{resolve_output(folder / kSixwayPositiveFile), bytes(positive)},
                                 {resolve_output(folder / kSixwayNegativeFile), bytes(negative)},
                                 {resolve_output(folder / kSixwayLayoutFile), bytes(text)}};
    write_outputs_together(files);
}

}  // namespace smoketrace
