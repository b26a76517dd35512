// Bounded reading of a JSON file's text (see json_text_file.hpp).
#include <smoketrace/io/json_text_file.hpp>

#include <array>
#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <string_view>
#include <sys/stat.h>
#include <system_error>
#include <unistd.h>

namespace smoketrace {

namespace {

// Bytes per read(): small enough that a file refused on its first bytes costs nothing.
constexpr std::size_t kChunkBytes = std::size_t(1) << 16;

[[noreturn]] void fail(const std::string& problem) { throw JsonTextFileError(problem); }

std::string errno_text(int error) { return std::error_code(error, std::generic_category()).message(); }

struct FileDescriptor {
    int fd;
    ~FileDescriptor() { ::close(fd); }
};

// A byte as a message shows it: 'c' when printable ASCII, else its hexadecimal code.
std::string shown_byte(unsigned char c) {
    if (c >= 0x20 && c < 0x7F) return std::string("'") + char(c) + "'";
    constexpr char kHex[] = "0123456789abcdef";
    return std::string("0x") + kHex[c >> 4] + kHex[c & 0xF];
}

// Whether the text read so far settles that it is a JSON object: throws when it cannot be one; returns false
// while only a byte-order mark and white space have been seen (more may follow). `from`: where the white
// space scan stopped last time, so that a long blank start is scanned once.
bool first_byte_checked(std::string_view text, std::size_t& from) {
    constexpr std::string_view kBom = "\xEF\xBB\xBF";
    if (from == 0) {
        if (text.size() < kBom.size() && kBom.substr(0, text.size()) == text) return false;
        if (text.substr(0, kBom.size()) == kBom) from = kBom.size();
    }
    while (from < text.size() && (text[from] == ' ' || text[from] == '\t' || text[from] == '\n' || text[from] == '\r'))
        ++from;
    if (from == text.size()) return false;
    if (text[from] != '{' && text[from] != '\0')  // a NUL byte is named as such by the caller
        fail("not a JSON object: its first non-blank byte, byte " + std::to_string(from + 1) + ", is " +
             shown_byte(static_cast<unsigned char>(text[from])) + " (a JSON object begins with '{')");
    return true;
}

}  // namespace

std::string read_json_object_text(const std::filesystem::path& path, std::uint64_t max_bytes, std::size_t padding) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) fail("cannot open the file for reading (" + errno_text(errno) + ")");
    const FileDescriptor closer{fd};
    struct stat info{};
    if (::fstat(fd, &info) != 0) fail("cannot read the file (" + errno_text(errno) + ")");
    if (S_ISDIR(info.st_mode)) fail("is a directory, not a file");
    const std::string limit = "the limit of " + std::to_string(max_bytes) + " bytes";
    std::string text;
    // A regular file's size is known: refused before anything is read, and read into one allocation.
    if (S_ISREG(info.st_mode)) {
        if (std::uint64_t(info.st_size) > max_bytes)
            fail("the file is " + std::to_string(info.st_size) + " bytes, more than " + limit);
        text.reserve(std::size_t(info.st_size) + padding);
    }
    std::array<char, kChunkBytes> chunk;
    bool first_checked = false;
    std::size_t blank_end = 0;
    while (true) {
        const ssize_t n = ::read(fd, chunk.data(), chunk.size());
        if (n < 0) {
            if (errno == EINTR) continue;
            fail("cannot read the file (" + errno_text(errno) + ")");
        }
        if (n == 0) break;
        // A FIFO, a device or a file that grows while it is read: the same bound.
        if (std::uint64_t(text.size()) + std::uint64_t(n) > max_bytes)
            fail("it is longer than " + limit);
        const std::size_t start = text.size();
        text.append(chunk.data(), std::size_t(n));
        // The first problem in the file is the one reported: a first byte other than '{', or a NUL byte.
        if (!first_checked) first_checked = first_byte_checked(text, blank_end);
        if (const void* nul = std::memchr(text.data() + start, '\0', std::size_t(n)))
            fail("byte " + std::to_string(std::size_t(static_cast<const char*>(nul) - text.data()) + 1) +
                 " is a NUL byte, which JSON text never holds (is it a binary file?)");
    }
    if (text.capacity() < text.size() + padding) text.reserve(text.size() + padding);
    return text;
}

}  // namespace smoketrace
