// Huge-page advice for large arrays (see huge_page_allocator.hpp).
#include <smoketrace/core/huge_page_allocator.hpp>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace smoketrace {

void advise_huge_pages([[maybe_unused]] void* p, [[maybe_unused]] std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    // Only whole 2 MB pages inside the buffer become huge pages.
    if (bytes >= kHugePageBytes) (void)::madvise(p, bytes, MADV_HUGEPAGE);
#endif
}

}  // namespace smoketrace
