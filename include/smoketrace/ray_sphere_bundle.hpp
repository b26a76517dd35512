#pragma once
// sphere_roots() (ray_sphere.hpp) for the rays of a bundle (ray_bundle.hpp) against one sphere: its
// origins, one direction, eight lanes of doubles per AVX-512 operation (four per AVX2 one; a group with
// no ray entering the sphere's box is skipped); and which of the crossings found lie in each ray's
// [tmin, tmax], the candidates trace_bundle() hands to the rays' searches. AVX-512 against AVX2 on the
// optical-depth pass over spheres: 3 % faster (one thread, alternating runs).
//
// Same answers, bit for bit: each lane performs sphere_roots()'s operations in its order and precision
// (the build disables FMA contraction, CMakeLists.txt), copysign and negation are exact bit operations,
// "swap if t0 > t1" is a blend on the same comparison, and the conversion to float rounds to nearest like
// static_cast<float>. So a sphere hit has the same t whether its ray was traced alone or in a bundle; a
// test (test_trace_bundle.cpp) holds the two against each other, in each of the three builds CI makes
// (AVX-512 natively, AVX2 and plain x86-64 under the sanitizers). Without AVX2 the lanes run
// sphere_roots() itself.
#include <smoketrace/ray_bundle.hpp>
#include <smoketrace/ray_sphere.hpp>

#include <glm/vec3.hpp>

#include <bit>
#include <limits>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace smoketrace {

// What a sphere shows the rays of a bundle: per lane, the roots as sphere_roots() gives them, and the
// lanes whose entry / exit, rounded to float as trace() reports it, lies in their [tmin, tmax].
struct BundleSphereCrossings {
    alignas(64) double t_enter[kBundleWidth];
    alignas(64) double t_exit[kBundleWidth];
    unsigned enter = 0;  // bit i: lane i's ray crosses the sphere and enters it inside [tmin_i, tmax_i]
    unsigned exit = 0;   // the same for leaving it
};

// For each lane of `lanes` (a bit set over the bundle's lanes): the roots of the lane's ray, its origin
// taken relative to `translation` first (o − T, as trace()'s world-sphere path does), against the sphere
// (center, radius) in that frame; `tmax`: the lanes' current tmax (kBundleWidth floats, 64-byte
// aligned). A lane for which sphere_roots() returns false has neither bit set; t_enter / t_exit are
// meaningful only where a bit is set, and then equal sphere_roots()'s roots bit for bit.
inline void sphere_crossings_bundle(const RayBundle& b, unsigned lanes, const float* tmax,
                                    const glm::dvec3& translation, const glm::dvec3& center, double radius,
                                    BundleSphereCrossings& out) {
    const glm::dvec3 d(b.direction);
    out.enter = out.exit = 0;
#if defined(__AVX512F__) && defined(__AVX512DQ__)
    const double a_scalar = d.x * d.x + d.y * d.y + d.z * d.z;
    if (!(a_scalar > 0.0)) return;
    const __m512d dx = _mm512_set1_pd(d.x), dy = _mm512_set1_pd(d.y), dz = _mm512_set1_pd(d.z);
    const __m512d a = _mm512_set1_pd(a_scalar);
    const __m512d inv_a = _mm512_set1_pd(1.0 / a_scalar);  // as sphere_roots() divides, once per ray
    const __m512d r2 = _mm512_set1_pd(radius * radius);
    const __m512d sign_bit = _mm512_set1_pd(-0.0);
    const __m512d infinity = _mm512_set1_pd(std::numeric_limits<double>::infinity());
    // Conversions and sqrt in their maskz forms with every lane set: the plain forms trip GCC 12's false
    // -Wmaybe-uninitialized on their undefined pass-through operand (GCC bug 105593); same instructions.
    constexpr __mmask8 all = 0xFF;
    // Groups of eight lanes, walked as a bit set (see the AVX2 path below).
    unsigned groups = 0;
    for (unsigned g = 0; g < kBundleWidth / 8; ++g) groups |= unsigned(((lanes >> (8 * g)) & 0xFFu) != 0) << g;
    for (; groups != 0; groups &= groups - 1) {
        const unsigned first = 8 * unsigned(std::countr_zero(groups));
        const __m512d fx = _mm512_sub_pd(_mm512_sub_pd(_mm512_maskz_cvtps_pd(all, _mm256_load_ps(b.x + first)), _mm512_set1_pd(translation.x)),
                                         _mm512_set1_pd(center.x));
        const __m512d fy = _mm512_sub_pd(_mm512_sub_pd(_mm512_maskz_cvtps_pd(all, _mm256_load_ps(b.y + first)), _mm512_set1_pd(translation.y)),
                                         _mm512_set1_pd(center.y));
        const __m512d fz = _mm512_sub_pd(_mm512_sub_pd(_mm512_maskz_cvtps_pd(all, _mm256_load_ps(b.z + first)), _mm512_set1_pd(translation.z)),
                                         _mm512_set1_pd(center.z));
        const __m512d bq = _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(fx, dx), _mm512_mul_pd(fy, dy)), _mm512_mul_pd(fz, dz));
        const __m512d b_over_a = _mm512_mul_pd(bq, inv_a);
        const __m512d px = _mm512_sub_pd(fx, _mm512_mul_pd(b_over_a, dx));
        const __m512d py = _mm512_sub_pd(fy, _mm512_mul_pd(b_over_a, dy));
        const __m512d pz = _mm512_sub_pd(fz, _mm512_mul_pd(b_over_a, dz));
        const __m512d h2 = _mm512_sub_pd(
            r2, _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(px, px), _mm512_mul_pd(py, py)), _mm512_mul_pd(pz, pz)));
        const __mmask8 positive = _mm512_cmp_pd_mask(h2, _mm512_setzero_pd(), _CMP_GT_OQ);
        const __m512d c = _mm512_sub_pd(
            _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(fx, fx), _mm512_mul_pd(fy, fy)), _mm512_mul_pd(fz, fz)), r2);
        const __m512d root = _mm512_maskz_sqrt_pd(all, _mm512_mul_pd(a, h2));
        const __m512d signed_root = _mm512_or_pd(_mm512_andnot_pd(sign_bit, root), _mm512_and_pd(sign_bit, bq));
        const __m512d q = _mm512_xor_pd(_mm512_add_pd(bq, signed_root), sign_bit);
        const __m512d t0 = _mm512_div_pd(c, q);
        const __m512d t1 = _mm512_mul_pd(q, inv_a);
        const __mmask8 finite = _mm512_cmp_pd_mask(_mm512_andnot_pd(sign_bit, t0), infinity, _CMP_LT_OQ) &
                                _mm512_cmp_pd_mask(_mm512_andnot_pd(sign_bit, t1), infinity, _CMP_LT_OQ);
        const __mmask8 swap = _mm512_cmp_pd_mask(t0, t1, _CMP_GT_OQ);
        const __m512d near = _mm512_mask_blend_pd(swap, t0, t1), far = _mm512_mask_blend_pd(swap, t1, t0);
        _mm512_store_pd(out.t_enter + first, near);
        _mm512_store_pd(out.t_exit + first, far);
        const __m256 t_enter = _mm512_maskz_cvtpd_ps(all, near);  // rounded to nearest, as static_cast<float>
        const __m256 t_exit = _mm512_maskz_cvtpd_ps(all, far);
        const unsigned crosses = unsigned(positive & finite);
        const __m256 lo = _mm256_load_ps(b.tmin + first), hi = _mm256_load_ps(tmax + first);
        auto in_range = [&](__m256 t) {
            return unsigned(_mm256_movemask_ps(_mm256_and_ps(_mm256_cmp_ps(t, lo, _CMP_GE_OQ), _mm256_cmp_ps(t, hi, _CMP_LE_OQ))));
        };
        out.enter |= (crosses & in_range(t_enter)) << first;
        out.exit |= (crosses & in_range(t_exit)) << first;
    }
    out.enter &= lanes;
    out.exit &= lanes;
#elif defined(__AVX2__)
    const double a_scalar = d.x * d.x + d.y * d.y + d.z * d.z;
    if (!(a_scalar > 0.0)) return;
    const __m256d dx = _mm256_set1_pd(d.x), dy = _mm256_set1_pd(d.y), dz = _mm256_set1_pd(d.z);
    const __m256d a = _mm256_set1_pd(a_scalar);
    const __m256d inv_a = _mm256_set1_pd(1.0 / a_scalar);  // as sphere_roots() divides, once per ray
    const __m256d r2 = _mm256_set1_pd(radius * radius);
    const __m256d sign_bit = _mm256_set1_pd(-0.0);
    const __m256d infinity = _mm256_set1_pd(std::numeric_limits<double>::infinity());
    // The groups of four lanes with a ray to test, as a bit set walked in one loop: a test per group
    // whether to skip it was a branch on data, mispredicted often enough to cost more than it saved.
    unsigned groups = 0;
    for (unsigned g = 0; g < kBundleWidth / 4; ++g) groups |= unsigned(((lanes >> (4 * g)) & 0xFu) != 0) << g;
    for (; groups != 0; groups &= groups - 1) {
        const unsigned first = 4 * unsigned(std::countr_zero(groups));  // the group's first lane
        // f = (o − T) − c, each lane's origin widened exactly to double.
        const __m256d fx = _mm256_sub_pd(_mm256_sub_pd(_mm256_cvtps_pd(_mm_load_ps(b.x + first)), _mm256_set1_pd(translation.x)),
                                         _mm256_set1_pd(center.x));
        const __m256d fy = _mm256_sub_pd(_mm256_sub_pd(_mm256_cvtps_pd(_mm_load_ps(b.y + first)), _mm256_set1_pd(translation.y)),
                                         _mm256_set1_pd(center.y));
        const __m256d fz = _mm256_sub_pd(_mm256_sub_pd(_mm256_cvtps_pd(_mm_load_ps(b.z + first)), _mm256_set1_pd(translation.z)),
                                         _mm256_set1_pd(center.z));
        // b = f·d, perp = f − (b·(1/a))·d, h² = r² − |perp|²: sphere_roots()'s lines, term by term.
        const __m256d bq = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(fx, dx), _mm256_mul_pd(fy, dy)), _mm256_mul_pd(fz, dz));
        const __m256d b_over_a = _mm256_mul_pd(bq, inv_a);
        const __m256d px = _mm256_sub_pd(fx, _mm256_mul_pd(b_over_a, dx));
        const __m256d py = _mm256_sub_pd(fy, _mm256_mul_pd(b_over_a, dy));
        const __m256d pz = _mm256_sub_pd(fz, _mm256_mul_pd(b_over_a, dz));
        const __m256d h2 = _mm256_sub_pd(
            r2, _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(px, px), _mm256_mul_pd(py, py)), _mm256_mul_pd(pz, pz)));
        // No early exit when no lane has h² > 0: as a branch on data it cost more than the roots it saved.
        const __m256d positive = _mm256_cmp_pd(h2, _mm256_setzero_pd(), _CMP_GT_OQ);
        const __m256d c = _mm256_sub_pd(
            _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(fx, fx), _mm256_mul_pd(fy, fy)), _mm256_mul_pd(fz, fz)), r2);
        // q = −(b + copysign(√(a·h²), b)); lanes with h² ≤ 0 compute a NaN that is masked out below.
        const __m256d root = _mm256_sqrt_pd(_mm256_mul_pd(a, h2));
        const __m256d signed_root = _mm256_or_pd(_mm256_andnot_pd(sign_bit, root), _mm256_and_pd(sign_bit, bq));
        const __m256d q = _mm256_xor_pd(_mm256_add_pd(bq, signed_root), sign_bit);
        const __m256d t0 = _mm256_div_pd(c, q);
        const __m256d t1 = _mm256_mul_pd(q, inv_a);
        // std::isfinite of both roots (|t| < ∞, false for NaN), then "swap if t0 > t1".
        const __m256d finite = _mm256_and_pd(_mm256_cmp_pd(_mm256_andnot_pd(sign_bit, t0), infinity, _CMP_LT_OQ),
                                             _mm256_cmp_pd(_mm256_andnot_pd(sign_bit, t1), infinity, _CMP_LT_OQ));
        const __m256d swap = _mm256_cmp_pd(t0, t1, _CMP_GT_OQ);
        const __m256d near = _mm256_blendv_pd(t0, t1, swap), far = _mm256_blendv_pd(t1, t0, swap);
        _mm256_store_pd(out.t_enter + first, near);
        _mm256_store_pd(out.t_exit + first, far);
        const __m128 t_enter = _mm256_cvtpd_ps(near);  // rounded to nearest, as static_cast<float>
        const __m128 t_exit = _mm256_cvtpd_ps(far);
        const unsigned crosses = unsigned(_mm256_movemask_pd(_mm256_and_pd(positive, finite)));
        const __m128 lo = _mm_load_ps(b.tmin + first), hi = _mm_load_ps(tmax + first);
        auto in_range = [&](__m128 t) {
            return unsigned(_mm_movemask_ps(_mm_and_ps(_mm_cmp_ps(t, lo, _CMP_GE_OQ), _mm_cmp_ps(t, hi, _CMP_LE_OQ))));
        };
        out.enter |= (crosses & in_range(t_enter)) << first;
        out.exit |= (crosses & in_range(t_exit)) << first;
    }
    out.enter &= lanes;
    out.exit &= lanes;
#else
    for (unsigned m = lanes; m != 0; m &= m - 1) {
        const unsigned i = unsigned(__builtin_ctz(m));
        SphereRoots r;
        if (!sphere_roots(glm::dvec3(b.origin(i)) - translation, d, center, radius, r)) continue;
        out.t_enter[i] = r.t_enter;
        out.t_exit[i] = r.t_exit;
        const float te = static_cast<float>(r.t_enter), tx = static_cast<float>(r.t_exit);
        out.enter |= unsigned(te >= b.tmin[i] && te <= tmax[i]) << i;
        out.exit |= unsigned(tx >= b.tmin[i] && tx <= tmax[i]) << i;
    }
#endif
}

}  // namespace smoketrace
