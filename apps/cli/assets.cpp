#include "assets.hpp"

#include "arguments.hpp"
#include "binary_path.hpp"

#include <smoketrace/render/sixway_texture.hpp>

#include <cstdlib>
#include <system_error>
#include <vector>

namespace smoketrace::cli {
namespace {

namespace fs = std::filesystem;

const char* g_argv0 = nullptr;  // main()'s argv[0], for running_binary() where the system cannot say

fs::path checked_folder(const std::string& folder, std::string_view source) {
    std::error_code ec;
    if (!fs::is_directory(folder, ec))
        throw CliError(std::string(source) + ": " + quoted_arg(folder) + " is not a folder (an assets folder holds " +
                       std::string(kSixwayLayoutFile) + " and the PNGs it names)");
    return folder;
}

}  // namespace

void remember_argv0(const char* argv0) { g_argv0 = argv0; }

fs::path find_assets(const std::optional<std::string>& given, std::string_view flag) {
    if (given) return checked_folder(*given, flag);
    const char* env = std::getenv(kAssetsEnvironment);
    if (env && *env) return checked_folder(env, kAssetsEnvironment);

    std::string searched = std::string(flag) + " (not given), " + kAssetsEnvironment + " (not set)";
    std::string why;
    if (const std::optional<fs::path> self = running_binary(g_argv0, why); !self) {
        searched += ", beside the binary (its path unknown: " + why + ")";
    } else {
        const fs::path bin = self->parent_path();
        for (const fs::path& candidate : {(bin / SMOKETRACE_DATA_FROM_BIN).lexically_normal(), bin / "assets"}) {
            std::error_code ec;
            if (fs::is_regular_file(candidate / kSixwayLayoutFile, ec)) return candidate;
            searched += ", " + candidate.string();
        }
    }
    throw CliError("no assets folder (one holding " + std::string(kSixwayLayoutFile) + ") found; looked in: " +
                   searched + ". Give " + std::string(flag) + " DIR or set " + kAssetsEnvironment + "=DIR");
}

}  // namespace smoketrace::cli
