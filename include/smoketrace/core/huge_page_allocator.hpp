#pragma once
// Memory in 2 MB pages for large arrays read at random: a mesh BLAS's wide nodes and triangle blocks, which
// an incoherent ray reaches by a chain of dependent loads. With 4 KB pages nearly every such load of a large
// mesh also misses the TLB; a 2 MB page covers 512 times as much, so the walk waits on the cache miss alone.
// Arrays of at least one huge page are aligned to 2 MB and advised as huge pages (Linux; elsewhere a no-op);
// smaller ones keep `SmallAlign` and waste nothing.
#include <cstddef>
#include <new>
#include <type_traits>
#include <utility>

namespace smoketrace {

inline constexpr std::size_t kHugePageBytes = std::size_t{2} << 20;

// Advises [p, p + bytes) as transparent huge pages when bytes ≥ kHugePageBytes (p 2 MB aligned). Advice is a
// hint: a failure changes nothing.
void advise_huge_pages(void* p, std::size_t bytes);

// kUnwritten: elements are grown without being written, as UnwrittenAllocator's (aligned_allocator.hpp), so
// that the owner's own writes are the first touch of the pages.
template <class T, std::size_t SmallAlign = 64, bool kUnwritten = false>
struct HugePageAllocator {
    using value_type = T;
    HugePageAllocator() = default;
    template <class U>
    HugePageAllocator(const HugePageAllocator<U, SmallAlign, kUnwritten>&) {}
    template <class U>
    struct rebind {
        using other = HugePageAllocator<U, SmallAlign, kUnwritten>;
    };
    T* allocate(std::size_t n) {
        const std::size_t bytes = n * sizeof(T);
        void* p = ::operator new(bytes, alignment_for(bytes));
        advise_huge_pages(p, bytes);
        return static_cast<T*>(p);
    }
    void deallocate(T* p, std::size_t n) { ::operator delete(p, alignment_for(n * sizeof(T))); }
    template <class U, class... Args>
    void construct(U* p, Args&&... args) {
        if constexpr (kUnwritten && sizeof...(Args) == 0) {
            static_assert(std::is_trivially_default_constructible_v<U>);
        } else {
            ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
        }
    }
    template <class U>
    bool operator==(const HugePageAllocator<U, SmallAlign, kUnwritten>&) const { return true; }

    static std::align_val_t alignment_for(std::size_t bytes) {
        return std::align_val_t{bytes >= kHugePageBytes ? kHugePageBytes : SmallAlign};
    }
};

}  // namespace smoketrace
