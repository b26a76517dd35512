// Memory available to the process (see memory_budget.hpp).
#include <smoketrace/core/memory_budget.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <string>
#include <unistd.h>

namespace smoketrace {
namespace {

// The first token of a cgroup limit file as a byte count; "max" (no limit), a missing file or garbage give 0.
std::uint64_t cgroup_limit(const char* path) {
    std::ifstream in(path);
    std::string token;
    if (!(in >> token) || token.empty() || token.find_first_not_of("0123456789") != std::string::npos) return 0;
    try {
        return std::stoull(token);
    } catch (...) {
        return 0;  // out of range: no usable limit
    }
}

std::uint64_t detect() {
    std::uint64_t bytes = 0;
#if defined(_SC_PHYS_PAGES)  // not POSIX, but Linux, macOS and the BSDs have it
    const long pages = ::sysconf(_SC_PHYS_PAGES), page_size = ::sysconf(_SC_PAGESIZE);
    if (pages > 0 && page_size > 0) bytes = std::uint64_t(pages) * std::uint64_t(page_size);
#endif
    // cgroup v2, then v1 (v1 reports "no limit" as a huge number, which min() ignores); Linux only, and a
    // file that is not there is no limit.
    for (const char* path : {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"}) {
        const std::uint64_t limit = cgroup_limit(path);
        if (limit > 0) bytes = bytes > 0 ? std::min(bytes, limit) : limit;
    }
    // sysconf cannot fail on Linux; should it anyway, or where it cannot say, assume a small machine rather than none.
    return bytes > 0 ? bytes : std::uint64_t{1} << 30;
}

}  // namespace

std::uint64_t machine_memory_bytes() {
    static const std::uint64_t bytes = detect();
    return bytes;
}

std::string format_bytes(std::uint64_t bytes) {
    char text[32];
    const double b = double(bytes);
    if (b >= 0x1p30) std::snprintf(text, sizeof text, "%.1f GiB", b / 0x1p30);
    else if (b >= 0x1p20) std::snprintf(text, sizeof text, "%.0f MiB", b / 0x1p20);
    else if (b >= 0x1p10) std::snprintf(text, sizeof text, "%.0f KiB", b / 0x1p10);
    else std::snprintf(text, sizeof text, "%.0f bytes", b);
    return text;
}

}  // namespace smoketrace
