#pragma once
// The one BVH traversal loop, shared by bottom-level trees (triangles, spheres) and the top level
// (instances). Front to back: of two children the nearer (by box entry distance) is visited first and
// the other is pushed with its entry distance, so that it is skipped when it is popped after a closer
// hit has shrunk tmax. The stack lives on the stack; the builder bounds the depth (kMaxBvhDepth).
#include <smoketrace/geometry/aabb.hpp>
#include <smoketrace/accel/bvh.hpp>

#include <cstddef>
#include <cstdint>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace smoketrace {

struct TraversalStats {
    std::uint32_t nodes_visited = 0;
    std::uint32_t boxes_tested = 0;
    std::uint32_t primitives_tested = 0;
};

// Both children of an inner node against one ray: bit 0 of the result is the left child, bit 1 the right,
// with their entry distances in t_left / t_right. Exactly the scalar intersect() of aabb.hpp for each child
// (same operations, same roundings, NaN from 0·∞ ignored the same way), so every result is the same; with
// AVX2 the two boxes share one pass (half the instructions of two tests): each 32-byte node is loaded
// whole and permuted so that its lanes hold the ray's near x, y, z and far x, y, z planes; the far
// distances are negated so that one max reduction serves both ends.
class ChildPairTest {
public:
    explicit ChildPairTest(const BoxRay& r) : ray_(r) {
#if defined(__AVX2__)
        static_assert(sizeof(BvhNode) == 8 * sizeof(float) && offsetof(BvhNode, bounds) == 0);
        planes_ = _mm256_setr_epi32(r.near[0], r.near[1], r.near[2], r.far[0], r.far[1], r.far[2], 0, 0);
        origin_ = _mm256_setr_ps(r.origin.x, r.origin.y, r.origin.z, r.origin.x, r.origin.y, r.origin.z, 0.0f, 0.0f);
        scale_ = _mm256_setr_ps(r.inv_dir.x, r.inv_dir.y, r.inv_dir.z, -r.inv_far.x, -r.inv_far.y, -r.inv_far.z,
                                0.0f, 0.0f);
#endif
    }

    [[gnu::always_inline]] unsigned test(const BvhNode* pair, float tmax, float& t_left, float& t_right) const {
#if defined(__AVX2__)
        const float* base = reinterpret_cast<const float*>(pair);
        // Lanes (n_x, n_y, n_z, −f_x, −f_y, −f_z, ·, ·) per child; negation is exact, so −f is the scalar
        // far distance with its sign flipped.
        const __m256 l = _mm256_mul_ps(_mm256_sub_ps(_mm256_permutevar8x32_ps(_mm256_loadu_ps(base), planes_), origin_), scale_);
        const __m256 r = _mm256_mul_ps(_mm256_sub_ps(_mm256_permutevar8x32_ps(_mm256_loadu_ps(base + 8), planes_), origin_), scale_);
        const __m256 xy = _mm256_unpacklo_ps(l, r);  // nxL nxR nyL nyR | −fyL −fyR −fzL −fzR
        const __m256 z = _mm256_permutevar8x32_ps(_mm256_unpackhi_ps(l, r), _mm256_setr_epi32(0, 1, 0, 1, 2, 3, 2, 3));
        // max(candidate, current) returns `current` when the candidate is NaN (vmaxps returns its second
        // operand), which is the scalar test's "candidate > current ? candidate : current": a candidate
        // always goes first and the accumulator, never NaN, second.
        __m256 acc = _mm256_max_ps(xy, _mm256_set_m128(_mm_set1_ps(-(tmax * kSlabFarScale)), _mm_set1_ps(ray_.tmin)));
        acc = _mm256_max_ps(z, acc);
        acc = _mm256_max_ps(acc, _mm256_permute_ps(acc, _MM_SHUFFLE(1, 0, 3, 2)));
        const __m128 t_enter = _mm256_castps256_ps128(acc);                               // lanes 0, 1
        const __m128 t_exit = _mm_xor_ps(_mm256_extractf128_ps(acc, 1), _mm_set1_ps(-0.0f));  // lanes 0, 1
        t_left = _mm_cvtss_f32(t_enter);
        t_right = _mm_cvtss_f32(_mm_movehdup_ps(t_enter));
        return unsigned(_mm_movemask_ps(_mm_cmp_ps(t_enter, t_exit, _CMP_LE_OQ))) & 3u;
#else
        return unsigned(intersect(pair[0].bounds, ray_, tmax, t_left)) |
               unsigned(intersect(pair[1].bounds, ray_, tmax, t_right)) << 1;
#endif
    }

private:
    const BoxRay& ray_;
#if defined(__AVX2__)
    __m256i planes_;
    __m256 origin_;
    __m256 scale_;
#endif
};

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
