#pragma once
// Contract: the leaves textbook::walk_bvh reaches in the binary tree this one collapses, while tmax stays (each box
// lies in its parent's, and the slab test is monotone in the planes), in its own order and counts.
// The traversal loop of the 4-wide BVH (wide_bvh.hpp): the top level's walk for rays that collect every
// hit (TlasWalk::all_hits, trace.hpp). Each child's mask is tested before its box (DXR's instance
// inclusion, trace.hpp rule 1), so a subtree no visible instance lives in is never entered. Then the
// children the ray enters are taken in the ray's order along the node's axis: leaves at once, inner
// children the first next and the others pushed with their entry distances, so that one popped after a
// hit has shrunk tmax is skipped.
//
// Not strictly near to far, on purpose: a ray that collects every hit gains nothing from the order, and
// sorting the children by entry distance costs more than it saves. Camera rays, whose commits and early
// termination need the strict order, keep the binary walk (docs/design.md, "Two walks of the top level").
#include <smoketrace/core/simd/lanes.hpp>
#include <smoketrace/geometry/aabb.hpp>
#include <smoketrace/accel/bvh_traversal.hpp>
#include <smoketrace/accel/wide_box_test.hpp>
#include <smoketrace/accel/wide_bvh.hpp>

#include <bit>
#include <cstdint>
#include <cstring>
#include <limits>

namespace smoketrace {

// Bit i set when child i's mask meets the inclusion mask: the four mask bytes at once.
[[gnu::always_inline]] inline unsigned admitted_children(const WideBvhNode& n, std::uint8_t inclusion_mask) {
    using Bytes = simd::Bytes<kWideBvhWidth>;
    std::uint32_t masks;
    std::memcpy(&masks, n.mask, sizeof masks);
    masks &= 0x01010101u * inclusion_mask;
    return bits(Bytes::from_word(masks) != Bytes::broadcast(0));
}

// A 4-bit child set with slot i moved to slot 3 − i (the order a ray meets a node's children when it
// goes the negative way along the node's axis).
inline constexpr std::uint8_t kReversedSlots[16] = {0, 8, 4, 12, 2, 10, 6, 14, 1, 9, 5, 13, 3, 11, 7, 15};

// Calls leaf(first, count) for every leaf, among those whose mask meets `inclusion_mask`, whose box the
// ray enters before tmax; `tmax` is read through the reference at every step, so a leaf callback that
// commits a hit narrows the search. leaf returns true to end the traversal; the function then returns
// true. Counters: nodes_visited counts wide nodes and leaves, boxes_tested the child boxes tested
// (those whose mask admitted the ray).
template <class LeafFn>
inline bool traverse_wide_bvh(const WideBvh& bvh, const BoxRay& ray, const float& tmax, std::uint8_t inclusion_mask,
                              LeafFn&& leaf, TraversalStats& stats) {
    if (bvh.empty() || (bvh.root_mask() & inclusion_mask) == 0) return false;
    const WideBvhNode* nodes = bvh.nodes();
    const WideBoxTest<kWideBvhWidth> box_test(ray);
    // Per axis: 3 when the ray goes the negative way (children in reverse slot order), else 0.
    unsigned flip_of_axis[3];
    for (int a = 0; a < 3; ++a) flip_of_axis[a] = ray.near[a] == a + 3 ? 3u : 0u;

    // Inner children left for later. Each wide node pushes at most width − 1, and the wide tree is no
    // deeper than the binary.
    StackEntry stack[(kWideBvhWidth - 1) * kMaxBvhDepth + 1];
    int sp = 0;
    std::uint32_t node = 0;
    for (;;) {
        ++stats.nodes_visited;
        const WideBvhNode& n = nodes[node];
        const unsigned admitted = admitted_children(n, inclusion_mask);
        stats.boxes_tested += unsigned(std::popcount(admitted));
        alignas(16) float t[kWideBvhWidth];
        const unsigned hits = admitted != 0 ? box_test.test(n, tmax, t) & admitted : 0u;
        // Children in the order the ray goes along the node's axis (slots sorted there, wide_bvh.hpp):
        // j-th child of the ray's order is slot j ^ flip. Near to far in all but overlapping boxes, and
        // with no branch on the data: sorting by entry distance and branching on leaf versus inner child
        // were half the traversal's mispredictions, for a light ray rising through the smoke.
        const unsigned flip = flip_of_axis[n.axis];
        auto in_ray_order = [&](unsigned set) { return flip != 0 ? unsigned(kReversedSlots[set]) : set; };
        // Leaves first, each while it can still hold a hit before tmax. A hit one of them commits shrinks
        // tmax before the inner children are entered. (So a leaf may come before a nearer inner sibling's
        // subtree: any-hit order is unspecified, DXR rule 6, and the closest hit is found either way.)
        for (unsigned m = in_ray_order(hits & n.leaves); m != 0; m &= m - 1) {
            const unsigned i = unsigned(std::countr_zero(m)) ^ flip;
            if (!(t[i] <= tmax * kSlabFarScale)) continue;
            ++stats.nodes_visited;
            if (leaf(n.child[i], n.count[i])) return true;
        }
        if (unsigned m = in_ray_order(hits & ~unsigned(n.leaves)); m != 0) {
            // The first in ray order goes next; the others are pushed last first, so they pop in order.
            const unsigned first = unsigned(std::countr_zero(m)) ^ flip;
            for (m &= m - 1; m != 0;) {
                const unsigned j = 31u - unsigned(std::countl_zero(m));
                m &= ~(1u << j);
                const unsigned i = j ^ flip;
                stack[sp++] = StackEntry{n.child[i], t[i]};
            }
            // Tested again: a leaf above may have shrunk tmax since the box test.
            if (t[first] <= tmax * kSlabFarScale) {
                node = n.child[first];
                continue;
            }
        }
        // The next inner child that can still hold a hit before tmax.
        if (!pop_live_entry(stack, sp, tmax, node)) return false;
    }
}

}  // namespace smoketrace
