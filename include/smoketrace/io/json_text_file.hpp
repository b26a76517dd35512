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
#include <string_view>
#include <vector>

namespace smoketrace {

// Why a JSON file was not read: the problem only; the caller names the file in its own form.
class JsonTextFileError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// A file's text as read_json_object_text() read it, followed by readable padding. A regular file is mapped,
// not copied: a scene of a million particles is over a hundred megabytes, and a copy is that much fresh memory
// to fault in and clear, where the file's pages already lie in the page cache. Such a file must not be cut
// short while its text is in use: as with any mapped file, the pages past its new end would end the process
// with SIGBUS. Anything else (a FIFO, a device) is read as it comes into memory of its own. Move-only.
class JsonText {
public:
    JsonText() = default;
    JsonText(JsonText&& other) noexcept;
    JsonText& operator=(JsonText&& other) noexcept;
    JsonText(const JsonText&) = delete;
    JsonText& operator=(const JsonText&) = delete;
    ~JsonText();

    [[nodiscard]] const char* data() const { return data_; }
    [[nodiscard]] std::size_t size() const { return size_; }
    // size() plus at least the padding asked for: the bytes past the text may be read (simdjson's
    // padded_string_view wants them), and they are zero unless the file grew while it was mapped.
    [[nodiscard]] std::size_t capacity() const { return capacity_; }
    [[nodiscard]] std::string_view view() const { return {data_, size_}; }

private:
    friend JsonText read_json_object_text(const std::filesystem::path&, std::uint64_t, std::size_t);
    void release();
    std::vector<char> stream_;     // a stream's bytes, then zeros
    void* mapping_ = nullptr;      // a regular file's pages, then zero pages
    std::size_t mapping_bytes_ = 0;
    const char* data_ = "";
    std::size_t size_ = 0;
    std::size_t capacity_ = 0;
};

// The whole text of `path`, at most `max_bytes` long, with at least `padding` readable bytes after it (room a
// parser such as simdjson reads past the end). Throws JsonTextFileError: it cannot be opened or read, it is a
// folder, it is longer than `max_bytes`, it holds a NUL byte, or its first byte after an optional UTF-8
// byte-order mark and JSON white space is not '{'. Empty or all-blank text is returned as it is, for the
// parser to report.
[[nodiscard]] JsonText read_json_object_text(const std::filesystem::path& path, std::uint64_t max_bytes,
                                             std::size_t padding = 0);

}  // namespace smoketrace
