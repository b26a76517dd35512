#pragma once
// Contract: for each of the tile's rays, at least the leaves textbook::walk_bvh reaches (a frustum and a reach
// stand in for each ray's box test); trace_tile() then tests each ray on its own.
// The walk of a ray tile (geometry/ray_tile.hpp) through a BVH: once for all the tile's rays, a node entered
// unless the tile's frustum excludes its box, or its box lies farther from the tile's origin than any ray
// of the tile reaches. trace_tile() walks the top level with it to gather the instances the tile's rays can
// meet (trace/trace_tile.hpp); the closest-hit tile query walks a mesh BLAS's wide tree with it
// (trace/blas_tile_traversal.hpp).
#include <smoketrace/accel/blas_wide_bvh.hpp>
#include <smoketrace/accel/blas_wide_traversal.hpp>
#include <smoketrace/accel/bvh.hpp>
#include <smoketrace/accel/bvh_traversal.hpp>
#include <smoketrace/core/simd/lanes.hpp>
#include <smoketrace/geometry/ray_tile.hpp>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <bit>
#include <cmath>
#include <cstdint>

namespace smoketrace {

// A lower bound on the t at which a ray from `p` of unit direction meets `box`: the distance from p to the
// box's nearest point (0 inside it), in double, less 2^-20 of it (a float unit direction's length is 1 only
// to a few units of 2^-24, and t is distance over that length), then made a float no larger than that.
[[nodiscard]] inline float distance_to_box(const glm::vec3& p, const Aabb& box) {
    const glm::dvec3 q(p);
    const glm::dvec3 d = glm::max(glm::max(glm::dvec3(box.lo) - q, q - glm::dvec3(box.hi)), glm::dvec3(0.0));
    const double dist = std::sqrt(glm::dot(d, d)) * (1.0 - 0x1p-20);
    const float f = static_cast<float>(dist);
    return double(f) > dist ? std::nextafter(f, 0.0f) : f;
}

// Calls leaf(first, count) for every leaf of `bvh` that the tile may see (see above) within distance
// `reach` of its origin (the largest tmax of its rays; the rays must have unit directions). `enter(node)`
// may veto a node before its box is tested, as in traverse_bvh(). Leaves come in depth-first order.
template <class LeafFn, class NodeFilter = AdmitAllNodes>
inline void traverse_bvh_tile(const Bvh& bvh, const RayTile& tile, float reach, LeafFn&& leaf, TraversalStats& stats,
                              NodeFilter&& enter = {}) {
    if (bvh.nodes.empty() || !enter(0u)) return;
    const BvhNode* nodes = bvh.nodes.data();
    auto visible = [&](std::uint32_t node) {
        ++stats.boxes_tested;
        const Aabb& b = nodes[node].bounds;
        return !tile.outside(b) && distance_to_box(tile.origin(), b) <= reach;
    };
    if (!visible(0)) return;
    std::uint32_t stack[kMaxBvhDepth + 1];
    int sp = 0;
    std::uint32_t node = 0;
    for (;;) {
        ++stats.nodes_visited;
        const BvhNode& n = nodes[node];
        if (n.is_leaf()) {
            leaf(n.first, n.count);
        } else {
            const bool vl = enter(n.first) && visible(n.first);
            const bool vr = enter(n.first + 1) && visible(n.first + 1);
            if (vl || vr) {
                if (vl && vr) stack[sp++] = n.first + 1;
                node = vl ? n.first : n.first + 1;
                continue;
            }
        }
        if (sp == 0) return;
        node = stack[--sp];
    }
}

// The tile's tests of a wide node's W child boxes (stored per plane, as BlasWideNode's) at once, in lanes of
// doubles: lane by lane the operations and roundings of RayTile::outside() and distance_to_box(), so the same
// decisions and distances. Returns the children (bit i, among the `used`) that the tile may see within
// `reach`, with their distances in `distance`.
template <unsigned W>
[[gnu::always_inline]] inline unsigned visible_children(const RayTile& tile, const float (&bounds)[6][W],
                                                        unsigned used, float reach, float* distance) {
    constexpr unsigned D = simd::kDoubleLanes < W ? simd::kDoubleLanes : W;
    using Doubles = simd::Doubles<D>;
    const glm::dvec3 o(tile.origin());
    const glm::dvec3* planes = tile.frustum_planes();
    const Doubles zero = Doubles::broadcast(0.0);
    unsigned outside = 0;
    alignas(64) double dist[W];
    for (unsigned h = 0; h < W; h += D) {
        Doubles lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
            lo[a] = Doubles::widen(bounds[a] + h) - Doubles::broadcast(o[a]);
            hi[a] = Doubles::widen(bounds[a + 3] + h) - Doubles::broadcast(o[a]);
        }
        for (int k = 0; k < 4; ++k) {
            const glm::dvec3& n = planes[k];
            // outside()'s corner that minimises n·q: the choice depends on the plane alone.
            const Doubles d = Doubles::broadcast(n.x) * (n.x > 0.0 ? lo[0] : hi[0]) +
                              Doubles::broadcast(n.y) * (n.y > 0.0 ? lo[1] : hi[1]) +
                              Doubles::broadcast(n.z) * (n.z > 0.0 ? lo[2] : hi[2]);
            outside |= bits(d > zero) << h;
        }
        // distance_to_box(): per axis max(lo − q, q − hi, 0) (q − hi is −(hi − q) exactly), then the length.
        Doubles sq[3];
        for (int a = 0; a < 3; ++a) {
            const Doubles g = max(max(lo[a], -hi[a]), zero);
            sq[a] = g * g;
        }
        store(dist + h, sqrt(sq[0] + sq[1] + sq[2]) * Doubles::broadcast(1.0 - 0x1p-20));
    }
    const unsigned all = W == 32 ? ~0u : (1u << used) - 1u;
    unsigned visible = 0;
    for (unsigned m = ~outside & all; m != 0; m &= m - 1) {
        const unsigned i = unsigned(std::countr_zero(m));
        const float f = static_cast<float>(dist[i]);
        distance[i] = double(f) > dist[i] ? std::nextafter(f, 0.0f) : f;
        if (distance[i] <= reach) visible |= 1u << i;
    }
    return visible;
}

// The walk of a ray tile through a mesh BLAS's wide tree (blas_wide_bvh.hpp), nearest first: a node's
// children that the tile may see within `reach` (read through the reference at every step, so a leaf
// callback that shortens the rays shortens the walk) are taken in the order of their boxes' distance from
// the tile's origin, the nearest next and the others stacked; an entry popped beyond the reach of that
// moment is skipped. Calls leaf(ref, count, box) for each leaf reached (ref: what the leaf slot holds, box
// its box); leaf returns true to end the walk. prefetch_leaf(ref, count) is called for each leaf the tile may
// see, when its parent is visited, as in traverse_blas_wide(); the children nodes are fetched then too.
template <unsigned W, class LeafFn, class PrefetchLeaf = NoLeafPrefetch>
inline void traverse_blas_wide_tile(const BlasWideBvh<W>& bvh, const RayTile& tile, const float& reach,
                                    LeafFn&& leaf, TraversalStats& stats, PrefetchLeaf&& prefetch_leaf = {}) {
    using detail::kLeafRef;
    if (bvh.empty()) return;
    const BlasWideNode<W>* nodes = bvh.nodes();
    auto slot_box = [&](const BlasWideNode<W>& n, unsigned i) {
        return Aabb{glm::vec3(n.bounds[0][i], n.bounds[1][i], n.bounds[2][i]),
                    glm::vec3(n.bounds[3][i], n.bounds[4][i], n.bounds[5][i])};
    };
    StackEntry stack[(W - 1) * kMaxBvhDepth + 1];
    int sp = 0;
    std::uint32_t ref = 0;
    for (;;) {
        ++stats.nodes_visited;
        if (ref & kLeafRef) {
            const std::uint32_t k = ref & ~kLeafRef;
            const BlasWideNode<W>& p = nodes[k / W];
            if (leaf(p.child[k % W], p.count[k % W], slot_box(p, k % W))) return;
        } else {
            const BlasWideNode<W>& n = nodes[ref];
            // The children the tile may see, by distance (insertion into at most W entries).
            StackEntry near[W];
            unsigned count = 0;
            stats.boxes_tested += n.used;
            alignas(64) float dist[W];
            for (unsigned m = visible_children(tile, n.bounds, n.used, reach, dist); m != 0; m &= m - 1) {
                const unsigned i = unsigned(std::countr_zero(m));
                const float d = dist[i];
                const bool is_leaf = (n.leaves >> i) & 1u;
                if (is_leaf) prefetch_leaf(n.child[i], n.count[i]);
                else detail::prefetch_bytes<sizeof(BlasWideNode<W>)>(nodes + n.child[i]);
                const std::uint32_t child = is_leaf ? kLeafRef | (ref * W + i) : n.child[i];
                unsigned j = count++;
                for (; j > 0 && near[j - 1].t > d; --j) near[j] = near[j - 1];
                near[j] = StackEntry{child, d};
            }
            if (count != 0) {
                for (unsigned j = count; j-- > 1;) stack[sp++] = near[j];
                ref = near[0].node;
                continue;
            }
        }
        if (!pop_live_entry(stack, sp, reach, ref)) return;
    }
}

}  // namespace smoketrace
