// smoketrace bake-sixway: bakes the six-way lighting flipbook (sixway_baker.hpp) and writes the two atlases
// and their sidecar. With no -o it regenerates them in the assets folder the other commands read
// (assets.hpp): from the build tree, the source tree's assets/.
#include "arguments.hpp"
#include "assets.hpp"
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
    const std::filesystem::path folder = out ? std::filesystem::path(*out) : find_assets(std::nullopt, "-o");
    std::error_code ec;
    if (!std::filesystem::is_directory(folder, ec))
        throw CliError("-o: " + quoted_arg(folder.string()) + " is not an existing folder");
    // Before baking: each of the three files can be written (none is a folder, the folder takes new files).
    for (const std::string_view name : {kSixwayPositiveFile, kSixwayNegativeFile, kSixwayLayoutFile})
        (void)checked_output(folder / name, {});

    const auto start = std::chrono::steady_clock::now();
    const SixwayBake bake = bake_sixway(settings);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    write_sixway_bake(folder, bake);
    // On standard error, as every command's "wrote": standard output is for what a command was asked to print.
    std::cerr << "baked " << bake.grid.frames << " frames of " << settings.tile << "x" << settings.tile << " ("
              << bake.positive.width << "x" << bake.positive.height << " atlases) in " << seconds << " s\nwrote "
              << shown_text((folder / kSixwayPositiveFile).string(), kMaxShownPathBytes) << ", "
              << shown_text((folder / kSixwayNegativeFile).string(), kMaxShownPathBytes) << ", "
              << shown_text((folder / kSixwayLayoutFile).string(), kMaxShownPathBytes) << "\n";
    return 0;
}

constexpr OptionHelp kOptions[] = {
    {"-o", "DIR", "the assets folder (as render --assets finds it)", "existing folder to write the three files into"},
    {"--frames", "N", "16", "flipbook frames, 1…256"},
    {"--tile", "PX", "128", "side of one frame's tile in texels, 4…256"},
    {"--seed", "S", "1", "noise seed: another seed bakes another puff"},
};

const RegisterCommand reg{{"bake-sixway", "bake-sixway [-o DIR] [--frames N] [--tile PX] [--seed S]",
                           "Bake the six-way lighting flipbook (sixway_pos.png, sixway_neg.png, sixway.json) into DIR "
                           "(default: the assets folder).",
                           &run_bake_sixway, kOptions}};

}  // namespace
}  // namespace smoketrace::cli
