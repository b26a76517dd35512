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
#include <smoketrace/geometry/ray_triangle_block.hpp>
#include <smoketrace/geometry/ray_triangle.hpp>

#include <bit>
#include <cstdint>
#include <limits>

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
        // TriangleRay's set-up in lanes: the same comparisons pick each ray's axes, the same division and
        // products make its shear, so a lane holds TriangleRay(tile.ray(lane))'s numbers when its axes are
        // lane 0's; if one ray's differ, the table is not used (shared_axes false).
        using Floats = simd::Floats<simd::kFloatLanes>;
        const float* d[3] = {tile.direction_x(), tile.direction_y(), tile.direction_z()};
        const Floats zero = Floats::broadcast(0.0f), one = Floats::broadcast(1.0f);
        const bool negative = d[kz][0] < 0.0f;
        for (unsigned lane = 0; lane < kTileRays; lane += simd::kFloatLanes) {
            const Floats x = Floats::load(d[0] + lane), y = Floats::load(d[1] + lane), z = Floats::load(d[2] + lane);
            const Floats ax = abs(x), ay = abs(y), az = abs(z);
            const unsigned x_over_y = bits(ax > ay);
            const unsigned on_x = x_over_y & bits(ax > az), on_y = ~x_over_y & bits(ay > az);
            const unsigned all = simd::kFloatLanes == 32 ? ~0u : (1u << simd::kFloatLanes) - 1u;
            const unsigned on_kz = kz == 0 ? on_x : kz == 1 ? on_y : ~(on_x | on_y) & all;
            const Floats dkz = Floats::load(d[kz] + lane);
            const unsigned sign = bits(dkz < zero);
            if (on_kz != all || sign != (negative ? all : 0u)) {
                shared_axes = false;
                return;
            }
            const Floats s = one / dkz;
            store(sz + lane, s);
            store(sx + lane, Floats::load(d[kx] + lane) * s);
            store(sy + lane, Floats::load(d[ky] + lane) * s);
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
    alignas(64) double u[W], v[W], w[W];

    [[nodiscard]] ShearedTriangle lane(unsigned i) const {
        return {ax[i], ay[i], bx[i], by[i], cx[i], cy[i], u[i], v[i], w[i]};
    }
};

// The triangle v0 v1 v2 as `rays` lanes [first, first + W) see it (their axes shared: rays.shared_axes),
// from a = v0 − origin, b = v1 − origin, c = v2 − origin in float, as shear_triangle() forms them. Returns the
// lanes (bit i: lane first + i, among `lanes`) the triangle does not straddle, exactly those for which
// straddles(shear_triangle(ray, v0, v1, v2)) is false, with their edge functions in `out` (the edge
// functions of other lanes may be left unset).
//
// The triangle comes as `rel`: the three vertices relative to the origin, each in the rays' axes (kx, ky, kz),
// rel[3·j + k] for vertex j; relative() makes them from world-space vertices.
struct RelativeTriangle {
    float rel[9];
};
[[nodiscard]] inline RelativeTriangle relative(const TileTriangleRays& rays, const glm::vec3& origin,
                                               const glm::vec3& v0, const glm::vec3& v1, const glm::vec3& v2) {
    const glm::vec3* v[3] = {&v0, &v1, &v2};
    const int axis[3] = {rays.kx, rays.ky, rays.kz};
    RelativeTriangle t;
    for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k) t.rel[3 * j + k] = (*v[j])[axis[k]] - origin[axis[k]];
    return t;
}

template <unsigned W>
[[gnu::always_inline]] inline unsigned shear_lanes(const TileTriangleRays& rays, unsigned first, unsigned lanes,
                                                   const RelativeTriangle& t, ShearedLanes<W>& out) {
    using Floats = simd::Floats<W>;
    const Floats sx = Floats::load(rays.sx + first), sy = Floats::load(rays.sy + first);
    const float* r = t.rel;
    // shear_triangle(): x − sx·z and y − sy·z of each vertex relative to the origin.
    const Floats ax = Floats::broadcast(r[0]) - sx * Floats::broadcast(r[2]);
    const Floats ay = Floats::broadcast(r[1]) - sy * Floats::broadcast(r[2]);
    const Floats bx = Floats::broadcast(r[3]) - sx * Floats::broadcast(r[5]);
    const Floats by = Floats::broadcast(r[4]) - sy * Floats::broadcast(r[5]);
    const Floats cx = Floats::broadcast(r[6]) - sx * Floats::broadcast(r[8]);
    const Floats cy = Floats::broadcast(r[7]) - sy * Floats::broadcast(r[8]);
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
    if ((keep | uncertain) == 0) return 0;
    // The exact edge functions, with shear_triangle()'s expressions: for the survivors, and to decide the rest
    // (a ray through an edge or a vertex, or an overflow).
    // Half a block of doubles at a time (one lane at a time in the scalar twin, W = 1).
    constexpr unsigned D = W >= 2 ? W / 2 : 1;
    using Doubles = simd::Doubles<D>;
    for (unsigned h = 0; h < W; h += D) {
        if ((((keep | uncertain) >> h) & ((1u << D) - 1u)) == 0) continue;  // no lane of this half is needed
        const Doubles dax = Doubles::widen(out.ax + h), day = Doubles::widen(out.ay + h);
        const Doubles dbx = Doubles::widen(out.bx + h), dby = Doubles::widen(out.by + h);
        const Doubles dcx = Doubles::widen(out.cx + h), dcy = Doubles::widen(out.cy + h);
        store(out.u + h, dcx * dby - dcy * dbx);
        store(out.v + h, dax * dcy - day * dcx);
        store(out.w + h, dbx * day - dby * dax);
    }
    for (unsigned m = uncertain; m != 0; m &= m - 1) {
        const unsigned i = unsigned(__builtin_ctz(m));
        if (!straddles(out.lane(i))) keep |= 1u << i;
    }
    return keep;
}

// finish_triangle_hit() for the lanes `keep` of a block that shear_lanes() kept, in lanes of doubles: the
// same operations on the same numbers, so each lane gets the scalar function's t and facing, bit for bit
// (its barycentrics: lane_barycentrics(), for the lanes that hit). The plane's distance n·(v0 − origin) is the same for every ray of the tile (`n_dot_p`, formed
// as the scalar function forms it). Lanes with an edge function or determinant of exactly 0 (or NaN: an
// overflow), where the tie-break decides, are returned in `on_edge` for finish_triangle_hit() itself; `hit`
// holds the others whose t lies in [tmin, tmax] (the tile's tmax of each ray, in double; the float t is
// checked by the caller, as the scalar function checks it last).
template <unsigned W>
struct FinishedLanes {
    alignas(64) double t[W];
    unsigned hit = 0, front = 0, on_edge = 0;
};

// finish_triangle_hit()'s barycentrics of lane i (v / det, w / det, det = u + v + w), formed for a lane that
// hits: the same operations, so the same floats.
template <unsigned W>
[[nodiscard]] inline glm::vec2 lane_barycentrics(const ShearedLanes<W>& s, unsigned i) {
    const double det = s.u[i] + s.v[i] + s.w[i];
    return glm::vec2(float(s.v[i] / det), float(s.w[i] / det));
}

template <unsigned W>
[[gnu::always_inline]] inline void finish_lanes(const RayTile& tile, unsigned first, unsigned keep,
                                                const ShearedLanes<W>& s, const glm::dvec3& n, double n_dot_p,
                                                FinishedLanes<W>& out) {
    out.hit = out.front = out.on_edge = 0;
    {
        constexpr unsigned D = W >= 2 ? W / 2 : 1;  // the scalar twin (W = 1): one lane at a time
        using Doubles = simd::Doubles<D>;
        const Doubles zero = Doubles::broadcast(0.0);
        const Doubles inf = Doubles::broadcast(std::numeric_limits<double>::infinity());
        auto nonzero = [&](Doubles x) { return bits((x < zero) | (x > zero)); };
        for (unsigned h = 0; h < W; h += D) {
            const unsigned lanes = (keep >> h) & ((1u << D) - 1u);
            if (lanes == 0) continue;
            const Doubles u = Doubles::load(s.u + h), v = Doubles::load(s.v + h), w = Doubles::load(s.w + h);
            const Doubles det = u + v + w;
            const unsigned exact = nonzero(u) & nonzero(v) & nonzero(w) & nonzero(det);
            const Doubles dx = Doubles::widen(tile.direction_x() + first + h);
            const Doubles dy = Doubles::widen(tile.direction_y() + first + h);
            const Doubles dz = Doubles::widen(tile.direction_z() + first + h);
            const Doubles n_dot_d =
                Doubles::broadcast(n.x) * dx + Doubles::broadcast(n.y) * dy + Doubles::broadcast(n.z) * dz;
            const Doubles t = Doubles::broadcast(n_dot_p) / n_dot_d;
            const Doubles tmin = Doubles::broadcast(double(tile.tmin()));
            const Doubles tmax = Doubles::widen(tile.tmax_data() + first + h);
            // t >= tmin && t <= tmax, false for NaN, from the ordered < and > the lanes have.
            const unsigned not_nan = bits((t > -inf) | (t < inf));
            const unsigned in_range = not_nan & ~bits(t < tmin) & ~bits(t > tmax);
            store(out.t + h, t);
            out.on_edge |= (lanes & ~exact) << h;
            out.hit |= (lanes & exact & nonzero(n_dot_d) & in_range) << h;
            out.front |= bits(det > zero) << h;
        }
    }
}

// A triangle's vertices for triangle_tile_hits(): three vectors, or one lane of a TriangleBlock
// (ray_triangle_block.hpp), read straight from its rows.
struct TriangleVertices {
    const glm::vec3 &v0, &v1, &v2;
    [[nodiscard]] glm::vec3 vertex(int j) const { return j == 0 ? v0 : j == 1 ? v1 : v2; }
    [[nodiscard]] RelativeTriangle relative_to(const TileTriangleRays& rays, const glm::vec3& origin) const {
        return relative(rays, origin, v0, v1, v2);
    }
};
struct BlockLaneVertices {
    const TriangleBlock& block;
    unsigned lane;
    [[nodiscard]] glm::vec3 vertex(int j) const { return block.vertex(lane, j); }
    [[nodiscard]] RelativeTriangle relative_to(const TileTriangleRays& rays, const glm::vec3& origin) const {
        const int axis[3] = {rays.kx, rays.ky, rays.kz};
        RelativeTriangle t;
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k) t.rel[3 * j + k] = block.planes[3 * j + axis[k]][lane] - origin[axis[k]];
        return t;
    }
};

// The whole test of one triangle against tile rays: for each row r of `rows` and each block of W lanes of
// it, the lanes lanes_of(r, block) (a mask of W bits; asked just before the block is tested, so it may drop
// rays whose search ended meanwhile) are sheared and finished together; on_hit(lane, hit) is called for each
// ray that meets the triangle in [tmin, tmax] of that moment (its tmax read from the tile), in lane order
// within a block, with finish_triangle_hit()'s t, barycentrics and facing, bit for bit. The rays must share
// their axes (rays.shared_axes).
template <unsigned W, class Vertices, class LanesOf, class OnHit>
[[gnu::always_inline]] inline void triangle_tile_hits(const RayTile& tile, const TileTriangleRays& rays,
                                                      TileLineSet rows, const Vertices& vertices, LanesOf&& lanes_of,
                                                      OnHit&& on_hit) {
    const glm::vec3& eye = tile.origin();
    const RelativeTriangle rel = vertices.relative_to(rays, eye);
    // The plane (the normal and finish_triangle_hit()'s n·(v0 − origin), the same for every ray of the tile),
    // formed when a first ray gets past the straddle test: most triangles a tile tests are hit by none.
    glm::vec3 v0;
    glm::dvec3 normal;
    double n_dot_p = 0.0;
    bool plane_ready = false;
    const float* tmax = tile.tmax_data();
    for (TileLineSet rs = rows; rs != 0; rs &= rs - 1) {
        const unsigned r = unsigned(std::countr_zero(rs));
        for (unsigned blk = 0; blk < kTileColumns / W; ++blk) {
            const unsigned lanes = lanes_of(r, blk);
            if (lanes == 0) continue;
            const unsigned first = RayTile::lane(blk * W, r);
            ShearedLanes<W> sheared;
            const unsigned keep = shear_lanes<W>(rays, first, lanes, rel, sheared);
            if (keep == 0) continue;
            if (!plane_ready) {
                v0 = vertices.vertex(0);
                normal = triangle_normal(v0, vertices.vertex(1), vertices.vertex(2));
                const glm::dvec3 p = glm::dvec3(v0) - glm::dvec3(eye);
                n_dot_p = normal.x * p.x + normal.y * p.y + normal.z * p.z;
                plane_ready = true;
            }
            FinishedLanes<W> done;
            finish_lanes<W>(tile, first, keep, sheared, normal, n_dot_p, done);
            for (unsigned m = done.hit; m != 0; m &= m - 1) {
                const unsigned i = unsigned(std::countr_zero(m));
                const unsigned lane = first + i;
                TriangleHit th;
                th.t = static_cast<float>(done.t[i]);
                // Rounding to float must stay in range, as in finish_triangle_hit().
                if (!(th.t >= tile.tmin() && th.t <= tmax[lane])) continue;
                th.barycentrics = lane_barycentrics(sheared, i);
                th.front_face = (done.front >> i) & 1u;
                on_hit(lane, th);
            }
            for (unsigned m = done.on_edge; m != 0; m &= m - 1) {
                const unsigned i = unsigned(std::countr_zero(m));
                const unsigned lane = first + i;
                TriangleHit th;
                if (finish_triangle_hit(rays.ray(lane), sheared.lane(i), v0, normal, tmax[lane], th)) on_hit(lane, th);
            }
        }
    }
}

}  // namespace smoketrace
