#pragma once
// Where the benchmark finds its inputs: the six-way texture and the scene files of the source tree's assets/.
// Not only a path compiled in, so that the bench runs from a copied build, from another tree, and from a
// folder of a build's programs packed to run on another machine. Looked for in this order:
//   1. the folder given with --assets DIR;
//   2. the folder in the environment variable SMOKETRACE_ASSETS (the command line's, apps/cli/assets.hpp);
//   3. beside the binary: <bin>/../share/smoketrace (an installed tree's data folder), <bin>/assets (the
//      command line's place in the build tree), <bin>/../assets (a packed folder: bin/ and assets/ side by
//      side). The binary is the running one (/proc/self/exe) and, where that is another file, the one
//      argv[0] names: a program started through a bundled dynamic loader runs as the loader;
//   4. the source tree's assets/, compiled in (SMOKETRACE_ASSET_DIR).
// A folder counts only when it holds every file of kBenchAssetFiles; one given (1, 2) that does not is an
// error naming the folder and the file it lacks, never passed over for the next.
#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

namespace smoketrace::bench {

inline constexpr const char* kBenchAssetsEnvironment = "SMOKETRACE_ASSETS";

// The files the sections read from the assets folder (sixway.json names its two PNGs, read with it).
inline constexpr std::array<std::string_view, 4> kBenchAssetFiles = {
    "sixway.json", "scenes/two_tubes_above.json", "scenes/two_tubes_right.json", "scenes/two_tubes_sequence.json"};

struct BenchAssets {
    std::filesystem::path folder;
    std::string found_by;  // how it was found, for the run's header: "--assets", "beside the binary", ...
};

// The assets folder (above). `given`: --assets's value; `argv0`: main()'s argv[0]. Throws std::runtime_error
// when a folder given lacks a file, or when no folder holds them all: the message names every place looked in
// and how to give one.
[[nodiscard]] BenchAssets find_bench_assets(const std::optional<std::string>& given, const char* argv0);

}  // namespace smoketrace::bench
