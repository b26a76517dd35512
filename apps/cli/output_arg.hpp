#pragma once
// -o, checked before any work: what the path names (output_path.hpp) and that it is none of the command's
// inputs. A problem is a usage error (CliError, exit code 2) that names the path.
#include "arguments.hpp"

#include <smoketrace/io/output_path.hpp>

#include <filesystem>
#include <string>
#include <vector>

namespace smoketrace::cli {

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

}  // namespace smoketrace::cli
