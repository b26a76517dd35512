#pragma once
// The wide tree of a mesh BLAS: the binary SAH tree (bvh.hpp) collapsed into nodes of W children (4 or 8),
// each node holding its children's boxes side by side per plane, so that one operation over W lanes tests
// every child against a ray (WideBoxTest, wide_box_test.hpp). A binary node costs one or two
// poorly predicted branches per step; a W-wide node replaces about log2(W) of them.
//
// The binary tree stays the master copy, as for the TLAS (wide_bvh.hpp): it is what the builder makes and
// what the SAH cost is read from; collapse() derives the wide tree from it. A leaf slot keeps its binary
// leaf's primitive count and names where the leaf's primitives are (a mesh BLAS: its first triangle block).
#include <smoketrace/core/huge_page_allocator.hpp>
#include <smoketrace/accel/bvh.hpp>

#include <cstdint>
#include <span>
#include <vector>

namespace smoketrace {

// One node of W child slots. Slots 0 … used − 1 are filled; the others have an empty box (lo = +∞,
// hi = −∞, which every ray misses) so that the box test needs no mask.
template <unsigned W>
struct alignas(64) BlasWideNode {
    static_assert(W == 4 || W == 8);
    // bounds[p][i]: plane p of child i, planes in the order of planes() (lo.x, lo.y, lo.z, hi.x, hi.y,
    // hi.z), so that BoxRay's near / far plane indices select a whole row.
    float bounds[6][W];
    std::uint32_t child[W];  // inner: a node index; leaf: what collapse() was given for it
    std::uint8_t count[W];   // leaf: its primitive count (≥ 1); inner or unused: 0
    std::uint8_t used;       // filled slots
    std::uint8_t leaves;     // bit i set when child i is a leaf
    // The filled slots are sorted by their boxes' centres along this axis (0, 1, 2): a ray going the
    // positive way meets them roughly in slot order.
    std::uint8_t axis;
};
static_assert(sizeof(BlasWideNode<4>) == 128);
static_assert(sizeof(BlasWideNode<8>) == 256);

template <unsigned W>
class BlasWideBvh {
public:
    using Node = BlasWideNode<W>;

    // Root at node 0. Which binary inner nodes become wide nodes is the cut of least total box area (the
    // wide tree's SAH cost; wide_cut.hpp), so that nodes a ray is likely to enter are
    // full and small subtrees hang in their parent's slots; a node's slots are ordered by order_slots()
    // (bvh.hpp). A node's inner children are stored side by side. A leaf slot's child is leaf_refs[i] for
    // the binary leaf node i (leaf_refs has one entry per binary node). Throws std::length_error for a leaf
    // of more than 255 primitives.
    void collapse(const Bvh& binary, std::span<const std::uint32_t> leaf_refs);

    [[nodiscard]] bool empty() const { return nodes_.empty(); }
    [[nodiscard]] const Node* nodes() const { return nodes_.data(); }
    [[nodiscard]] std::size_t node_count() const { return nodes_.size(); }

private:
    // In huge pages (a walk reads it at random), grown unwritten: collapse() writes each node whole.
    std::vector<Node, HugePageAllocator<Node, 64, /*kUnwritten=*/true>> nodes_;
};

extern template class BlasWideBvh<4>;
extern template class BlasWideBvh<8>;

}  // namespace smoketrace
