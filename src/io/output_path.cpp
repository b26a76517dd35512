// Output paths: resolving what an output path names, and writing it without harming it (output_path.hpp).
#include <smoketrace/io/output_path.hpp>

#include <smoketrace/io/temporary_file.hpp>

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <iostream>
#include <memory>
#include <string>
#include <sys/stat.h>
#include <unistd.h>

namespace smoketrace {

namespace fs = std::filesystem;

namespace {

// Linux's limit on symbolic links in one path lookup (MAXSYMLINKS): a longer chain is taken as a loop.
constexpr int kMaxLinks = 40;

std::string errno_text(int e) { return std::strerror(e); }

[[noreturn]] void refuse(const std::string& what, const std::string& problem) {
    throw OutputPathError(what + ": " + problem);
}

bool same_file(const struct stat& a, const struct stat& b) { return a.st_dev == b.st_dev && a.st_ino == b.st_ino; }

fs::path folder_of(const fs::path& file) { return file.has_parent_path() ? file.parent_path() : fs::path("."); }

// The path as given, and where its links lead when that is elsewhere: what messages name.
std::string describe(const fs::path& given, const fs::path& file) {
    if (file == given) return given.string();
    return given.string() + " (a link to '" + file.string() + "')";
}

// Where a chain of symbolic links ends, by the links' text: a relative target is taken from the folder
// holding the link, as the kernel does. A path that is not a link (or does not exist) is returned as is.
fs::path follow_links(const fs::path& given) {
    fs::path p = given;
    for (int n = 0;; ++n) {
        struct stat st{};
        if (::lstat(p.c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) return p;
        if (n == kMaxLinks)
            refuse(given.string(), "more than " + std::to_string(kMaxLinks) + " symbolic links in a row (a loop?)");
        std::error_code ec;
        const fs::path target = fs::read_symlink(p, ec);
        if (ec) refuse(given.string(), "cannot read the symbolic link '" + p.string() + "' (" + ec.message() + ")");
        p = target.is_absolute() ? target : p.parent_path() / target;
    }
}

// The folder a new or replaced `file` is written in must exist and take new files, checked here so that
// the problem is reported before any work rather than after it.
void check_folder(const fs::path& given, const fs::path& file) {
    const fs::path folder = folder_of(file);
    const std::string what = describe(given, file);
    struct stat st{};
    if (::stat(folder.c_str(), &st) != 0) {
        const int e = errno;
        if (e == ENOENT) refuse(what, "folder '" + folder.string() + "' does not exist");
        refuse(what, "folder '" + folder.string() + "': " + errno_text(e));
    }
    if (!S_ISDIR(st.st_mode)) refuse(what, "'" + folder.string() + "' is not a folder");
    if (::faccessat(AT_FDCWD, folder.c_str(), W_OK | X_OK, AT_EACCESS) != 0)
        refuse(what, "cannot create files in folder '" + folder.string() + "' (" + errno_text(errno) + ")");
}

OutputTarget stream_target(const fs::path& given) {
    if (::faccessat(AT_FDCWD, given.c_str(), W_OK, AT_EACCESS) != 0)
        refuse(given.string(), "cannot be written (" + errno_text(errno) + ")");
    return {OutputKind::stream, given, given};
}

// An std::streambuf over a file descriptor that keeps the first write error's errno: std::ofstream reports
// only that something failed. Writes of a buffer's size or more (a PNG file) bypass the buffer.
class DescriptorBuffer final : public std::streambuf {
public:
    explicit DescriptorBuffer(int fd) : fd_(fd), buffer_(new char[kSize]) {
        setp(buffer_.get(), buffer_.get() + kSize);
    }
    [[nodiscard]] int error() const { return error_; }

protected:
    int_type overflow(int_type ch) override {
        if (!drain()) return traits_type::eof();
        if (!traits_type::eq_int_type(ch, traits_type::eof())) {
            *pptr() = traits_type::to_char_type(ch);
            pbump(1);
        }
        return traits_type::not_eof(ch);
    }
    std::streamsize xsputn(const char* s, std::streamsize n) override {
        if (n < kSize) return std::streambuf::xsputn(s, n);
        if (!drain() || !write_all(s, std::size_t(n))) return 0;
        return n;
    }
    int sync() override { return drain() ? 0 : -1; }

private:
    static constexpr std::streamsize kSize = 1 << 16;
    bool drain() {
        const std::size_t n = std::size_t(pptr() - pbase());
        setp(buffer_.get(), buffer_.get() + kSize);
        return write_all(buffer_.get(), n);
    }
    bool write_all(const char* p, std::size_t n) {
        if (error_) return false;
        while (n > 0) {
            const ssize_t done = ::write(fd_, p, n);
            if (done < 0 && errno == EINTR) continue;
            if (done <= 0) {
                error_ = done < 0 ? errno : EIO;
                return false;
            }
            p += done;
            n -= std::size_t(done);
        }
        return true;
    }
    int fd_;
    int error_ = 0;
    std::unique_ptr<char[]> buffer_;
};

// Runs write() into `fd` and flushes; throws naming `what` when anything failed.
void write_to(int fd, const std::string& what, const std::function<void(std::ostream&)>& write) {
    DescriptorBuffer buffer(fd);
    std::ostream out(&buffer);
    write(out);
    out.flush();
    if (buffer.error()) throw std::runtime_error(what + ": write failed (" + errno_text(buffer.error()) + ")");
    if (!out) throw std::runtime_error(what + ": write failed");
}

struct Descriptor {
    int fd;
    ~Descriptor() {
        if (fd >= 0) ::close(fd);
    }
    // close() reports late errors of some file systems (NFS, quotas): checked before a rename.
    int close() {
        const int r = ::close(fd);
        fd = -1;
        return r;
    }
};

void write_standard_output(const OutputTarget& target, const std::function<void(std::ostream&)>& write) {
    std::cout.flush();  // whatever the program printed before comes first
    const std::string what = target.given == kStandardOutputPath ? std::string("standard output")
                                                                  : target.given.string() + " (standard output)";
    write_to(STDOUT_FILENO, what, write);
}

void write_stream(const OutputTarget& target, const std::function<void(std::ostream&)>& write) {
    // No O_CREAT: the file exists (a FIFO, a device), and if it vanished it is not recreated as a plain
    // file. O_TRUNC is ignored by FIFOs and devices; it matters only for a regular file reached through a
    // /proc link, which it then treats as a shell's '>' would.
    int fd;
    do fd = ::open(target.file.c_str(), O_WRONLY | O_NOCTTY | O_CLOEXEC | O_TRUNC);
    while (fd < 0 && errno == EINTR);
    if (fd < 0)
        throw std::runtime_error(target.given.string() + ": cannot open for writing (" + errno_text(errno) + ")");
    Descriptor d{fd};
    write_to(fd, target.given.string(), write);
    if (d.close() != 0 && errno != EINTR)
        throw std::runtime_error(target.given.string() + ": write failed (" + errno_text(errno) + ")");
}

// A fresh temporary file beside `target.file` holding what write() writes, closed. Throws naming the target.
void fill_temporary(TemporaryFile& tmp, const OutputTarget& target, const std::function<void(std::ostream&)>& write) {
    const fs::path& file = target.file;
    const std::string what = describe(target.given, file);
    const fs::path folder = folder_of(file);
    if (!tmp.create(hidden_name_beside(file, ".tmp")))
        throw std::runtime_error(what + ": cannot create a file in folder '" + folder.string() + "' (" +
                                 errno_text(errno) + ")");
    // A replaced file keeps its permissions (a private 0600 file must not come back world-readable).
    struct stat old{};
    if (::stat(file.c_str(), &old) == 0 && S_ISREG(old.st_mode)) (void)::fchmod(tmp.fd(), old.st_mode & 0777);
    write_to(tmp.fd(), what, write);
    if (tmp.close() != 0 && errno != EINTR)
        throw std::runtime_error(what + ": write failed (" + errno_text(errno) + ")");
}

void write_replacing(const OutputTarget& target, const std::function<void(std::ostream&)>& write) {
    TemporaryFile tmp;  // removed on every failure, and by a signal that ends the program meanwhile
    fill_temporary(tmp, target, write);
    if (!tmp.rename_to(target.file))
        throw std::runtime_error(describe(target.given, target.file) + ": cannot rename into place (" +
                                 errno_text(errno) + ")");
}

}  // namespace

OutputTarget resolve_output(const fs::path& path) {
    if (path.empty()) throw OutputPathError("the output path is empty");
    if (path == kStandardOutputPath) return {OutputKind::standard_output, path, path};
    struct stat st{};
    if (::stat(path.c_str(), &st) != 0) {
        const int e = errno;
        // ENOENT: a new file, or a link whose target does not exist yet (created where the link points).
        // ENOTDIR: some folder on the way is a file; check_folder() says which.
        if (e == ENOENT || e == ENOTDIR) {
            const fs::path file = follow_links(path);
            check_folder(path, file);
            return {OutputKind::replace, path, file};
        }
        refuse(path.string(), errno_text(e));  // a loop of links, no permission to look, a name too long
    }
    if (S_ISDIR(st.st_mode)) refuse(path.string(), "is a directory");
    struct stat link{};
    const bool is_link = ::lstat(path.c_str(), &link) == 0 && S_ISLNK(link.st_mode);
    if (is_link) {
        struct stat out{};
        if (::fstat(STDOUT_FILENO, &out) == 0 && same_file(st, out)) return {OutputKind::standard_output, path, path};
    }
    if (!S_ISREG(st.st_mode)) return stream_target(path);
    if (!is_link) {
        check_folder(path, path);
        return {OutputKind::replace, path, path};
    }
    const fs::path file = follow_links(path);
    struct stat end{};
    // A link whose text does not lead to the file it opens is one of the kernel's (/proc/self/fd/N of a
    // deleted file, say): there is no folder to replace it in, so it is written as it is.
    if (::stat(file.c_str(), &end) != 0 || !same_file(end, st)) return stream_target(path);
    check_folder(path, file);
    return {OutputKind::replace, path, file};
}

void check_not_an_input(const OutputTarget& output, const std::vector<fs::path>& inputs) {
    if (output.kind == OutputKind::standard_output) return;
    struct stat out{};
    if (::stat(output.given.c_str(), &out) != 0) return;  // nothing there yet: no input either
    for (const fs::path& input : inputs) {
        struct stat in{};
        if (::stat(input.c_str(), &in) == 0 && same_file(in, out))
            throw OutputPathError(output.given.string() + ": is the same file as the input '" + input.string() +
                                  "'; an output never overwrites an input");
    }
}

void write_output(const OutputTarget& target, const std::function<void(std::ostream&)>& write) {
    switch (target.kind) {
        case OutputKind::standard_output: return write_standard_output(target, write);
        case OutputKind::stream: return write_stream(target, write);
        case OutputKind::replace: return write_replacing(target, write);
    }
}

void write_output(const fs::path& path, const std::function<void(std::ostream&)>& write) {
    write_output(resolve_output(path), write);
}

void write_outputs_together(std::span<const GroupOutput> outputs) {
    for (const GroupOutput& o : outputs)
        if (o.target.kind != OutputKind::replace)
            throw OutputPathError(o.target.given.string() +
                                  ": is not a regular file; the files of this group are replaced together, and a "
                                  "stream cannot be taken back");
    std::vector<std::unique_ptr<TemporaryFile>> temporaries;
    std::vector<TemporaryFile*> files;
    std::vector<fs::path> targets;
    for (const GroupOutput& o : outputs) {
        temporaries.push_back(std::make_unique<TemporaryFile>());
        fill_temporary(*temporaries.back(), o.target, o.write);
        files.push_back(temporaries.back().get());
        targets.push_back(o.target.file);
    }
    rename_together(files, targets);
}

}  // namespace smoketrace
