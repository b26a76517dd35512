#pragma once
// Where the command line finds its assets: the six-way textures (sixway.json and the two PNGs it names).
// Never a path compiled in: the same binary works from the build tree, from an installed prefix, and
// after either is moved. Looked for in this order:
//   1. the folder given on the command line (render --assets DIR, or its older name --textures DIR);
//   2. the folder in the environment variable SMOKETRACE_ASSETS;
//   3. <folder of the binary>/../share/smoketrace: an installed tree (bin/smoketrace; the relative path
//      follows the install's bin and data folders, CMakeLists.txt);
//   4. <folder of the binary>/assets: the build tree, where CMake links it to the source tree's assets/.
// A folder given (1, 2) must exist and is used as it is; 3 and 4 count only when they hold sixway.json.
// The binary's folder comes from the system where it says (binary_path.hpp), else from argv[0].
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

namespace smoketrace::cli {

inline constexpr const char* kAssetsEnvironment = "SMOKETRACE_ASSETS";

// Keeps main()'s argv[0] (which outlives every command) for finding the binary where the system cannot say.
void remember_argv0(const char* argv0);

// The assets folder. `given` is the command line's folder and `flag` its name, for messages. Throws
// CliError when a folder given is not one, or when none of 3 and 4 holds sixway.json: the message names
// every place looked in and how to give one.
[[nodiscard]] std::filesystem::path find_assets(const std::optional<std::string>& given, std::string_view flag);

}  // namespace smoketrace::cli
