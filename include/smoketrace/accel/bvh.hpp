#pragma once
// The bounding volume hierarchy shared by every level of smoketrace: bottom-level trees over triangles
// and spheres, and the top-level tree over instances.
//
// Node layout (32 bytes): the node's own box, then either its children or its primitive range.
// The two children of a node are stored side by side as a pair at an even index (the root is node 0,
// node 1 is padding), and the node array is 64-byte aligned, so one cache line holds both child boxes:
// the traversal tests both children of a node after a single memory fetch, the same effect as a
// "child boxes in the parent" layout but with a node half the size. Nodes are in depth-first order
// (a pair always comes after its parent), so a refit is one backward sweep over the array.
#include <smoketrace/geometry/aabb.hpp>

#include <cstddef>
#include <cstdint>
#include <new>
#include <span>
#include <type_traits>
#include <utility>
#include <vector>

namespace smoketrace {

struct alignas(32) BvhNode {
    Aabb bounds;
    std::uint32_t first;  // inner node: index of the left child (the right is first + 1);
                          // leaf: first entry in Bvh::prim_indices
    std::uint32_t count;  // 0 for an inner node, else the number of primitives in the leaf

    [[nodiscard]] bool is_leaf() const { return count != 0; }
};
static_assert(sizeof(BvhNode) == 32);

// Minimal allocator so that node pairs sit in one 64-byte cache line.
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

// AlignedAllocator whose vectors leave the elements they grow by unwritten, for implicit-lifetime types
// (trivially copyable and destructible, such as Aabb and BvhNode) whose owner writes every element whole:
// their initialisers made growing an array of ten million boxes or nodes a serial pass over fresh pages.
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

// Deepest tree any builder may produce; traversal stacks are this deep and live on the stack.
inline constexpr int kMaxBvhDepth = 64;

// SAH cost constants (Goldsmith–Salmon / MacDonald–Booth): cost of stepping through one inner node
// (two box tests) relative to one primitive test. 1:1 is the usual choice for a scalar triangle test
// that costs about as much as the two box tests of a node pair.
struct SahCosts {
    float traversal = 1.0f;
    float intersection = 1.0f;
};

// One node's term of the SAH sum before the division by the root's area: its box area times the cost
// of stepping through it (inner node) or of testing its primitives (leaf).
inline double sah_term(const BvhNode& n, const SahCosts& costs) {
    const double c = n.is_leaf() ? double(costs.intersection) * double(n.count) : double(costs.traversal);
    return double(n.bounds.area()) * c;
}

// A refit tree whose SAH cost exceeds this multiple of its cost when last built is rebuilt, by the TLAS
// (kTlasRebuildSahRatio) and by a deforming mesh BLAS (MeshBlas::update_vertices) alike. 1.2 keeps
// traversal within about 20 % of a fresh tree (SAH cost tracks nodes visited per ray closely) while
// letting small per-frame motion through with a refit alone; see bench "tlas".
inline constexpr double kRebuildSahRatio = 1.2;

struct Bvh {
    // nodes[0] is the root. Grown unwritten (the builder writes every node, in parallel): whoever grows
    // the array writes each new node whole.
    std::vector<BvhNode, UnwrittenAllocator<BvhNode, 64>> nodes;
    std::vector<std::uint32_t> prim_indices;                    // leaf ranges index into the input

    [[nodiscard]] bool empty() const { return nodes.empty(); }
    [[nodiscard]] const Aabb& bounds() const { return nodes[0].bounds; }
    [[nodiscard]] std::size_t node_count() const;  // nodes in use (padding slot excluded)
    [[nodiscard]] int depth() const;

    // Expected cost of a random ray that hits the root box (SAH): every node weighted by
    // area(node)/area(root), inner nodes by the traversal cost, leaves by intersection·count.
    [[nodiscard]] double sah_cost(const SahCosts& costs = {}) const;

    // Recomputes every box bottom-up from new primitive boxes, keeping the topology. O(nodes).
    void refit(std::span<const Aabb> prim_boxes);
};

// The children a wide node collapsed from binary node `node` takes (the top level's wide tree, wide_bvh.hpp):
// start from the node's two children (or the node itself, a leaf), then keep opening the inner slot of
// largest surface area (the one a ray is likeliest to enter) while fewer than `width` are taken; then
// order_slots(). Writes the binary nodes to `slots` (room for `width`).
struct WideSlots {
    unsigned count;
    int axis;  // 0, 1, 2
};
WideSlots collapse_slots(const Bvh& binary, std::uint32_t node, unsigned width, std::uint32_t* slots);

// Orders a wide node's n ≤ 16 slots (binary nodes) by box centre along the axis on which the centres spread
// most, stably, so that ties keep the binary tree's left-right order; returns that axis (0, 1, 2).
int order_slots(const Bvh& binary, std::uint32_t* slots, unsigned n);

}  // namespace smoketrace
