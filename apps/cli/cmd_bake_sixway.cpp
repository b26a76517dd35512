// smoketrace bake-sixway: bakes the six-way lighting flipbook (sixway_baker.hpp) and writes the two atlases
// and their sidecar. With no -o it regenerates the committed assets in the source tree's assets/ folder.
#include "arguments.hpp"
#include "command.hpp"
#include "output_arg.hpp"

#include <smoketrace/render/sixway_baker.hpp>
#include <smoketrace/io/sixway_files.hpp>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <limits>

namespace smoketrace::cli {
namespace {

int run_bake_sixway(const Args& args) {
    ArgReader reader(args);
    SixwayBakeSettings settings;
    std::filesystem::path folder = SMOKETRACE_ASSET_DIR;
    if (const auto o = reader.string("-o")) folder = *o;
    if (const auto f = reader.integer("--frames", 1, kSixwayMaxBakeFrames)) settings.frames = int(*f);
    if (const auto t = reader.integer("--tile", 4, kSixwayMaxBakeTile)) settings.tile = int(*t);
    if (const auto s = reader.integer("--seed", 0, std::numeric_limits<std::uint32_t>::max()))
        settings.seed = std::uint32_t(*s);
    reader.finish();
    std::error_code ec;
    if (!std::filesystem::is_directory(folder, ec)) throw CliError("-o: '" + folder.string() + "' is not an existing folder");
    // Before baking: each of the three files can be written (none is a folder, the folder takes new files).
    for (const std::string_view name : {kSixwayPositiveFile, kSixwayNegativeFile, kSixwayLayoutFile})
        (void)checked_output(folder / name, {});

    const auto start = std::chrono::steady_clock::now();
    const SixwayBake bake = bake_sixway(settings);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    write_sixway_bake(folder, bake);
    std::cout << "baked " << bake.grid.frames << " frames of " << settings.tile << "x" << settings.tile << " ("
              << bake.positive.width << "x" << bake.positive.height << " atlases) in " << seconds << " s\nwrote "
              << (folder / kSixwayPositiveFile).string() << ", " << (folder / kSixwayNegativeFile).string() << ", "
              << (folder / kSixwayLayoutFile).string() << "\n";
    return 0;
}

const RegisterCommand reg{{"bake-sixway", "bake-sixway [-o DIR] [--frames N] [--tile PX] [--seed S]",
                           "Bake the six-way lighting flipbook (sixway_pos.png, sixway_neg.png, sixway.json) into DIR "
                           "(default: the source tree's assets/).",
                           &run_bake_sixway}};

}  // namespace
}  // namespace smoketrace::cli
