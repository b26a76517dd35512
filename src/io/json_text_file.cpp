// Bounded reading of a JSON file's text (see json_text_file.hpp).
#include <smoketrace/io/json_text_file.hpp>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <string_view>
#include <sys/mman.h>
#include <sys/stat.h>
#include <system_error>
#include <utility>
#include <unistd.h>

namespace smoketrace {

namespace {

// A stream's first read()'s bytes and least growth: small enough that a stream refused on its first bytes
// costs nothing.
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

JsonText::JsonText(JsonText&& other) noexcept { *this = std::move(other); }

JsonText& JsonText::operator=(JsonText&& other) noexcept {
    if (this == &other) return *this;
    release();
    stream_ = std::move(other.stream_);
    mapping_ = std::exchange(other.mapping_, nullptr);
    mapping_bytes_ = std::exchange(other.mapping_bytes_, 0);
    size_ = std::exchange(other.size_, 0);
    capacity_ = std::exchange(other.capacity_, 0);
    data_ = mapping_ ? static_cast<const char*>(mapping_) : stream_.data();
    if (!mapping_ && stream_.empty()) data_ = "";
    other.data_ = "";
    return *this;
}

JsonText::~JsonText() { release(); }

void JsonText::release() {
    if (mapping_) ::munmap(mapping_, mapping_bytes_);
    mapping_ = nullptr;
    mapping_bytes_ = 0;
    stream_.clear();
}

JsonText read_json_object_text(const std::filesystem::path& path, std::uint64_t max_bytes, std::size_t padding) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) fail("cannot open the file for reading (" + errno_text(errno) + ")");
    const FileDescriptor closer{fd};
    struct stat info{};
    if (::fstat(fd, &info) != 0) fail("cannot read the file (" + errno_text(errno) + ")");
    if (S_ISDIR(info.st_mode)) fail("is a directory, not a file");
    const std::string limit = "the limit of " + std::to_string(max_bytes) + " bytes";
    // A regular file's size is known: refused before anything is read.
    if (S_ISREG(info.st_mode) && std::uint64_t(info.st_size) > max_bytes)
        fail("the file is " + std::to_string(info.st_size) + " bytes, more than " + limit);
    JsonText text;
    // The first problem in the file is the one reported: a first byte other than '{', or a NUL byte.
    bool first_checked = false;
    std::size_t blank_end = 0;
    const auto check = [&](std::size_t start, std::size_t end) {
        if (!first_checked) first_checked = first_byte_checked(std::string_view(text.data_, end), blank_end);
        if (const void* nul = std::memchr(text.data_ + start, '\0', end - start))
            fail("byte " + std::to_string(std::size_t(static_cast<const char*>(nul) - text.data_) + 1) +
                 " is a NUL byte, which JSON text never holds (is it a binary file?)");
    };
    if (S_ISREG(info.st_mode) && info.st_size > 0) {
        // The file's pages, followed by anonymous ones (read as zeros, never written, so never faulted in as
        // fresh memory) for the padding: a reservation of the whole, the file mapped over its start.
        const std::size_t size = std::size_t(info.st_size);
        const std::size_t page = std::size_t(::sysconf(_SC_PAGESIZE));
        const std::size_t bytes = (size + padding + page - 1) / page * page;
        void* const region = ::mmap(nullptr, bytes, PROT_READ, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (region == MAP_FAILED) fail("cannot map the file (" + errno_text(errno) + ")");
        text.mapping_ = region;
        text.mapping_bytes_ = bytes;
        if (::mmap(region, size, PROT_READ, MAP_PRIVATE | MAP_FIXED, fd, 0) == MAP_FAILED)
            fail("cannot map the file (" + errno_text(errno) + ")");
        text.data_ = static_cast<const char*>(region);
        text.size_ = size;
        text.capacity_ = bytes;
        check(0, size);
        return text;
    }
    // A stream (or a file that says it is empty, as /proc's do): read as it comes, in chunks, up to the bound.
    std::vector<char>& bytes = text.stream_;
    std::size_t size = 0;
    while (true) {
        if (bytes.size() == size) bytes.resize(std::max(2 * size, size + kChunkBytes));
        const std::uint64_t want = std::min<std::uint64_t>(bytes.size() - size, max_bytes + 1 - size);
        const ssize_t n = ::read(fd, bytes.data() + size, std::size_t(want));
        if (n < 0) {
            if (errno == EINTR) continue;
            fail("cannot read the file (" + errno_text(errno) + ")");
        }
        if (n == 0) break;
        // However long the stream runs: the same bound.
        if (std::uint64_t(size) + std::uint64_t(n) > max_bytes) fail("it is longer than " + limit);
        const std::size_t start = size;
        size += std::size_t(n);
        text.data_ = bytes.data();
        check(start, size);
    }
    bytes.resize(size + padding);
    std::fill(bytes.begin() + std::ptrdiff_t(size), bytes.end(), '\0');
    text.data_ = bytes.data();
    text.size_ = size;
    text.capacity_ = bytes.size();
    return text;
}

}  // namespace smoketrace
