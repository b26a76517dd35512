#pragma once
// The text of a JSON file (a scene file, a six-way sidecar), read with a bound: a regular file is refused by its
// size before a byte is read, anything else (a FIFO, a device) is read as a stream that stops at the bound,
// and text that cannot be a JSON object (a NUL byte, a first non-blank byte other than '{') is refused as soon
// as it is read. So /dev/zero, a sparse file of gigabytes or a binary file named by mistake costs one
// buffer, not the machine's memory.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace smoketrace {

// Why a JSON file was not read: the problem only; the caller names the file in its own form.
class JsonTextFileError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// The whole text of `path`, at most `max_bytes` long, with a capacity of at least its size plus `padding`
// (room a parser such as simdjson reads past the end). Throws JsonTextFileError: it cannot be opened or read,
// it is a folder, it is longer than `max_bytes`, it holds a NUL byte, or its first byte after an optional
// UTF-8 byte-order mark and JSON white space is not '{'. Empty or all-blank text is returned as it is, for
// the parser to report.
[[nodiscard]] std::string read_json_object_text(const std::filesystem::path& path, std::uint64_t max_bytes,
                                                std::size_t padding = 0);

}  // namespace smoketrace
