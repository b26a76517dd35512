// smoketrace bake-sixway: bakes the six-way lighting flipbook (sixway_baker.hpp) and writes the two atlases
// and their sidecar, together or not at all, into the folder -o names or the current folder. Never by
// default into the assets folder the other commands read (assets.hpp): that may be an installed
// share/smoketrace, or the source tree's committed assets/.
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
    const auto out = reader.string("-o");
    if (const auto f = reader.integer("--frames", 1, kSixwayMaxBakeFrames)) settings.frames = int(*f);
    if (const auto t = reader.integer("--tile", 4, kSixwayMaxBakeTile)) settings.tile = int(*t);
    if (const auto s = reader.integer("--seed", 0, std::numeric_limits<std::uint32_t>::max()))
        settings.seed = std::uint32_t(*s);
    reader.finish();
    const std::filesystem::path folder = out ? std::filesystem::path(*out) : std::filesystem::path(".");
    std::error_code ec;
    if (!std::filesystem::is_directory(folder, ec)) throw CliError("-o: '" + folder.string() + "' is not an existing folder");
    // Before baking: each of the three files can be replaced (none is a folder or a stream, the folder takes
    // new files), as the three must be for write_sixway_bake() to put them in place together.
    for (const std::string_view name : {kSixwayPositiveFile, kSixwayNegativeFile, kSixwayLayoutFile})
        if (checked_output(folder / name, {}).kind != OutputKind::replace)
            throw CliError("-o: " + (folder / name).string() + ": is not a regular file; the three files of a bake "
                           "are replaced together, which a FIFO or a device cannot be");

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

constexpr OptionHelp kOptions[] = {
    {"-o", "DIR", "the current folder (never the assets folder render reads, unless named)",
     "existing folder to write the three files into; they replace its old ones together or not at all"},
    {"--frames", "N", "16", "flipbook frames, 1…256"},
    {"--tile", "PX", "128", "side of one frame's tile in texels, 4…256"},
    {"--seed", "S", "1", "noise seed: another seed bakes another puff"},
};

const RegisterCommand reg{{"bake-sixway", "bake-sixway [-o DIR] [--frames N] [--tile PX] [--seed S]",
                           "Bake the six-way lighting flipbook (sixway_pos.png, sixway_neg.png, sixway.json) into DIR "
                           "(default: the current folder), the three replaced together or not at all; render "
                           "--assets DIR then uses them.",
                           &run_bake_sixway, kOptions}};

}  // namespace
}  // namespace smoketrace::cli
