#pragma once
// Fresh memory faulted in by several threads at once. The first write to a page of fresh memory costs a page
// fault (the kernel finds a page and zeroes it), and an array of ten million particles spans 10^5 pages: a
// std::vector grown by resize() takes those faults one after another, on one thread, in its pass that
// value-initialises the elements. With the pages populated first, by the threads of a TBB arena together,
// that pass only writes. (Arrays whose owner writes every element in parallel need no such pass at all:
// UnwrittenAllocator, aligned_allocator.hpp.)
#include <cstddef>
#include <vector>

namespace smoketrace {

// Faults in the pages wholly inside [p, p + bytes) for writing, parts of them on the threads of the calling
// thread's TBB arena: madvise(MADV_POPULATE_WRITE) on Linux 5.14 and later. Elsewhere, or where the kernel
// refuses it, nothing happens (the first writes fault the pages in, as they would have). Their contents
// are unchanged.
void populate_pages(void* p, std::size_t bytes);

// v.resize(n), where growing the storage first populates the part beyond the old elements (populate_pages).
template <class T>
void resize_populated(std::vector<T>& v, std::size_t n) {
    if (n > v.capacity()) {
        v.reserve(n);
        populate_pages(v.data() + v.size(), (n - v.size()) * sizeof(T));
    }
    v.resize(n);
}

}  // namespace smoketrace
