#pragma once
// A 4-wide BVH collapsed from a binary one: each node holds the boxes of up to four children side by side
// (structure of arrays), so that one SSE pass tests all four against a ray. The top level keeps one
// for the rays that collect every hit (trace.hpp, TlasWalk::all_hits): a light ray rising through the
// smoke walks a deep TLAS, and in a binary tree every second step is a poorly predicted branch on
// which child comes first; four children per node halve the steps.
//
// The binary tree stays the master copy. It is built and refit as a binary tree (its SAH cost drives the
// rebuild policy, accel_scene.hpp); collapse() derives the wide tree from it after a build, and refit() copies
// its boxes and masks over after a refit, through the binary node each child slot was made from.
#include <smoketrace/geometry/aabb.hpp>
#include <smoketrace/accel/bvh.hpp>

#include <cstdint>
#include <vector>

namespace smoketrace {

inline constexpr unsigned kWideBvhWidth = 4;

// One node: four child slots. Unused slots have an empty box (lo = +∞, hi = −∞, which every ray misses)
// and mask 0.
struct alignas(64) WideBvhNode {
    // bounds[p][i]: plane p of child i, planes in the order of planes() (lo.x, lo.y, lo.z, hi.x, hi.y,
    // hi.z), so that BoxRay's near / far plane indices select a whole row.
    alignas(16) float bounds[6][kWideBvhWidth];
    std::uint32_t child[kWideBvhWidth];  // inner: a WideBvhNode index; leaf: first entry in Bvh::prim_indices
    std::uint8_t count[kWideBvhWidth];   // 0: inner child (or unused); else the leaf's primitive count
    std::uint8_t mask[kWideBvhWidth];    // OR of the instance masks below the child; 0 if unused
    std::uint8_t leaves;                 // bit i set when child i is a leaf
    // The used slots are sorted by their boxes' centres along this axis (0, 1, 2): a ray going the
    // positive way along it meets them roughly in slot order, the other way in reverse.
    std::uint8_t axis;
};
static_assert(sizeof(WideBvhNode) == 128);

class WideBvh {
public:
    // Root at node 0. Which binary inner nodes become wide nodes is the cut of least total box area
    // (wide_cut.hpp), as for the mesh BLAS: nodes a ray is likely to enter are full and small subtrees
    // hang in their parent's slots. Each node orders its slots by order_slots() (bvh.hpp: along the axis
    // on which their centres spread most, WideBvhNode::axis). `node_masks` are
    // the binary nodes' masks (all 0xFF where masks are not used). Leaves keep their primitive ranges,
    // so Bvh::prim_indices serves both trees.
    void collapse(const Bvh& binary, const std::vector<std::uint8_t>& node_masks);
    // Boxes and masks from the binary tree after it was refit (same topology as at collapse()).
    void refit(const Bvh& binary, const std::vector<std::uint8_t>& node_masks);

    [[nodiscard]] bool empty() const { return nodes_.empty(); }
    [[nodiscard]] const WideBvhNode* nodes() const { return nodes_.data(); }
    [[nodiscard]] std::size_t node_count() const { return nodes_.size(); }
    [[nodiscard]] std::uint8_t root_mask() const { return root_mask_; }

private:
    // Grown unwritten: collapse() writes each node whole, in parallel, the first touch of their pages.
    std::vector<WideBvhNode, UnwrittenAllocator<WideBvhNode, 64>> nodes_;
    std::vector<std::uint32_t, UnwrittenAllocator<std::uint32_t>> source_;  // per node and slot: the binary
                                                                            // node it copies (~0u: unused)
    std::uint8_t root_mask_ = 0;
};

}  // namespace smoketrace
