#pragma once
// The watertight ray/triangle test (ray_triangle.hpp) for eight triangles at once.
//
// A mesh BLAS keeps its triangles twice: as records in leaf order (for the rare full test) and as nine
// planes of floats, plane 3·j + a holding coordinate a of vertex j of every triangle in the same order
// (structure of arrays). shear_block() reads eight consecutive triangles from the planes, shears them in
// lanes of floats (core/simd/lanes.hpp: one AVX2 operation for the eight), decides from float edge
// functions which of them do not straddle the ray (exactly: see float_edge), and only those go on to
// finish_triangle_hit(), one by one. Most triangles of a leaf straddle (a ray crosses a closed surface
// twice), so the expensive part of the scalar test, the shear and the three double-precision edge
// functions, is done for eight triangles in about the instructions of one. (Without AVX2 the lanes are
// their scalar definition, eight at a time in plain C++.)
//
// Same answers, bit for bit: every lane performs the scalar shear_triangle()'s operations in the same
// order and precision (the build disables FMA contraction, CMakeLists.txt), the straddle decision is the
// scalar one, and finish_triangle_hit() sees the same numbers. Shared edges therefore stay watertight
// whichever kernel runs, and a test (test_geometry.cpp) checks the two kernels against each other.
#include <smoketrace/core/simd/lanes.hpp>
#include <smoketrace/geometry/ray_triangle.hpp>

#include <cstddef>
#include <cstdint>

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

namespace detail {
using BlockFloats = simd::Floats<kTriangleBlockLanes>;
using BlockDoubles = simd::Doubles<kTriangleBlockLanes / 2>;

// Four lanes' exact straddle test, the edge functions in double as in shear_triangle(): bit i set when
// lane i does not straddle.
[[gnu::always_inline]] inline unsigned exact_keep4(BlockDoubles ax, BlockDoubles ay, BlockDoubles bx, BlockDoubles by,
                                                   BlockDoubles cx, BlockDoubles cy) {
    const BlockDoubles u = cx * by - cy * bx;
    const BlockDoubles v = ax * cy - ay * cx;
    const BlockDoubles w = bx * ay - by * ax;
    const BlockDoubles zero = BlockDoubles::broadcast(0.0);
    const auto negative = (u < zero) | (v < zero) | (w < zero);
    const auto positive = (u > zero) | (v > zero) | (w > zero);
    return ~bits(negative & positive) & 0xFu;
}

// An edge function p·q − r·s in float, and whether its sign is the exact one. Rounding is monotonic,
// so p·q > r·s implies fl(p·q) ≥ fl(r·s), and a difference of two floats rounds with its exact sign:
// a nonzero result has the sign of the exact value. Zero (the two products rounded together) or NaN
// (overflow) says nothing, and the double computation decides.
[[gnu::always_inline]] inline BlockFloats float_edge(BlockFloats p, BlockFloats q, BlockFloats r, BlockFloats s,
                                                     simd::Mask<float, kTriangleBlockLanes>& certain) {
    const BlockFloats e = p * q - r * s;
    certain = differs(e, BlockFloats::broadcast(0.0f));
    return e;
}
}  // namespace detail

// Shears triangles [first, first + lanes) (lanes ≤ 8) into `out`; returns the mask of those that do not
// straddle the ray (bit i: triangle first + i), exactly the triangles for which
// straddles(shear_triangle(...)) is false, and for those lanes (only) also the exact edge functions.
//
// The straddle decision is made from float edge functions wherever their signs are certain, which is
// everywhere but on an edge (see float_edge). Only a block with a lane whose float edge function is 0
// forms the edge functions in double, with the scalar test's operations, to decide it exactly.
inline unsigned shear_block(const TriangleRay& r, const TrianglePlanes& tris, std::uint32_t first, unsigned lanes,
                            ShearedBlock& out) {
    using Floats = detail::BlockFloats;
    const unsigned valid = (1u << lanes) - 1u;
    const float* origin = &r.origin.x;
    const Floats ox = Floats::broadcast(origin[r.kx]), oy = Floats::broadcast(origin[r.ky]);
    const Floats oz = Floats::broadcast(origin[r.kz]);
    const Floats sx = Floats::broadcast(r.sx), sy = Floats::broadcast(r.sy);
    Floats px[3], py[3];
    for (int j = 0; j < 3; ++j) {
        // shear_triangle(): (v − origin) per component, then x − sx·z and y − sy·z.
        const Floats x = Floats::loadu(tris.at(j, r.kx, first)) - ox;
        const Floats y = Floats::loadu(tris.at(j, r.ky, first)) - oy;
        const Floats z = Floats::loadu(tris.at(j, r.kz, first)) - oz;
        px[j] = x - sx * z;
        py[j] = y - sy * z;
    }
    store(out.ax, px[0]);
    store(out.ay, py[0]);
    store(out.bx, px[1]);
    store(out.by, py[1]);
    store(out.cx, px[2]);
    store(out.cy, py[2]);

    simd::Mask<float, kTriangleBlockLanes> cu, cv, cw;
    const Floats u = detail::float_edge(px[2], py[1], py[2], px[1], cu);
    const Floats v = detail::float_edge(px[0], py[2], py[0], px[2], cv);
    const Floats w = detail::float_edge(px[1], py[0], py[1], px[0], cw);
    const Floats zero = Floats::broadcast(0.0f);
    const auto negative = (u < zero) | (v < zero) | (w < zero);
    const auto positive = (u > zero) | (v > zero) | (w > zero);
    const unsigned certain = bits(cu & cv & cw);
    const unsigned straddling = bits(negative & positive);
    unsigned keep = certain & ~straddling & valid;
    if (const unsigned uncertain = ~certain & valid; uncertain != 0) {
        using simd::widen_high;
        using simd::widen_low;
        const unsigned exact = detail::exact_keep4(widen_low(px[0]), widen_low(py[0]), widen_low(px[1]),
                                                   widen_low(py[1]), widen_low(px[2]), widen_low(py[2])) |
                               detail::exact_keep4(widen_high(px[0]), widen_high(py[0]), widen_high(px[1]),
                                                   widen_high(py[1]), widen_high(px[2]), widen_high(py[2])) << 4;
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
}

}  // namespace smoketrace
