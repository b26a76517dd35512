#pragma once
// ChildPairTest's AVX2 kernel (bvh_traversal.hpp): both children of an inner node against one ray in one
// pass, 27 instructions instead of the scalar definition's 54 (callgrind). Each 32-byte node is loaded
// whole and permuted so that its lanes hold the ray's near x, y, z and far x, y, z planes; the far
// distances are negated so that one max reduction serves both ends. The shuffles it lives on have no
// counterpart in the lanes types (core/simd/lanes.hpp), so it stays in AVX2 instructions.
//
// The same answers as ChildPairTestScalar, two intersect() calls of aabb.hpp: the same operations and
// roundings, NaN from 0·∞ ignored the same way, so the same hit bits and entry distances (a hit's entry
// distance may be +0 where the scalar one is −0: the reductions order the equal candidates differently).
// tests/test_bvh.cpp holds the two against each other.
#include <smoketrace/core/simd/isa.hpp>
#include <smoketrace/geometry/aabb.hpp>
#include <smoketrace/accel/bvh.hpp>

#include <cstddef>

#if defined(SMOKETRACE_SIMD_AVX2)
#include <immintrin.h>

namespace smoketrace {

class ChildPairTestAvx2 {
public:
    explicit ChildPairTestAvx2(const BoxRay& r) : ray_(r) {
        static_assert(sizeof(BvhNode) == 8 * sizeof(float) && offsetof(BvhNode, bounds) == 0);
        planes_ = _mm256_setr_epi32(r.near[0], r.near[1], r.near[2], r.far[0], r.far[1], r.far[2], 0, 0);
        origin_ = _mm256_setr_ps(r.origin.x, r.origin.y, r.origin.z, r.origin.x, r.origin.y, r.origin.z, 0.0f, 0.0f);
        scale_ = _mm256_setr_ps(r.inv_dir.x, r.inv_dir.y, r.inv_dir.z, -r.inv_far.x, -r.inv_far.y, -r.inv_far.z,
                                0.0f, 0.0f);
    }

    // Bit 0: the ray meets pair[0]'s box in [tmin, tmax], with its entry distance in t_left; bit 1:
    // pair[1], t_right.
    [[gnu::always_inline]] unsigned test(const BvhNode* pair, float tmax, float& t_left, float& t_right) const {
        const float* base = reinterpret_cast<const float*>(pair);
        // Lanes (n_x, n_y, n_z, −f_x, −f_y, −f_z, ·, ·) per child; negation is exact, so −f is the scalar
        // far distance with its sign flipped.
        const __m256 l =
            _mm256_mul_ps(_mm256_sub_ps(_mm256_permutevar8x32_ps(_mm256_loadu_ps(base), planes_), origin_), scale_);
        const __m256 r =
            _mm256_mul_ps(_mm256_sub_ps(_mm256_permutevar8x32_ps(_mm256_loadu_ps(base + 8), planes_), origin_), scale_);
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
    }

private:
    const BoxRay& ray_;
    __m256i planes_;
    __m256 origin_;
    __m256 scale_;
};

}  // namespace smoketrace
#endif  // SMOKETRACE_SIMD_AVX2
