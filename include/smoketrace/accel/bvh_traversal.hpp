#pragma once
// Contract: the nodes, their order and the counts of textbook::walk_bvh (textbook/trace.hpp), with the same box
// test; the ChildPairTest of AVX2 gives the scalar test's answers.
// The one BVH traversal loop, shared by bottom-level trees (triangles, spheres) and the top level
// (instances). Front to back: of two children the nearer (by box entry distance) is visited first and
// the other is pushed with its entry distance, so that it is skipped when it is popped after a closer
// hit has shrunk tmax. The stack lives on the stack; the builder bounds the depth (kMaxBvhDepth).
#include <smoketrace/core/simd/isa.hpp>
#include <smoketrace/geometry/aabb.hpp>
#include <smoketrace/accel/bvh.hpp>
#include <smoketrace/accel/child_pair_test_avx2.hpp>

#include <cstddef>
#include <cstdint>

namespace smoketrace {

struct TraversalStats {
    std::uint32_t nodes_visited = 0;
    std::uint32_t boxes_tested = 0;
    std::uint32_t primitives_tested = 0;
};

// Both children of an inner node against one ray: bit 0 of the result is the left child, bit 1 the right,
// with their entry distances in t_left / t_right. The definition: the scalar intersect() of aabb.hpp for
// each child. With AVX2 ChildPairTest is ChildPairTestAvx2 (child_pair_test_avx2.hpp), which gives the
// same answers in half the instructions.
class ChildPairTestScalar {
public:
    explicit ChildPairTestScalar(const BoxRay& r) : ray_(r) {}

    [[gnu::always_inline]] unsigned test(const BvhNode* pair, float tmax, float& t_left, float& t_right) const {
        return unsigned(intersect(pair[0].bounds, ray_, tmax, t_left)) |
               unsigned(intersect(pair[1].bounds, ray_, tmax, t_right)) << 1;
    }

private:
    const BoxRay& ray_;
};

#if defined(SMOKETRACE_SIMD_AVX2)
using ChildPairTest = ChildPairTestAvx2;
#else
using ChildPairTest = ChildPairTestScalar;
#endif

// A subtree left for later on a traversal stack, with the distance at which the ray enters its box.
struct StackEntry {
    std::uint32_t node;
    float t;
};

// Pops entries until one can still hold a hit before tmax, and returns its node; false when the stack
// runs out. Shared by the binary and the 4-wide walk (wide_bvh_traversal.hpp).
[[gnu::always_inline]] inline bool pop_live_entry(const StackEntry* stack, int& sp, float tmax, std::uint32_t& node) {
    for (;;) {
        if (sp == 0) return false;
        const StackEntry e = stack[--sp];
        if (e.t <= tmax * kSlabFarScale) {
            node = e.node;
            return true;
        }
    }
}

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
    const ChildPairTest pair_test(ray);

    StackEntry stack[kMaxBvhDepth + 1];
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
            const unsigned hits = (el || er) ? pair_test.test(nodes + n.first, tmax, tl, tr) : 0u;
            const bool hl = el && (hits & 1u), hr = er && (hits & 2u);
            if (hl && hr) {
                const bool right_first = tr < tl;
                stack[sp++] = right_first ? StackEntry{n.first, tl} : StackEntry{n.first + 1, tr};
                node = right_first ? n.first + 1 : n.first;
                continue;
            }
            if (hl || hr) {
                node = hl ? n.first : n.first + 1;
                continue;
            }
        }
        // The next subtree that can still hold a hit before tmax.
        if (!pop_live_entry(stack, sp, tmax, node)) return false;
    }
}

}  // namespace smoketrace
