#pragma once
// Six-way lighting textures as files (render/sixway_texture.hpp has the format and the texture): the
// positive and negative atlas PNGs and the JSON sidecar (kSixwayLayoutFile) that gives their grid.
#include <smoketrace/render/sixway_baker.hpp>
#include <smoketrace/render/sixway_texture.hpp>

#include <cstdint>
#include <filesystem>

namespace smoketrace {

// The longest sidecar read: the baker writes under 1 KB, so 1 MiB leaves room for any hand-made one.
inline constexpr std::uint64_t kMaxSixwayLayoutBytes = std::uint64_t(1) << 20;
// The largest atlas read, checked against each PNG's header before it is decoded: 8192x8192 texels (256 MB
// as RGBA, twice that in the texture), twice the side of the largest the baker makes (kSixwayMaxBakeTile
// tiles of kSixwayMaxBakeFrames frames: 4096x4096), room for atlases from other tools.
inline constexpr int kMaxSixwayAtlasSide = 8192;

// What a sidecar says: the grid and the two PNGs (names resolved against the sidecar's folder), read
// without loading the images.
struct SixwayLayout {
    SixwayAtlasGrid grid;
    std::filesystem::path positive;
    std::filesystem::path negative;
};

// Throws std::runtime_error naming the file, the JSON path and the problem; also when the file is longer than
// kMaxSixwayLayoutBytes or cannot be a JSON object (a NUL byte, a first non-blank byte other than '{').
[[nodiscard]] SixwayLayout read_sixway_layout(const std::filesystem::path& layout_json);

// The bake settings a sidecar records (its "bake" object; frames from its grid): the puff the textures were
// baked from, which the ground truth renders as a volume. Throws std::runtime_error naming the file and the
// JSON path (/bake, /bake/radius, ...) when one is missing, of the wrong type or out of range.
[[nodiscard]] SixwayBakeSettings read_sixway_bake_settings(const std::filesystem::path& layout_json);
// From the two PNGs and a grid. Throws std::runtime_error naming the file and the problem; an atlas wider or
// taller than kMaxSixwayAtlasSide, or a negative one of another size than the positive, before it is decoded.
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
