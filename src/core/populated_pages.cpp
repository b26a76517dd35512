// Fresh pages faulted in on several threads (see populated_pages.hpp).
#include <smoketrace/core/populated_pages.hpp>

#include <algorithm>
#include <cstdint>

#include <tbb/parallel_for.h>

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif

namespace smoketrace {

namespace {

// The bytes one call populates: 512 pages of 4 KiB, so that a call's cost vanishes beside its faults and
// the parts of a large array share out evenly among threads.
constexpr std::uintptr_t kPartBytes = std::uintptr_t{2} << 20;

}  // namespace

void populate_pages([[maybe_unused]] void* p, [[maybe_unused]] std::size_t bytes) {
#if defined(__linux__) && defined(MADV_POPULATE_WRITE)
    const auto page = std::uintptr_t(::sysconf(_SC_PAGESIZE));
    const auto begin = (std::uintptr_t(p) + page - 1) / page * page;
    const auto end = (std::uintptr_t(p) + bytes) / page * page;
    if (end <= begin) return;
    const std::size_t parts = std::size_t((end - begin + kPartBytes - 1) / kPartBytes);
    tbb::parallel_for(std::size_t{0}, parts, [&](std::size_t i) {
        const std::uintptr_t from = begin + i * kPartBytes, to = std::min(end, from + kPartBytes);
        // Advice: a kernel without it (EINVAL) or short of memory leaves the faults to the first writes.
        (void)::madvise(reinterpret_cast<void*>(from), to - from, MADV_POPULATE_WRITE);
    });
#endif
}

}  // namespace smoketrace
