#pragma once
// The watertight ray/triangle test (ray_triangle.hpp) for eight triangles at once.
//
// A mesh BLAS keeps its triangles in blocks of eight (TriangleBlock): nine rows of eight floats, row 3·j + a
// holding coordinate a of vertex j of each lane's triangle (structure of arrays), and each lane's input
// triangle index, 320 bytes on five whole cache lines. shear_block() reads a block, shears its triangles in
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

// Eight triangles in plane form. Lanes past the triangles a block holds are zero (never read as a triangle:
// shear_block() masks them off). A leaf of a mesh BLAS owns its blocks whole, so its test reads
// consecutive memory.
struct alignas(64) TriangleBlock {
    float planes[9][kTriangleBlockLanes];  // planes[3·j + a][i]: coordinate a of vertex j of lane i
    std::uint32_t primitive[kTriangleBlockLanes];  // lane i's input triangle index

    [[nodiscard]] glm::vec3 vertex(unsigned lane, int j) const {
        return {planes[3 * j][lane], planes[3 * j + 1][lane], planes[3 * j + 2][lane]};
    }
    void set(unsigned lane, const glm::vec3& v0, const glm::vec3& v1, const glm::vec3& v2, std::uint32_t prim) {
        const glm::vec3* v[3] = {&v0, &v1, &v2};
        for (int j = 0; j < 3; ++j)
            for (int a = 0; a < 3; ++a) planes[3 * j + a][lane] = (*v[j])[a];
        primitive[lane] = prim;
    }
};
static_assert(sizeof(TriangleBlock) == 320);

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

// Shears lanes [0, lanes) (lanes ≤ 8) of the block into `out`; returns the mask of those that do not
// straddle the ray (bit i: lane i), exactly the triangles for which
// straddles(shear_triangle(...)) is false, and for those lanes (only) also the exact edge functions.
//
// The straddle decision is made from float edge functions wherever their signs are certain, which is
// everywhere but on an edge (see float_edge). Only a block with a lane whose float edge function is 0
// forms the edge functions in double, with the scalar test's operations, to decide it exactly.
inline unsigned shear_block(const TriangleRay& r, const TriangleBlock& block, unsigned lanes, ShearedBlock& out) {
    using Floats = detail::BlockFloats;
    const unsigned valid = (1u << lanes) - 1u;
    const float* origin = &r.origin.x;
    const Floats ox = Floats::broadcast(origin[r.kx]), oy = Floats::broadcast(origin[r.ky]);
    const Floats oz = Floats::broadcast(origin[r.kz]);
    const Floats sx = Floats::broadcast(r.sx), sy = Floats::broadcast(r.sy);
    Floats px[3], py[3];
    for (int j = 0; j < 3; ++j) {
        // shear_triangle(): (v − origin) per component, then x − sx·z and y − sy·z.
        const Floats x = Floats::load(block.planes[3 * j + r.kx]) - ox;
        const Floats y = Floats::load(block.planes[3 * j + r.ky]) - oy;
        const Floats z = Floats::load(block.planes[3 * j + r.kz]) - oz;
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
