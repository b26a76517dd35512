#include <smoketrace/atomic_file.hpp>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <unistd.h>

namespace smoketrace {

void write_file_atomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write) {
    namespace fs = std::filesystem;
    const fs::path folder = path.has_parent_path() ? path.parent_path() : fs::path(".");
    std::error_code ec;
    if (!fs::is_directory(folder, ec))
        throw std::runtime_error(path.string() + ": folder '" + folder.string() + "' does not exist");
    // Unique per process and per call, so two threads (or two processes) writing the same target
    // never share a temporary file.
    static std::atomic<unsigned> serial{0};
    std::string name(1, '.');
    name += path.filename().string();
    name += ".tmp";
    name += std::to_string(::getpid());
    name += '-';
    name += std::to_string(serial.fetch_add(1));
    const fs::path tmp = folder / name;
    struct Cleanup {
        const fs::path& p;
        bool armed = true;
        ~Cleanup() {
            if (armed) {
                std::error_code e;
                fs::remove(p, e);
            }
        }
    } cleanup{tmp};
    {
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        if (!out) throw std::runtime_error(path.string() + ": cannot write (" + std::strerror(errno) + ")");
        write(out);
        out.flush();
        if (!out) throw std::runtime_error(path.string() + ": write failed (" + std::strerror(errno) + ")");
    }
    fs::rename(tmp, path, ec);
    if (ec) throw std::runtime_error(path.string() + ": cannot rename into place (" + ec.message() + ")");
    cleanup.armed = false;
}

}  // namespace smoketrace
