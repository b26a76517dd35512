// Bounded reading of a binary file (see file_bytes.hpp).
#include <smoketrace/io/file_bytes.hpp>

#include <array>
#include <cerrno>
#include <stdexcept>
#include <string>
#include <system_error>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace smoketrace {

namespace {

[[noreturn]] void read_error(const std::filesystem::path& path, const std::string& problem) {
    throw std::runtime_error("cannot read '" + path.string() + "': " + problem);
}

std::string errno_text(int error) { return std::error_code(error, std::generic_category()).message(); }

struct FileDescriptor {
    int fd;
    ~FileDescriptor() { ::close(fd); }
};

}  // namespace

std::vector<std::uint8_t> read_file_bytes(const std::filesystem::path& path, std::uint64_t max_bytes) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) read_error(path, errno_text(errno));
    const FileDescriptor closer{fd};
    struct stat info{};
    if (::fstat(fd, &info) != 0) read_error(path, errno_text(errno));
    if (S_ISDIR(info.st_mode)) read_error(path, errno_text(EISDIR));
    const std::string too_large = "file is larger than " + std::to_string(max_bytes) + " bytes";
    if (std::uint64_t(info.st_size) > max_bytes) read_error(path, too_large);
    std::vector<std::uint8_t> bytes;
    // A regular file's size is known: one allocation. A stream grows the buffer as it comes.
    if (S_ISREG(info.st_mode)) bytes.reserve(std::size_t(info.st_size));
    std::array<std::uint8_t, 1 << 16> buffer;
    while (true) {
        const ssize_t n = ::read(fd, buffer.data(), buffer.size());
        if (n < 0) {
            if (errno == EINTR) continue;
            read_error(path, errno_text(errno));
        }
        if (n == 0) break;
        bytes.insert(bytes.end(), buffer.data(), buffer.data() + n);
        if (bytes.size() > max_bytes) read_error(path, too_large);
    }
    return bytes;
}

}  // namespace smoketrace
