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

// AlignedAllocator whose vectors leave the elements they grow by unwritten, for implicit-lifetime types
// (trivially copyable and destructible, such as Aabb, BvhNode and InstanceRecord) whose owner writes every
// element whole: their initialisers made growing an array of ten million boxes or nodes a serial pass over
// fresh pages, where the owner's own (parallel) writes should be the first touch.
template <class T, std::size_t Align = alignof(T)>
struct UnwrittenAllocator : AlignedAllocator<T, Align> {
    static_assert(std::is_trivially_copyable_v<T> && std::is_trivially_destructible_v<T>);
    UnwrittenAllocator() = default;
    template <class U>
    UnwrittenAllocator(const UnwrittenAllocator<U, Align>&) {}
    template <class U>
    struct rebind { using other = UnwrittenAllocator<U, Align>; };
    template <class U>
    void construct(U*) noexcept {}
    template <class U, class... Args>
    void construct(U* p, Args&&... args) { ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...); }
};

}  // namespace smoketrace
