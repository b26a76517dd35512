#pragma once
// Contract: the leaves textbook::walk_bvh reaches in the binary tree this one collapses, while tmax stays (each box
// lies in its parent's, and the slab test is monotone in the planes), in its own order and counts.
// The walks of a mesh BLAS's wide tree (blas_wide_bvh.hpp), for blas_traversal.hpp's queries and trace()'s
// object-space instance path (ray_search.hpp). Two orders:
//
// * nearest_first (closest hit, trace()): the children the ray enters are ordered by entry distance with
//   no branch on the data (one compare for two, a fixed sorting network over W keys for more), the
//   nearest taken next and the others pushed far first with their entry distances; an entry popped after
//   a hit has shrunk tmax beyond it is skipped. Leaves are stack entries like inner nodes, so a leaf is
//   tested only when nothing nearer is left.
// * any_order (all hits): slot order, leaves at once, no ordering work. A search that reports every hit
//   gains nothing from an order.
//
// Counters: nodes_visited counts wide nodes and leaves, boxes_tested the filled child slots of each node
// visited.
#include <smoketrace/core/simd/lanes.hpp>
#include <smoketrace/geometry/aabb.hpp>
#include <smoketrace/accel/blas_wide_bvh.hpp>
#include <smoketrace/accel/bvh_traversal.hpp>
#include <smoketrace/accel/wide_box_test.hpp>

#include <bit>
#include <cstddef>
#include <cstdint>

namespace smoketrace {

enum class BlasWalkOrder : std::uint8_t { nearest_first, any_order };

// The default leaf prefetch: none.
struct NoLeafPrefetch {
    void operator()(std::uint32_t, std::uint32_t) const {}
};

namespace detail {

// A float's bits as an unsigned integer of the same order (negative values below positive ones).
[[gnu::always_inline]] inline std::uint32_t ordered_bits(float t) {
    const std::uint32_t u = std::bit_cast<std::uint32_t>(t);
    return u ^ (std::uint32_t(std::int32_t(u) >> 31) | 0x80000000u);
}

[[gnu::always_inline]] inline void compare_swap(std::uint64_t* k, int a, int b) {
    const std::uint64_t lo = k[a] < k[b] ? k[a] : k[b];
    const std::uint64_t hi = k[a] < k[b] ? k[b] : k[a];
    k[a] = lo;
    k[b] = hi;
}

// Sorts W keys ascending with a fixed network (compiled to conditional moves: no branch on the data).
template <unsigned W>
[[gnu::always_inline]] inline void sort_keys(std::uint64_t* k) {
    if constexpr (W == 4) {
        compare_swap(k, 0, 1), compare_swap(k, 2, 3);
        compare_swap(k, 0, 2), compare_swap(k, 1, 3);
        compare_swap(k, 1, 2);
    } else {
        compare_swap(k, 0, 2), compare_swap(k, 1, 3), compare_swap(k, 4, 6), compare_swap(k, 5, 7);
        compare_swap(k, 0, 4), compare_swap(k, 1, 5), compare_swap(k, 2, 6), compare_swap(k, 3, 7);
        compare_swap(k, 0, 1), compare_swap(k, 2, 3), compare_swap(k, 4, 5), compare_swap(k, 6, 7);
        compare_swap(k, 2, 4), compare_swap(k, 3, 5);
        compare_swap(k, 1, 4), compare_swap(k, 3, 6);
        compare_swap(k, 1, 2), compare_swap(k, 3, 4), compare_swap(k, 5, 6);
    }
}

template <std::size_t Bytes>
[[gnu::always_inline]] inline void prefetch_bytes(const void* p) {
    for (std::size_t b = 0; b < Bytes; b += 64) __builtin_prefetch(static_cast<const char*>(p) + b);
}

// Stack references: an inner node's index, or kLeafRef | (node · W + slot) for the leaf in that slot.
inline constexpr std::uint32_t kLeafRef = 0x80000000u;

}  // namespace detail

// Calls leaf(ref, count) for every leaf whose box the ray enters before tmax (ref: what the leaf slot holds,
// see BlasWideBvh::collapse()); `tmax` is read through the reference at every step, so a leaf callback that
// commits a hit narrows the search. leaf returns true to end the traversal; the function then returns true.
// The root's own box is not tested: its children's are. prefetch_leaf(ref, count) is called for each leaf whose
// box the ray enters, when it is entered, with its count: a hint to start loading the leaf's primitives.
template <BlasWalkOrder Order, unsigned W, class LeafFn, class PrefetchLeaf = NoLeafPrefetch>
inline bool traverse_blas_wide(const BlasWideBvh<W>& bvh, const BoxRay& ray, const float& tmax, LeafFn&& leaf,
                               TraversalStats& stats, PrefetchLeaf&& prefetch_leaf = {}) {
    using detail::kLeafRef;
    if (bvh.empty()) return false;
    const BlasWideNode<W>* nodes = bvh.nodes();
    const WideBoxTest<W> box_test(ray);
    // Each node pushes at most W − 1 entries, and the wide tree is no deeper than the binary one.
    StackEntry stack[(W - 1) * kMaxBvhDepth + 1];
    int sp = 0;
    std::uint32_t ref = 0;
    // Counted in registers and added to `stats` on the way out: the leaf callback writes to `stats` too, so
    // counting there directly would be a store and a reload per node.
    std::uint32_t visited = 0, boxes = 0;
    auto finish = [&](bool ended) {
        stats.nodes_visited += visited;
        stats.boxes_tested += boxes;
        return ended;
    };
    for (;;) {
        ++visited;
        if (ref & kLeafRef) {
            const std::uint32_t k = ref & ~kLeafRef;
            const BlasWideNode<W>& p = nodes[k / W];
            if (leaf(p.child[k % W], p.count[k % W])) return finish(true);
        } else {
            const BlasWideNode<W>& n = nodes[ref];
            boxes += n.used;
            alignas(4 * W) float t[W];
            unsigned hits = box_test.test(n, tmax, t);
            // Every child entered is fetched now, so that the cache misses of siblings overlap instead of
            // following one another (an incoherent ray's walk waits on memory more than it computes).
            for (unsigned m = hits; m != 0; m &= m - 1) {
                const unsigned i = unsigned(std::countr_zero(m));
                if ((n.leaves >> i) & 1u) prefetch_leaf(n.child[i], n.count[i]);
                else detail::prefetch_bytes<sizeof(BlasWideNode<W>)>(nodes + n.child[i]);
            }
            // Without a branch: whether a hit child is a leaf is as unpredictable as which children are hit.
            auto ref_of = [&](unsigned i) {
                const std::uint32_t leaf_bits = 0u - ((unsigned(n.leaves) >> i) & 1u);
                return (n.child[i] & ~leaf_bits) | ((kLeafRef | (ref * W + i)) & leaf_bits);
            };
            if constexpr (Order == BlasWalkOrder::any_order) {
                // Leaves at once; the first inner child next, the others pushed.
                for (unsigned m = hits & n.leaves; m != 0; m &= m - 1) {
                    const unsigned i = unsigned(std::countr_zero(m));
                    if (!(t[i] <= tmax * kSlabFarScale)) continue;
                    ++visited;
                    if (leaf(n.child[i], n.count[i])) return finish(true);
                }
                hits &= ~unsigned(n.leaves);
                if (hits != 0) {
                    const unsigned first = unsigned(std::countr_zero(hits));
                    for (unsigned m = hits & (hits - 1); m != 0; m &= m - 1) {
                        const unsigned i = unsigned(std::countr_zero(m));
                        stack[sp++] = StackEntry{n.child[i], t[i]};
                    }
                    // Tested again: a leaf above may have shrunk tmax since the box test.
                    if (t[first] <= tmax * kSlabFarScale) {
                        ref = n.child[first];
                        continue;
                    }
                }
            } else if (hits != 0) {
                const unsigned first = unsigned(std::countr_zero(hits));
                const unsigned rest = hits & (hits - 1);
                if (rest == 0) {
                    ref = ref_of(first);
                    continue;
                }
                if ((rest & (rest - 1)) == 0) {
                    const unsigned second = unsigned(std::countr_zero(rest));
                    const unsigned swap = unsigned(t[second] < t[first]) * (first ^ second);
                    const unsigned near = first ^ swap, far = second ^ swap;
                    stack[sp++] = StackEntry{ref_of(far), t[far]};
                    ref = ref_of(near);
                    continue;
                }
                // Three or more: keys (entry distance, slot), the misses last, sorted by the network.
                std::uint64_t key[W];
                for (unsigned i = 0; i < W; ++i)
                    key[i] =
                        (std::uint64_t(detail::ordered_bits(t[i])) << 32 | i) | (0 - std::uint64_t((~hits >> i) & 1u));
                detail::sort_keys<W>(key);
                const int count = std::popcount(hits);
                for (int j = count - 1; j >= 1; --j) {
                    const unsigned i = unsigned(key[j] & 0xFFu);
                    stack[sp++] = StackEntry{ref_of(i), t[i]};
                }
                ref = ref_of(unsigned(key[0] & 0xFFu));
                continue;
            }
        }
        if (!pop_live_entry(stack, sp, tmax, ref)) return finish(false);
    }
}

}  // namespace smoketrace
