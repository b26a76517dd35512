#pragma once
// The bytes of a binary file (a PNG, an EXR, a PFM), read with a bound: a regular file is refused by its size
// before a byte is read, anything else (a FIFO, a device) is read as a stream that stops at the bound. So
// /dev/zero or a sparse file of gigabytes named by mistake costs one buffer, not the machine's memory.
#include <cstdint>
#include <filesystem>
#include <vector>

namespace smoketrace {

// The whole of `path`, at most `max_bytes` long. Throws std::runtime_error "cannot read 'PATH': PROBLEM":
// it cannot be opened or read (the system's reason), it is a folder, or it is longer than `max_bytes`.
[[nodiscard]] std::vector<std::uint8_t> read_file_bytes(const std::filesystem::path& path, std::uint64_t max_bytes);

}  // namespace smoketrace
