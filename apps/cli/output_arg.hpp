#pragma once
// -o, checked before any work: what the path names (output_path.hpp) and that it is none of the command's
// inputs (the scene, the PLY it names, the six-way textures). A problem is a usage error (CliError, exit
// code 2) that names the path.
#include "arguments.hpp"

#include <smoketrace/io/output_path.hpp>
#include <smoketrace/io/scene_file.hpp>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace smoketrace::cli {

// Whether `path` ends in `extension` (".png") in any case: out.PNG is what some systems and cameras write.
inline bool has_extension(const std::filesystem::path& path, std::string_view extension) {
    const std::string e = path.extension().string();
    return std::equal(e.begin(), e.end(), extension.begin(), extension.end(), [](char a, char b) {
        return std::tolower(static_cast<unsigned char>(a)) == std::tolower(static_cast<unsigned char>(b));
    });
}

inline OutputTarget checked_output(const std::filesystem::path& path,
                                   const std::vector<std::filesystem::path>& inputs) {
    try {
        OutputTarget target = resolve_output(path);
        check_not_an_input(target, inputs);
        return target;
    } catch (const OutputPathError& e) {
        throw CliError(std::string("-o: ") + e.what());
    }
}

// The same check for inputs known only once the scene is read, before anything is computed or written.
inline void check_output_not_input(const OutputTarget& target, const std::vector<std::filesystem::path>& inputs) {
    try {
        check_not_an_input(target, inputs);
    } catch (const OutputPathError& e) {
        throw CliError(std::string("-o: ") + e.what());
    }
}

// Every file a scene is read from: the scene file, and the PLY point cloud it names ("particles": "cloud.ply").
inline std::vector<std::filesystem::path> scene_inputs(const std::filesystem::path& scene_path,
                                                       const SceneDescription& scene) {
    std::vector<std::filesystem::path> inputs{scene_path};
    if (!scene.smoke.particle_file.empty()) inputs.emplace_back(scene.smoke.particle_file);
    return inputs;
}

}  // namespace smoketrace::cli
