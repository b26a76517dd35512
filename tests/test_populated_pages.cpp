// Fresh pages faulted in on several threads (populated_pages.hpp): the pages are there before the first
// write, their contents unchanged, and resize_populated() is resize().
#include <smoketrace/core/populated_pages.hpp>

#include <catch2/catch.hpp>
#include <tbb/task_arena.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <numeric>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>
#endif

using namespace smoketrace;

TEST_CASE("populated pages: resize_populated() keeps the elements and value-initialises the new ones",
          "[populated_pages]") {
    std::vector<std::uint64_t> v(1000);
    std::iota(v.begin(), v.end(), 1);
    tbb::task_arena(2).execute([&] { resize_populated(v, 3'000'000); });
    REQUIRE(v.size() == 3'000'000);
    for (std::size_t i = 0; i < 1000; ++i) REQUIRE(v[i] == i + 1);
    for (std::size_t i = 1000; i < v.size(); ++i) REQUIRE(v[i] == 0);
    resize_populated(v, 10);  // shrinking, as resize()
    CHECK(v.size() == 10);
    CHECK(v[9] == 10);
    populate_pages(nullptr, 0);  // nothing to populate
}

#if defined(__linux__) && defined(MADV_POPULATE_WRITE)
namespace {
long minor_faults() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return usage.ru_minflt;
}
}  // namespace

TEST_CASE("populated pages: fresh pages are faulted in before the first write, and keep what they hold",
          "[populated_pages]") {
    const auto page = std::size_t(::sysconf(_SC_PAGESIZE));
    const std::size_t pages = 4096, bytes = pages * page;
    auto* p = static_cast<unsigned char*>(
        ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0));
    REQUIRE(p != MAP_FAILED);
    if (::madvise(p, page, MADV_POPULATE_WRITE) != 0) {
        WARN("this kernel has no MADV_POPULATE_WRITE (before Linux 5.14): populate_pages() does nothing");
        ::munmap(p, bytes);
        return;
    }
    p[page] = 42;  // a page already there, written
    // From one byte into the first page: only the pages wholly inside are populated (the first one was, above).
    tbb::task_arena(2).execute([&] { populate_pages(p + 1, bytes - 1 - page / 2); });
    // Writing every page but the last (only half of it was inside) now takes no fault of its own. A
    // sanitizer's writes also fault in fresh shadow pages; the same writes over a second fresh mapping, not
    // populated, fault in as many of those, so the difference is the pages' own faults.
    auto write_pages = [&](unsigned char* q) {
        const long before = minor_faults();
        for (std::size_t i = 0; i + 1 < pages; ++i) q[i * page + 7] = 1;
        return minor_faults() - before;
    };
    auto* fresh = static_cast<unsigned char*>(
        ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0));
    REQUIRE(fresh != MAP_FAILED);
    // In 4 KiB pages, each its own fault, whatever the system's transparent huge page setting.
    (void)::madvise(fresh, bytes, MADV_NOHUGEPAGE);
    const long populated_faults = write_pages(p), fresh_faults = write_pages(fresh);
    CHECK(fresh_faults - populated_faults > long(pages - pages / 64));
    CHECK(p[page] == 42);
    CHECK(p[page + 8] == 0);
    ::munmap(fresh, bytes);
    ::munmap(p, bytes);
}
#endif
