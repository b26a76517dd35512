#pragma once
// Output files appear whole or not at all: written to a temporary file beside the target, then renamed
// over it (rename within one folder is atomic on POSIX file systems).
#include <filesystem>
#include <functional>
#include <ostream>
#include <string_view>

namespace smoketrace {

// Calls write(stream) on a temporary file in the target's folder and renames it to `path` when write
// returned and the stream is good. Throws std::runtime_error naming the path and the reason (missing
// folder, permission, disk full…); the temporary file is removed on every failure path.
void write_file_atomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write);

}  // namespace smoketrace
