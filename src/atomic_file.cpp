#include <smoketrace/atomic_file.hpp>

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
    const fs::path tmp = folder / ("." + path.filename().string() + ".tmp" + std::to_string(::getpid()));
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
