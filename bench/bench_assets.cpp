// The benchmark's asset search (bench_assets.hpp).
#include "bench_assets.hpp"

#include "cli/binary_path.hpp"

#include <cstdlib>
#include <stdexcept>
#include <system_error>
#include <vector>

namespace smoketrace::bench {
namespace {

namespace fs = std::filesystem;

// The first of kBenchAssetFiles that `folder` lacks; nullopt when it holds them all.
std::optional<std::string_view> missing_file(const fs::path& folder) {
    for (const std::string_view f : kBenchAssetFiles) {
        std::error_code ec;
        if (!fs::is_regular_file(folder / f, ec)) return f;
    }
    return std::nullopt;
}

std::string files_list() {
    std::string list;
    for (const std::string_view f : kBenchAssetFiles) list += (list.empty() ? "" : ", ") + std::string(f);
    return list;
}

// A folder given on the command line or in the environment: used as it is, or an error.
BenchAssets given_folder(const std::string& folder, std::string_view source) {
    std::error_code ec;
    if (!fs::is_directory(folder, ec))
        throw std::runtime_error(std::string(source) + ": " + cli::quoted_arg(folder) +
                                 " is not a folder (the bench's assets folder holds " + files_list() + ")");
    if (const auto lacks = missing_file(folder))
        throw std::runtime_error(std::string(source) + ": " + cli::quoted_arg(folder) + " holds no " +
                                 std::string(*lacks) + " (the bench's assets folder holds " + files_list() + ")");
    return {folder, std::string(source)};
}

// The binaries whose folders are searched: the running one, and the one argv[0] names where that differs.
std::vector<fs::path> binaries(const char* argv0, std::string& unknown) {
    std::vector<fs::path> out;
    if (const std::optional<fs::path> self = cli::running_binary(argv0, unknown)) out.push_back(*self);
    std::error_code ec;
    const fs::path cwd = fs::current_path(ec);
    if (argv0 && !ec)
        if (const auto named = cli::binary_from_argv0(argv0, cwd, std::getenv("PATH")))
            if (out.empty() || !fs::equivalent(out.front(), *named, ec)) out.push_back(*named);
    return out;
}

}  // namespace

BenchAssets find_bench_assets(const std::optional<std::string>& given, const char* argv0) {
    if (given) return given_folder(*given, "--assets");
    const char* env = std::getenv(kBenchAssetsEnvironment);
    if (env && *env) return given_folder(env, kBenchAssetsEnvironment);

    std::string searched = std::string("--assets (not given), ") + kBenchAssetsEnvironment + " (not set)";
    std::string unknown;
    const std::vector<fs::path> found = binaries(argv0, unknown);
    if (found.empty()) searched += ", beside the binary (its path unknown: " + unknown + ")";
    for (const fs::path& binary : found) {
        const fs::path bin = binary.parent_path();
        const fs::path installed = (bin / SMOKETRACE_DATA_FROM_BIN).lexically_normal(),
                       packed = (bin / ".." / "assets").lexically_normal();
        for (const fs::path& candidate : {installed, bin / "assets", packed}) {
            if (!missing_file(candidate)) return {candidate, "beside the binary " + binary.string()};
            searched += ", " + candidate.string();
        }
    }
    const fs::path source(SMOKETRACE_ASSET_DIR);
    if (!missing_file(source)) return {source, "the source tree's, compiled in"};
    searched += ", " + source.string() + " (the source tree's, compiled in)";
    throw std::runtime_error("no assets folder (one holding " + files_list() + ") found; looked in: " + searched +
                             ". Give --assets DIR or set " + kBenchAssetsEnvironment + "=DIR");
}

}  // namespace smoketrace::bench
