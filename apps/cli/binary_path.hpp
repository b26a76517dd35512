#pragma once
// Where the running binary is, so that the command line finds what was installed beside it (assets.hpp).
// Linux reads it from /proc/self/exe, macOS from _NSGetExecutablePath; anywhere else, or where /proc is not
// mounted, it is worked out from argv[0] the way the shell used it (binary_from_argv0).
#include "arguments.hpp"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <unistd.h>
#if defined(__APPLE__)
#include <cstdint>
#include <mach-o/dyld.h>
#endif

namespace smoketrace::cli {

// The file argv[0] names, found as execvp() finds it: a name holding a '/' is a path (relative ones from
// `cwd`); a bare name is looked for in the folders of `path_variable` (PATH: ':'-separated, an empty entry
// meaning the current folder; nullptr, PATH not set: not looked for), the first executable file of that name
// winning. Symbolic links are resolved,
// as the kernel's own answer has them, so that an installed binary reached through a link finds its prefix.
// nullopt when argv[0] names no executable file (whoever starts a program may give any argv[0]).
inline std::optional<std::filesystem::path> binary_from_argv0(std::string_view argv0, const std::filesystem::path& cwd,
                                                              const char* path_variable) {
    namespace fs = std::filesystem;
    const auto executable_file = [&](const fs::path& name) -> std::optional<fs::path> {
        std::error_code ec;
        const fs::path full = name.is_absolute() ? name : cwd / name;
        if (!fs::is_regular_file(full, ec) || ::access(full.c_str(), X_OK) != 0) return std::nullopt;
        fs::path real = fs::canonical(full, ec);
        return ec ? std::nullopt : std::optional<fs::path>(std::move(real));
    };
    if (argv0.empty()) return std::nullopt;
    if (argv0.find('/') != std::string_view::npos) return executable_file(fs::path(argv0));
    if (!path_variable) return std::nullopt;
    const std::string_view folders = path_variable;
    for (std::size_t begin = 0;;) {
        const std::size_t end = std::min(folders.find(':', begin), folders.size());
        const std::string_view folder = folders.substr(begin, end - begin);
        if (auto found = executable_file(fs::path(folder.empty() ? "." : folder) / argv0)) return found;
        if (end == folders.size()) return std::nullopt;
        begin = end + 1;
    }
}

// The running binary, symbolic links resolved; nullopt with `why` saying what was tried when it is unknown.
inline std::optional<std::filesystem::path> running_binary(const char* argv0, std::string& why) {
    namespace fs = std::filesystem;
    std::error_code ec;
#if defined(__APPLE__)
    std::uint32_t size = 0;
    (void)_NSGetExecutablePath(nullptr, &size);  // asks for the size it needs
    std::string buffer(size, '\0');
    if (_NSGetExecutablePath(buffer.data(), &size) == 0) {
        fs::path real = fs::canonical(buffer.c_str(), ec);
        if (!ec) return real;
    }
    why = "_NSGetExecutablePath failed";
#else
    fs::path self = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) return self;
    why = "/proc/self/exe: " + ec.message();
#endif
    const char* path = std::getenv("PATH");
    const fs::path cwd = fs::current_path(ec);
    if (argv0 && !ec)
        if (auto found = binary_from_argv0(argv0, cwd, path)) return found;
    why += ", and argv[0] " + (argv0 ? quoted_arg(argv0) : std::string("(none)")) + " names no executable file" +
           (path ? "" : " (PATH not set)");
    return std::nullopt;
}

}  // namespace smoketrace::cli
