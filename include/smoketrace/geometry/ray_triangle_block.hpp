#pragma once
// The watertight ray/triangle test (ray_triangle.hpp) for eight triangles at once.
//
// A mesh BLAS keeps its triangles twice: as records in leaf order (for the rare full test) and as nine
// planes of floats, plane 3·j + a holding coordinate a of vertex j of every triangle in the same order
// (structure of arrays). shear_block() reads eight consecutive triangles from the planes, shears them
// with AVX2, decides from float edge functions which of them do not straddle the ray (exactly: see
// float_edge), and only those go on to finish_triangle_hit(), one by one. Most triangles of a leaf
// straddle (a ray crosses a closed surface twice), so the expensive part of the scalar test, the shear
// and the three double-precision edge functions, is done for eight triangles in about the instructions
// of one.
//
// Same answers, bit for bit: every lane performs the scalar shear_triangle()'s operations in the same
// order and precision (the build disables FMA contraction, CMakeLists.txt), the straddle decision is the
// scalar one, and finish_triangle_hit() sees the same numbers. Shared edges therefore stay watertight
// whichever kernel runs, and a test (test_geometry.cpp) checks the two kernels against each other.
#include <smoketrace/geometry/ray_triangle.hpp>

#include <cstddef>
#include <cstdint>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace smoketrace {

inline constexpr std::uint32_t kTriangleBlockLanes = 8;

// One block's sheared vertices, lane i for triangle first + i, and the edge functions of the lanes
// shear_block() keeps.
struct ShearedBlock {
    alignas(32) float ax[8], ay[8], bx[8], by[8], cx[8], cy[8];
    alignas(32) double u[8], v[8], w[8];

    [[nodiscard]] ShearedTriangle lane(unsigned i) const {
        return {ax[i], ay[i], bx[i], by[i], cx[i], cy[i], u[i], v[i], w[i]};
    }
};

// Triangles in plane form: `planes` points at nine arrays of `stride` floats each (vertex j, axis a at
// planes + (3·j + a)·stride); every array holds at least kTriangleBlockLanes − 1 readable floats past its
// last triangle, so a block read at any triangle index stays inside it.
struct TrianglePlanes {
    const float* planes = nullptr;
    std::size_t stride = 0;

    [[nodiscard]] const float* at(int vertex, int axis, std::uint32_t first) const {
        return planes + std::size_t(3 * vertex + axis) * stride + first;
    }
};

#if defined(__AVX2__)
namespace detail {
// Lanes 0–3 and 4–7 of a float vector widened to double (exact).
inline __m256d low_pd(__m256 x) { return _mm256_cvtps_pd(_mm256_castps256_ps128(x)); }
inline __m256d high_pd(__m256 x) { return _mm256_cvtps_pd(_mm256_extractf128_ps(x, 1)); }

// Four lanes' exact straddle test, the edge functions in double as in shear_triangle(): bit i set when
// lane i does not straddle.
inline unsigned exact_keep4(__m256d ax, __m256d ay, __m256d bx, __m256d by, __m256d cx, __m256d cy) {
    const __m256d u = _mm256_sub_pd(_mm256_mul_pd(cx, by), _mm256_mul_pd(cy, bx));
    const __m256d v = _mm256_sub_pd(_mm256_mul_pd(ax, cy), _mm256_mul_pd(ay, cx));
    const __m256d w = _mm256_sub_pd(_mm256_mul_pd(bx, ay), _mm256_mul_pd(by, ax));
    const __m256d zero = _mm256_setzero_pd();
    const __m256d negative = _mm256_or_pd(_mm256_or_pd(_mm256_cmp_pd(u, zero, _CMP_LT_OQ), _mm256_cmp_pd(v, zero, _CMP_LT_OQ)),
                                          _mm256_cmp_pd(w, zero, _CMP_LT_OQ));
    const __m256d positive = _mm256_or_pd(_mm256_or_pd(_mm256_cmp_pd(u, zero, _CMP_GT_OQ), _mm256_cmp_pd(v, zero, _CMP_GT_OQ)),
                                          _mm256_cmp_pd(w, zero, _CMP_GT_OQ));
    return ~unsigned(_mm256_movemask_pd(_mm256_and_pd(negative, positive))) & 0xFu;
}

// An edge function p·q − r·s in float, and whether its sign is the exact one. Rounding is monotonic,
// so p·q > r·s implies fl(p·q) ≥ fl(r·s), and a difference of two floats rounds with its exact sign:
// a nonzero result has the sign of the exact value. Zero (the two products rounded together) or NaN
// (overflow) says nothing, and the double computation decides.
inline __m256 float_edge(__m256 p, __m256 q, __m256 r, __m256 s, __m256& certain) {
    const __m256 e = _mm256_sub_ps(_mm256_mul_ps(p, q), _mm256_mul_ps(r, s));
    certain = _mm256_cmp_ps(e, _mm256_setzero_ps(), _CMP_NEQ_OQ);
    return e;
}
}  // namespace detail
#endif

// Shears triangles [first, first + lanes) (lanes ≤ 8) into `out`; returns the mask of those that do not
// straddle the ray (bit i: triangle first + i), exactly the triangles for which
// straddles(shear_triangle(...)) is false, and for those lanes (only) also the exact edge functions.
//
// The straddle decision is made from float edge functions wherever their signs are certain, which is
// everywhere but on an edge (see float_edge). Only a block with a lane whose float edge function is 0
// forms the edge functions in double, with the scalar test's operations, to decide it exactly.
inline unsigned shear_block(const TriangleRay& r, const TrianglePlanes& tris, std::uint32_t first, unsigned lanes,
                            ShearedBlock& out) {
    const unsigned valid = (1u << lanes) - 1u;
#if defined(__AVX2__)
    const float* origin = &r.origin.x;
    const __m256 ox = _mm256_set1_ps(origin[r.kx]), oy = _mm256_set1_ps(origin[r.ky]), oz = _mm256_set1_ps(origin[r.kz]);
    const __m256 sx = _mm256_set1_ps(r.sx), sy = _mm256_set1_ps(r.sy);
    __m256 px[3], py[3];
    for (int j = 0; j < 3; ++j) {
        // shear_triangle(): (v − origin) per component, then x − sx·z and y − sy·z.
        const __m256 x = _mm256_sub_ps(_mm256_loadu_ps(tris.at(j, r.kx, first)), ox);
        const __m256 y = _mm256_sub_ps(_mm256_loadu_ps(tris.at(j, r.ky, first)), oy);
        const __m256 z = _mm256_sub_ps(_mm256_loadu_ps(tris.at(j, r.kz, first)), oz);
        px[j] = _mm256_sub_ps(x, _mm256_mul_ps(sx, z));
        py[j] = _mm256_sub_ps(y, _mm256_mul_ps(sy, z));
    }
    _mm256_store_ps(out.ax, px[0]);
    _mm256_store_ps(out.ay, py[0]);
    _mm256_store_ps(out.bx, px[1]);
    _mm256_store_ps(out.by, py[1]);
    _mm256_store_ps(out.cx, px[2]);
    _mm256_store_ps(out.cy, py[2]);

    __m256 cu, cv, cw;
    const __m256 u = detail::float_edge(px[2], py[1], py[2], px[1], cu);
    const __m256 v = detail::float_edge(px[0], py[2], py[0], px[2], cv);
    const __m256 w = detail::float_edge(px[1], py[0], py[1], px[0], cw);
    const __m256 zero = _mm256_setzero_ps();
    const __m256 negative = _mm256_or_ps(_mm256_or_ps(_mm256_cmp_ps(u, zero, _CMP_LT_OQ), _mm256_cmp_ps(v, zero, _CMP_LT_OQ)),
                                         _mm256_cmp_ps(w, zero, _CMP_LT_OQ));
    const __m256 positive = _mm256_or_ps(_mm256_or_ps(_mm256_cmp_ps(u, zero, _CMP_GT_OQ), _mm256_cmp_ps(v, zero, _CMP_GT_OQ)),
                                         _mm256_cmp_ps(w, zero, _CMP_GT_OQ));
    const unsigned certain = unsigned(_mm256_movemask_ps(_mm256_and_ps(_mm256_and_ps(cu, cv), cw)));
    const unsigned straddling = unsigned(_mm256_movemask_ps(_mm256_and_ps(negative, positive)));
    unsigned keep = certain & ~straddling & valid;
    if (const unsigned uncertain = ~certain & valid; uncertain != 0) {
        using detail::high_pd;
        using detail::low_pd;
        const unsigned exact = detail::exact_keep4(low_pd(px[0]), low_pd(py[0]), low_pd(px[1]), low_pd(py[1]),
                                                   low_pd(px[2]), low_pd(py[2])) |
                               detail::exact_keep4(high_pd(px[0]), high_pd(py[0]), high_pd(px[1]), high_pd(py[1]),
                                                   high_pd(px[2]), high_pd(py[2])) << 4;
        keep |= exact & uncertain;
    }
    // The survivors' exact edge functions, with shear_triangle()'s expressions on the same floats.
    for (unsigned m = keep; m != 0; m &= m - 1) {
        const unsigned i = unsigned(__builtin_ctz(m));
        out.u[i] = double(out.cx[i]) * double(out.by[i]) - double(out.cy[i]) * double(out.bx[i]);
        out.v[i] = double(out.ax[i]) * double(out.cy[i]) - double(out.ay[i]) * double(out.cx[i]);
        out.w[i] = double(out.bx[i]) * double(out.ay[i]) - double(out.by[i]) * double(out.ax[i]);
    }
    return keep;
#else
    unsigned keep = 0;
    for (unsigned i = 0; i < lanes; ++i) {
        const std::uint32_t k = first + i;
        const glm::vec3 v0(*tris.at(0, 0, k), *tris.at(0, 1, k), *tris.at(0, 2, k));
        const glm::vec3 v1(*tris.at(1, 0, k), *tris.at(1, 1, k), *tris.at(1, 2, k));
        const glm::vec3 v2(*tris.at(2, 0, k), *tris.at(2, 1, k), *tris.at(2, 2, k));
        const ShearedTriangle s = shear_triangle(r, v0, v1, v2);
        out.ax[i] = s.ax, out.ay[i] = s.ay, out.bx[i] = s.bx, out.by[i] = s.by, out.cx[i] = s.cx, out.cy[i] = s.cy;
        out.u[i] = s.u, out.v[i] = s.v, out.w[i] = s.w;
        keep |= unsigned(!straddles(s)) << i;
    }
    return keep & valid;
#endif
}

}  // namespace smoketrace
