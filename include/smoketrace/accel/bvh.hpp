#pragma once
// The bounding volume hierarchy shared by every level of smoketrace: bottom-level trees over triangles
// and spheres, and the top-level tree over instances.
//
// Node layout (32 bytes): the node's own box, then either its children or its primitive range.
// The two children of a node are stored side by side as a pair at an even index (the root is node 0,
// node 1 is padding), and the node array is 64-byte aligned, so one cache line holds both child boxes:
// the traversal tests both children of a node after a single memory fetch, the same effect as a
// "child boxes in the parent" layout but with a node half the size. Nodes are in depth-first order, left
// subtree first (a pair always comes after its parent, and a node's descendants are the stretch of the array
// from its pair on): a refit is one backward sweep over the array, or over each subtree's stretch in
// parallel (bvh_bottom_up.hpp).
#include <smoketrace/core/aligned_allocator.hpp>
#include <smoketrace/geometry/aabb.hpp>

#include <cstddef>
#include <cstdint>
#include <span>
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

// Orders a wide node's n ≤ 16 slots (binary nodes, as wide_cut.hpp chooses them) by box centre along the
// axis on which the centres spread most, stably, so that ties keep the binary tree's left-right order;
// returns that axis (0, 1, 2).
int order_slots(const Bvh& binary, std::uint32_t* slots, unsigned n);

}  // namespace smoketrace
