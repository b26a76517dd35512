#pragma once
// Six-way lighting textures as files (render/sixway_texture.hpp has the format and the texture): the
// positive and negative atlas PNGs and the JSON sidecar (kSixwayLayoutFile) that gives their grid.
#include <smoketrace/render/sixway_baker.hpp>
#include <smoketrace/render/sixway_texture.hpp>

#include <filesystem>

namespace smoketrace {

// What a sidecar says: the grid and the two PNGs (names resolved against the sidecar's folder), read
// without loading the images.
struct SixwayLayout {
    SixwayAtlasGrid grid;
    std::filesystem::path positive;
    std::filesystem::path negative;
};

// Throws std::runtime_error naming the file, the JSON path and the problem.
[[nodiscard]] SixwayLayout read_sixway_layout(const std::filesystem::path& layout_json);

// From the two PNGs and a grid. Throws std::runtime_error naming the file and the problem.
[[nodiscard]] SixwayTexture load_sixway_texture(const std::filesystem::path& positive_png,
                                                const std::filesystem::path& negative_png, SixwayAtlasGrid grid);
// From a sidecar (read_sixway_layout()) and the PNGs it names. Errors name the file and the JSON path.
[[nodiscard]] SixwayTexture load_sixway_texture(const std::filesystem::path& layout_json);

// Writes kSixwayPositiveFile, kSixwayNegativeFile and the kSixwayLayoutFile sidecar (grid and bake
// settings) into an existing folder, the three together or none of them (write_outputs_together()): a
// failure or a signal half-way leaves the folder's old set whole. Throws std::runtime_error (OutputPathError
// for a file that cannot be replaced: a folder, a FIFO) naming the file.
void write_sixway_bake(const std::filesystem::path& folder, const SixwayBake& bake);

}  // namespace smoketrace
