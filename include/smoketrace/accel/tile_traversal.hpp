#pragma once
// The walk of a ray tile (geometry/ray_tile.hpp) through a BVH: once for all the tile's rays, a node entered
// unless the tile's frustum excludes its box, or its box lies farther from the tile's origin than any ray
// of the tile reaches. trace_tile() walks the top level with it to gather the instances the tile's rays can
// meet (trace/trace_tile.hpp).
#include <smoketrace/accel/bvh.hpp>
#include <smoketrace/accel/bvh_traversal.hpp>
#include <smoketrace/geometry/ray_tile.hpp>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

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

}  // namespace smoketrace
