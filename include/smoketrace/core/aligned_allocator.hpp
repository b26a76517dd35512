#pragma once
// Allocators of aligned storage for std::vector: one that aligns, and one that also leaves grown elements
// unwritten. (Arrays of huge pages: huge_page_allocator.hpp.)
#include <cstddef>
#include <new>
#include <type_traits>
#include <utility>

namespace smoketrace {

// A std::vector allocator for over-aligned storage: a BVH's node pairs in one 64-byte cache line, a wide
// node or an instance record on a line of its own.
template <class T, std::size_t Align>
struct AlignedAllocator {
    using value_type = T;
    AlignedAllocator() = default;
    template <class U>
    AlignedAllocator(const AlignedAllocator<U, Align>&) {}
    template <class U>
    struct rebind { using other = AlignedAllocator<U, Align>; };
    T* allocate(std::size_t n) { return static_cast<T*>(::operator new(n * sizeof(T), std::align_val_t{Align})); }
    void deallocate(T* p, std::size_t) { ::operator delete(p, std::align_val_t{Align}); }
    bool operator==(const AlignedAllocator&) const { return true; }
};

// AlignedAllocator whose vectors leave the elements they grow by unwritten (default-initialised, not
// value-initialised): for large arrays of a type without initialisers whose owner writes every element
// itself, where zeroing them first was a serial pass over the whole array.
template <class T, std::size_t Align>
struct UninitialisedAlignedAllocator : AlignedAllocator<T, Align> {
    UninitialisedAlignedAllocator() = default;
    template <class U>
    UninitialisedAlignedAllocator(const UninitialisedAlignedAllocator<U, Align>&) {}
    template <class U>
    struct rebind { using other = UninitialisedAlignedAllocator<U, Align>; };
    template <class U>
    void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) { ::new (static_cast<void*>(p)) U; }
    template <class U, class... Args>
    void construct(U* p, Args&&... args) { ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...); }
};

}  // namespace smoketrace
