#pragma once
// The watertight ray/triangle test (ray_triangle.hpp) of one triangle against many rays that share their
// origin: the camera rays of a tile (ray_tile.hpp). The transpose of ray_triangle_block.hpp, which tests
// eight triangles against one ray.
//
// With a shared origin the vertices relative to it, v − origin, are the same for every ray; only the shear
// differs. Where the rays also share the dominant axes kx, ky, kz (every tile but the few on which the
// dominant axis of the camera rays changes), shear_lanes() shears the triangle for kFloatLanes rays in one
// operation per step, decides from float edge functions which rays it does not straddle (exactly, as
// shear_block() does: a float edge function whose sign is uncertain is recomputed in double), and only
// those rays go on to finish_triangle_hit(), one by one.
//
// Same answers, bit for bit: every lane performs the scalar shear_triangle()'s operations in the same order
// and precision, so a tile's ray meets exactly the triangles, edges and vertices its lone ray meets, and
// finish_triangle_hit() gives the same t and barycentrics (tests/test_trace_tile.cpp).
#include <smoketrace/core/simd/lanes.hpp>
#include <smoketrace/geometry/ray_tile.hpp>
#include <smoketrace/geometry/ray_triangle.hpp>

#include <cstdint>

namespace smoketrace {

// The per-ray part of the watertight test for a tile's rays: TriangleRay's shear per lane, and whether every
// ray of the tile has the same dominant axes (then shear_lanes() applies; else each ray takes the scalar test).
class TileTriangleRays {
public:
    int kx = 0, ky = 1, kz = 2;
    bool shared_axes = true;
    alignas(64) float sx[kTileRays];
    alignas(64) float sy[kTileRays];
    alignas(64) float sz[kTileRays];

    explicit TileTriangleRays(const RayTile& tile) : origin_(tile.origin()), tmin_(tile.tmin()), tile_(tile) {
        const TriangleRay first(tile.ray(0));
        kx = first.kx;
        ky = first.ky;
        kz = first.kz;
        for (unsigned lane = 0; lane < kTileRays; ++lane) {
            const TriangleRay r(tile.ray(lane));
            shared_axes = shared_axes && r.kx == kx && r.ky == ky && r.kz == kz;
            sx[lane] = r.sx;
            sy[lane] = r.sy;
            sz[lane] = r.sz;
        }
    }

    // Lane `lane`'s TriangleRay, field for field TriangleRay(tile.ray(lane)) (axes shared), without its division.
    [[nodiscard]] TriangleRay ray(unsigned lane) const {
        TriangleRay r;
        r.origin = origin_;
        r.direction = tile_.direction(lane);
        r.kx = kx;
        r.ky = ky;
        r.kz = kz;
        r.sx = sx[lane];
        r.sy = sy[lane];
        r.sz = sz[lane];
        r.tmin = tmin_;
        return r;
    }

private:
    glm::vec3 origin_;
    float tmin_;
    const RayTile& tile_;
};

// One triangle's sheared vertices and edge functions for a block of W lanes: lane i is the tile's ray
// first + i. The edge functions are filled for the lanes shear_lanes() keeps.
template <unsigned W>
struct ShearedLanes {
    alignas(64) float ax[W], ay[W], bx[W], by[W], cx[W], cy[W];
    double u[W], v[W], w[W];

    [[nodiscard]] ShearedTriangle lane(unsigned i) const {
        return {ax[i], ay[i], bx[i], by[i], cx[i], cy[i], u[i], v[i], w[i]};
    }
};

// The triangle v0 v1 v2 as `rays` lanes [first, first + W) see it (their axes shared: rays.shared_axes),
// a = v0 − origin, b = v1 − origin, c = v2 − origin in float, as shear_triangle() forms them. Returns the
// lanes (bit i: lane first + i, among `lanes`) the triangle does not straddle, exactly those for which
// straddles(shear_triangle(ray, v0, v1, v2)) is false, with their edge functions in `out`.
template <unsigned W>
[[gnu::always_inline]] inline unsigned shear_lanes(const TileTriangleRays& rays, unsigned first, unsigned lanes,
                                                   const glm::vec3& a, const glm::vec3& b, const glm::vec3& c,
                                                   ShearedLanes<W>& out) {
    using Floats = simd::Floats<W>;
    const Floats sx = Floats::load(rays.sx + first), sy = Floats::load(rays.sy + first);
    const float* pa = &a.x;
    const float* pb = &b.x;
    const float* pc = &c.x;
    // shear_triangle(): x − sx·z and y − sy·z of each vertex relative to the origin.
    const Floats ax = Floats::broadcast(pa[rays.kx]) - sx * Floats::broadcast(pa[rays.kz]);
    const Floats ay = Floats::broadcast(pa[rays.ky]) - sy * Floats::broadcast(pa[rays.kz]);
    const Floats bx = Floats::broadcast(pb[rays.kx]) - sx * Floats::broadcast(pb[rays.kz]);
    const Floats by = Floats::broadcast(pb[rays.ky]) - sy * Floats::broadcast(pb[rays.kz]);
    const Floats cx = Floats::broadcast(pc[rays.kx]) - sx * Floats::broadcast(pc[rays.kz]);
    const Floats cy = Floats::broadcast(pc[rays.ky]) - sy * Floats::broadcast(pc[rays.kz]);
    // Float edge functions: a nonzero one has the exact sign (shear_block()'s float_edge), a zero or NaN
    // one is decided in double below.
    const Floats u = cx * by - cy * bx;
    const Floats v = ax * cy - ay * cx;
    const Floats w = bx * ay - by * ax;
    const Floats zero = Floats::broadcast(0.0f);
    const unsigned certain = bits(differs(u, zero) & differs(v, zero) & differs(w, zero));
    const unsigned straddling = bits(((u < zero) | (v < zero) | (w < zero)) & ((u > zero) | (v > zero) | (w > zero)));
    store(out.ax, ax);
    store(out.ay, ay);
    store(out.bx, bx);
    store(out.by, by);
    store(out.cx, cx);
    store(out.cy, cy);
    unsigned keep = certain & ~straddling & lanes;
    const unsigned uncertain = ~certain & lanes;
    // The survivors' exact edge functions, and the rest (a ray through an edge or a vertex, or an overflow)
    // decided with them, all with shear_triangle()'s expressions.
    for (unsigned m = uncertain | keep; m != 0; m &= m - 1) {
        const unsigned i = unsigned(__builtin_ctz(m));
        out.u[i] = double(out.cx[i]) * double(out.by[i]) - double(out.cy[i]) * double(out.bx[i]);
        out.v[i] = double(out.ax[i]) * double(out.cy[i]) - double(out.ay[i]) * double(out.cx[i]);
        out.w[i] = double(out.bx[i]) * double(out.ay[i]) - double(out.by[i]) * double(out.ax[i]);
        if ((uncertain >> i & 1u) && !straddles(out.lane(i))) keep |= 1u << i;
    }
    return keep;
}

}  // namespace smoketrace
