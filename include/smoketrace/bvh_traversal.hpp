#pragma once
// The one BVH traversal loop, shared by bottom-level trees (triangles, spheres) and the top level
// (instances). Front to back: of two children the nearer (by box entry distance) is visited first and
// the other is pushed with its entry distance, so that it is skipped when it is popped after a closer
// hit has shrunk tmax. The stack lives on the stack; the builder bounds the depth (kMaxBvhDepth).
#include <smoketrace/aabb.hpp>
#include <smoketrace/bvh.hpp>

#include <cstdint>

namespace smoketrace {

struct TraversalStats {
    std::uint32_t nodes_visited = 0;
    std::uint32_t boxes_tested = 0;
    std::uint32_t primitives_tested = 0;
};

// Calls leaf(first, count) for every leaf whose box the ray enters before tmax; `tmax` is read
// through the reference on every step, so a leaf callback that commits a hit narrows the search.
// leaf returns true to end the traversal; traverse_bvh then returns true.
// `enter(node)` may veto a child before its box is tested (the top level uses it to skip subtrees whose
// instance masks cannot match the ray); the default admits every node and compiles away.
struct AdmitAllNodes {
    constexpr bool operator()(std::uint32_t) const { return true; }
};

template <class LeafFn, class NodeFilter = AdmitAllNodes>
inline bool traverse_bvh(const Bvh& bvh, const BoxRay& ray, const float& tmax, LeafFn&& leaf,
                         TraversalStats& stats, NodeFilter&& enter = {}) {
    if (bvh.nodes.empty() || !enter(0u)) return false;
    const BvhNode* nodes = bvh.nodes.data();
    float t_root;
    ++stats.boxes_tested;
    if (!intersect(nodes[0].bounds, ray, tmax, t_root)) return false;

    struct Entry {
        std::uint32_t node;
        float t;
    };
    Entry stack[kMaxBvhDepth + 1];
    int sp = 0;
    std::uint32_t node = 0;
    for (;;) {
        ++stats.nodes_visited;
        const BvhNode& n = nodes[node];
        if (n.is_leaf()) {
            if (leaf(n.first, n.count)) return true;
        } else {
            float tl = 0.0f, tr = 0.0f;
            const bool el = enter(n.first), er = enter(n.first + 1);
            stats.boxes_tested += unsigned(el) + unsigned(er);
            const bool hl = el && intersect(nodes[n.first].bounds, ray, tmax, tl);
            const bool hr = er && intersect(nodes[n.first + 1].bounds, ray, tmax, tr);
            if (hl && hr) {
                const bool right_first = tr < tl;
                stack[sp++] = right_first ? Entry{n.first, tl} : Entry{n.first + 1, tr};
                node = right_first ? n.first + 1 : n.first;
                continue;
            }
            if (hl || hr) {
                node = hl ? n.first : n.first + 1;
                continue;
            }
        }
        // Pop the next subtree that can still hold a hit before tmax.
        for (;;) {
            if (sp == 0) return false;
            const Entry e = stack[--sp];
            if (e.t <= tmax * kSlabFarScale) {
                node = e.node;
                break;
            }
        }
    }
}

}  // namespace smoketrace
