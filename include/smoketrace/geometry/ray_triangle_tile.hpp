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
// those rays go on to finish_lanes(), in lanes of doubles.
//
// The rays a mesh leaf is tested for are a few of a few rows of the tile: packed side by side
// (PackedTileRays, one axis group at a time), they fill the lanes. closest_packed_hits() tests a triangle
// on them, after shear_sieve(), a store-free pass of the float test alone, has sifted out the blocks of rays
// the triangle certainly misses.
//
// Same answers, bit for bit: every lane performs the scalar shear_triangle()'s operations in the same order
// and precision, so a tile's ray meets exactly the triangles, edges and vertices its lone ray meets, and
// finish_triangle_hit() gives the same t and barycentrics (tests/test_trace_tile.cpp).
#include <smoketrace/core/simd/lanes.hpp>
#include <smoketrace/geometry/ray_tile.hpp>
#include <smoketrace/geometry/ray_triangle_block.hpp>
#include <smoketrace/geometry/ray_triangle.hpp>

#include <array>
#include <bit>
#include <cstdint>
#include <limits>

namespace smoketrace {

// The rays of a tile fall into groups by the axes TriangleRay picks for them: group g has kz = g / 2 and, when
// g is odd (the direction negative along kz), kx and ky swapped. All rays of a tile share one group except on
// the few tiles where the camera rays' dominant axis changes.
inline constexpr unsigned kAxisGroups = 6;
struct RayAxes {
    int kx, ky, kz;
};
[[nodiscard]] constexpr RayAxes axes_of_group(unsigned g) {
    const int kz = int(g / 2), kx = (kz + 1) % 3, ky = (kx + 1) % 3;
    return g % 2 ? RayAxes{ky, kx, kz} : RayAxes{kx, ky, kz};
}

// The per-ray part of the watertight test for a tile's rays: TriangleRay's shear per lane, with each ray's
// own axes, and the axis groups of the rays. Where every ray of the tile has the same dominant axes
// (shared_axes), shear_lanes() applies to any block of lanes; else only to rays of one group, packed
// (PackedTileRays).
class TileTriangleRays {
public:
    int kx = 0, ky = 1, kz = 2;  // lane 0's axes
    bool shared_axes = true;
    unsigned groups = 0;  // the axis groups present: bit g for group g
    // The rays of group g: bit c of group_columns[g][r] for lane (c, r), for the groups present.
    TileLineSet group_columns[kAxisGroups][kTileRows];
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
        // lane 0's; if one ray's differ, every lane is set up by TriangleRay itself.
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
                break;
            }
            const Floats s = one / dkz;
            store(sz + lane, s);
            store(sx + lane, Floats::load(d[kx] + lane) * s);
            store(sy + lane, Floats::load(d[ky] + lane) * s);
        }
        if (shared_axes) {
            const unsigned g = group_of(first);
            groups = 1u << g;
            for (TileLineSet& c : group_columns[g]) c = kTileColumns == 32 ? ~0u : (1u << kTileColumns) - 1u;
            return;
        }
        for (auto& g : group_columns)
            for (TileLineSet& c : g) c = 0;
        for (unsigned lane = 0; lane < kTileRays; ++lane) {
            const TriangleRay r(tile.ray(lane));
            const unsigned g = group_of(r);
            groups |= 1u << g;
            group_columns[g][lane / kTileColumns] |= TileLineSet(1) << (lane % kTileColumns);
            sx[lane] = r.sx;
            sy[lane] = r.sy;
            sz[lane] = r.sz;
        }
    }

    // Lane `lane`'s TriangleRay, field for field TriangleRay(tile.ray(lane)), without its division.
    [[nodiscard]] TriangleRay ray(unsigned lane) const {
        TriangleRay r;
        r.origin = origin_;
        r.direction = tile_.direction(lane);
        RayAxes a{kx, ky, kz};
        if (!shared_axes)  // (then group_columns is set for every group)
            for (unsigned g = 0; g < kAxisGroups; ++g)
                if ((group_columns[g][lane / kTileColumns] >> (lane % kTileColumns)) & 1u) a = axes_of_group(g);
        r.kx = a.kx;
        r.ky = a.ky;
        r.kz = a.kz;
        r.sx = sx[lane];
        r.sy = sy[lane];
        r.sz = sz[lane];
        r.tmin = tmin_;
        return r;
    }

private:
    static unsigned group_of(const TriangleRay& r) { return unsigned(2 * r.kz) + unsigned(r.kx != (r.kz + 1) % 3); }

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

// shear_lanes()' float part: the sheared vertices, and which lanes' float edge functions decide the straddle
// test (`certain`) and say it straddles (`straddling`).
template <unsigned W>
struct FloatShear {
    simd::Floats<W> ax, ay, bx, by, cx, cy;
    unsigned certain, straddling;
};
template <unsigned W>
[[gnu::always_inline]] inline FloatShear<W> float_shear(const float* sx_lanes, const float* sy_lanes,
                                                        const RelativeTriangle& t) {
    using Floats = simd::Floats<W>;
    const Floats sx = Floats::load(sx_lanes), sy = Floats::load(sy_lanes);
    const float* r = t.rel;
    FloatShear<W> f;
    // shear_triangle(): x − sx·z and y − sy·z of each vertex relative to the origin.
    f.ax = Floats::broadcast(r[0]) - sx * Floats::broadcast(r[2]);
    f.ay = Floats::broadcast(r[1]) - sy * Floats::broadcast(r[2]);
    f.bx = Floats::broadcast(r[3]) - sx * Floats::broadcast(r[5]);
    f.by = Floats::broadcast(r[4]) - sy * Floats::broadcast(r[5]);
    f.cx = Floats::broadcast(r[6]) - sx * Floats::broadcast(r[8]);
    f.cy = Floats::broadcast(r[7]) - sy * Floats::broadcast(r[8]);
    // Float edge functions: a nonzero one has the exact sign (shear_block()'s float_edge), a zero or NaN
    // one is decided in double (shear_lanes()).
    const Floats u = f.cx * f.by - f.cy * f.bx;
    const Floats v = f.ax * f.cy - f.ay * f.cx;
    const Floats w = f.bx * f.ay - f.by * f.ax;
    const Floats zero = Floats::broadcast(0.0f);
    f.certain = bits(differs(u, zero) & differs(v, zero) & differs(w, zero));
    f.straddling = bits(((u < zero) | (v < zero) | (w < zero)) & ((u > zero) | (v > zero) | (w > zero)));
    return f;
}

// shear_lanes() from the rays' shear factors themselves: lane i's are sx_lanes[i], sy_lanes[i]
// (TileTriangleRays' sx, sy of its ray; W floats aligned to their size), wherever in the tile the rays lie
// (PackedTileRays).
template <unsigned W>
[[gnu::always_inline]] inline unsigned shear_lanes(const float* sx_lanes, const float* sy_lanes, unsigned lanes,
                                                   const RelativeTriangle& t, ShearedLanes<W>& out) {
    const FloatShear<W> f = float_shear<W>(sx_lanes, sy_lanes, t);
    const auto &ax = f.ax, &ay = f.ay, &bx = f.bx, &by = f.by, &cx = f.cx, &cy = f.cy;
    const unsigned certain = f.certain, straddling = f.straddling;
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
template <unsigned W>
[[gnu::always_inline]] inline unsigned shear_lanes(const TileTriangleRays& rays, unsigned first, unsigned lanes,
                                                   const RelativeTriangle& t, ShearedLanes<W>& out) {
    return shear_lanes<W>(rays.sx + first, rays.sy + first, lanes, t, out);
}

// The lanes (among `lanes`) that shear_lanes() may keep: all but those whose float edge functions say for
// certain that the triangle straddles them. No stores and no branches: a leaf's triangles are sifted with
// it in one pass, and only the blocks that pass are sheared in full (most do not).
template <unsigned W>
[[gnu::always_inline]] inline unsigned shear_sieve(const float* sx_lanes, const float* sy_lanes, unsigned lanes,
                                                   const RelativeTriangle& t) {
    const FloatShear<W> f = float_shear<W>(sx_lanes, sy_lanes, t);
    return ~(f.certain & f.straddling) & lanes;
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

// Half a block of lanes as finish_lanes() finished it (lanes h …, in lanes of doubles): its t and edge
// functions (out.t's, the ShearedLanes' u, v, w) and its bits of out.hit (bit i: lane h + i).
template <class Doubles>
struct FinishedHalf {
    unsigned h;
    Doubles t, u, v, w;
    unsigned hit;
};
// finish_lanes()' default for `on_half`: nothing.
struct IgnoreHalves {
    template <class Half>
    void operator()(const Half&) const {}
};

// finish_lanes() from the rays' directions and tmax themselves: lane i's are dx[i], dy[i], dz[i], tmax[i] (W
// floats each, aligned to half their size), wherever in the tile the rays lie (PackedTileRays).
// on_half(const FinishedHalf&) is called for each half block of lanes finished: a caller may take the hits
// from the registers.
template <unsigned W, class OnHalf = IgnoreHalves>
[[gnu::always_inline]] inline void finish_lanes(const float* dx_lanes, const float* dy_lanes, const float* dz_lanes,
                                                const float* tmax_lanes, float tmin, unsigned keep,
                                                const ShearedLanes<W>& s, const glm::dvec3& n, double n_dot_p,
                                                FinishedLanes<W>& out, OnHalf&& on_half = {}) {
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
            const Doubles dx = Doubles::widen(dx_lanes + h);
            const Doubles dy = Doubles::widen(dy_lanes + h);
            const Doubles dz = Doubles::widen(dz_lanes + h);
            const Doubles n_dot_d =
                Doubles::broadcast(n.x) * dx + Doubles::broadcast(n.y) * dy + Doubles::broadcast(n.z) * dz;
            const Doubles t = Doubles::broadcast(n_dot_p) / n_dot_d;
            const Doubles tmin_d = Doubles::broadcast(double(tmin));
            const Doubles tmax = Doubles::widen(tmax_lanes + h);
            // t >= tmin && t <= tmax, false for NaN, from the ordered < and > the lanes have.
            const unsigned not_nan = bits((t > -inf) | (t < inf));
            const unsigned in_range = not_nan & ~bits(t < tmin_d) & ~bits(t > tmax);
            store(out.t + h, t);
            const unsigned hit = lanes & exact & nonzero(n_dot_d) & in_range;
            out.on_edge |= (lanes & ~exact) << h;
            out.hit |= hit << h;
            out.front |= bits(det > zero) << h;
            on_half(FinishedHalf<Doubles>{h, t, u, v, w, hit});
        }
    }
}
template <unsigned W>
[[gnu::always_inline]] inline void finish_lanes(const RayTile& tile, unsigned first, unsigned keep,
                                                const ShearedLanes<W>& s, const glm::dvec3& n, double n_dot_p,
                                                FinishedLanes<W>& out) {
    finish_lanes<W>(tile.direction_x() + first, tile.direction_y() + first, tile.direction_z() + first,
                    tile.tmax_data() + first, tile.tmin(), keep, s, n, n_dot_p, out);
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
// A TriangleBlock's triangles as relative() makes each of them, for the whole block at once: rel[3·j + k][i]
// is lane i's vertex j minus the origin on the rays' axis k (kx, ky, kz), the same float subtraction.
struct RelativeBlock {
    alignas(32) float rel[9][kTriangleBlockLanes];

    RelativeBlock(const RayAxes& axes, const glm::vec3& origin, const TriangleBlock& block) {
        using Floats = simd::Floats<kTriangleBlockLanes>;
        const int axis[3] = {axes.kx, axes.ky, axes.kz};
        for (int k = 0; k < 3; ++k) {
            const Floats o = Floats::broadcast((&origin.x)[axis[k]]);
            for (int j = 0; j < 3; ++j) store(rel[3 * j + k], Floats::load(block.planes[3 * j + axis[k]]) - o);
        }
    }
    [[nodiscard]] RelativeTriangle lane(unsigned i) const {
        RelativeTriangle t;
        for (int q = 0; q < 9; ++q) t.rel[q] = rel[q][i];
        return t;
    }
};
struct BlockLaneVertices {
    const TriangleBlock& block;
    const RelativeBlock& relative;  // the block's, relative to the tile's origin
    unsigned lane;
    [[nodiscard]] glm::vec3 vertex(int j) const { return block.vertex(lane, j); }
    [[nodiscard]] RelativeTriangle relative_to(const TileTriangleRays&, const glm::vec3&) const {
        return relative.lane(lane);
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

// Some rays of a tile packed side by side: packed ray j is the tile's ray lane[j], with its shear factors
// (TileTriangleRays' sx, sy), its direction and its tmax copied. A leaf's box covers a few rays of a few rows
// of a tile; a triangle tested row by row would leave most lanes of each block idle, tested on the packed
// rays it fills them (closest_packed_hits()). The rays of one pack share their axes (one axis group of
// TileTriangleRays). Blocks of W packed rays start at multiples of W; the lanes from count to the end of the
// last block hold zeros (never reported: masked off).
//
// Each packed ray also keeps the closest hit that closest_packed_hits() has found for it since close(): its
// t is tmax[j], and hit_found (bit j % W of block j / W) says whether there is one.
template <unsigned W>
struct PackedTileRays {
    static constexpr unsigned kCapacity = kTileRays + W;  // store_compressed() writes whole blocks
    static constexpr unsigned kBlocks = kCapacity / W;
    alignas(64) float sx[kCapacity];
    alignas(64) float sy[kCapacity];
    alignas(64) float dx[kCapacity];
    alignas(64) float dy[kCapacity];
    alignas(64) float dz[kCapacity];
    alignas(64) float tmax[kCapacity];
    alignas(64) std::uint32_t lane[kCapacity];
    unsigned count = 0;
    // The closest hit: its edge functions (finish_triangle_hit()'s barycentrics come from them), its triangle
    // (the primitive index, exact in a double, so that one blend of double lanes updates all four), its facing.
    alignas(64) double hit_u[kCapacity];
    alignas(64) double hit_v[kCapacity];
    alignas(64) double hit_w[kCapacity];
    alignas(64) double hit_primitive[kCapacity];
    unsigned hit_found[kBlocks];
    unsigned hit_front[kBlocks];

    // Each lane's index, for add() to pack.
    alignas(64) static constexpr std::array<std::uint32_t, kTileRays> kLaneIds = [] {
        std::array<std::uint32_t, kTileRays> a{};
        for (unsigned i = 0; i < kTileRays; ++i) a[i] = i;
        return a;
    }();

    // Appends the tile's rays first + i for the bits i of `lanes` (a block of W lanes of one row), in lane order.
    [[gnu::always_inline]] void add(const RayTile& tile, const TileTriangleRays& rays, unsigned first,
                                    unsigned lanes) {
        using Floats = simd::Floats<W>;
        using UInts = simd::UInts<W>;
        store_compressed(sx + count, Floats::load(rays.sx + first), lanes);
        store_compressed(sy + count, Floats::load(rays.sy + first), lanes);
        store_compressed(dx + count, Floats::load(tile.direction_x() + first), lanes);
        store_compressed(dy + count, Floats::load(tile.direction_y() + first), lanes);
        store_compressed(dz + count, Floats::load(tile.direction_z() + first), lanes);
        store_compressed(tmax + count, Floats::load(tile.tmax_data() + first), lanes);
        store_compressed(lane + count, UInts::load(kLaneIds.data() + first), lanes);
        count += unsigned(std::popcount(lanes));
    }
    // After the last add(): zeros in the last block's lanes past count (masked off, but computed on: zeros keep
    // that arithmetic plain), and no hits yet.
    void close() {
        const unsigned end = (count + W - 1) / W * W;
        for (unsigned j = count; j < end; ++j) {
            sx[j] = sy[j] = dx[j] = dy[j] = dz[j] = tmax[j] = 0.0f;
            lane[j] = 0;
        }
        for (unsigned g = 0; g < end / W; ++g) hit_found[g] = hit_front[g] = 0;
    }

    // The closest hit's barycentrics, finish_triangle_hit()'s bit for bit: the same operations on the same numbers.
    [[nodiscard]] glm::vec2 hit_barycentrics(unsigned j) const {
        const double det = hit_u[j] + hit_v[j] + hit_w[j];
        return glm::vec2(float(hit_v[j] / det), float(hit_w[j] / det));
    }
    [[nodiscard]] bool hit_front_face(unsigned j) const { return (hit_front[j / W] >> (j % W)) & 1u; }
};

// triangle_tile_hits() for packed rays, in a closest-hit search: the lanes lanes_of[g] of each block g of W
// packed rays (all its rays, or shear_sieve()'s) are sheared and finished together, and each packed ray j
// that meets the triangle in [tmin, packed.tmax[j]] of that moment takes it as its closest hit (packed.tmax[j]
// lowered to its t; its primitive `primitive`), with finish_triangle_hit()'s t, facing and barycentrics, bit
// for bit. The hits of a block are taken in lanes of doubles, with no branch per hit.
template <unsigned W, class Vertices>
[[gnu::always_inline]] inline void closest_packed_hits(const RayTile& tile, const TileTriangleRays& rays,
                                                       PackedTileRays<W>& packed, const Vertices& vertices,
                                                       std::uint32_t primitive, const unsigned* lanes_of) {
    constexpr unsigned D = W >= 2 ? W / 2 : 1;  // the scalar twin (W = 1): one lane at a time
    using Doubles = simd::Doubles<D>;
    using DoubleMask = simd::Mask<double, D>;
    const glm::vec3& eye = tile.origin();
    const RelativeTriangle rel = vertices.relative_to(rays, eye);
    glm::vec3 v0;
    glm::dvec3 normal;
    double n_dot_p = 0.0;
    bool plane_ready = false;  // formed for the first ray past the straddle test, as in triangle_tile_hits()
    const Doubles tmin = Doubles::broadcast(double(tile.tmin()));
    for (unsigned first = 0; first < packed.count; first += W) {
        const unsigned lanes = lanes_of[first / W];
        if (lanes == 0) continue;
        ShearedLanes<W> sheared;
        // (GCC 12 does not see that the scalar twin reads only the edge functions shear_lanes() wrote, and
        // warns: zeros first there, at no cost that matters.)
        if constexpr (W == 1) sheared = ShearedLanes<W>{};
        const unsigned keep = shear_lanes<W>(packed.sx + first, packed.sy + first, lanes, rel, sheared);
        if (keep == 0) continue;
        if (!plane_ready) {
            v0 = vertices.vertex(0);
            normal = triangle_normal(v0, vertices.vertex(1), vertices.vertex(2));
            const glm::dvec3 p = glm::dvec3(v0) - glm::dvec3(eye);
            n_dot_p = normal.x * p.x + normal.y * p.y + normal.z * p.z;
            plane_ready = true;
        }
        FinishedLanes<W> done;
        unsigned taken = 0;
        auto take_hits = [&](const FinishedHalf<Doubles>& half) {
            // The float t must stay in range, as finish_triangle_hit() checks it last: compared in double,
            // where the float widens exactly.
            alignas(64) float t_float[D];
            store(t_float, narrow(half.t));
            const Doubles t_rounded = Doubles::widen(t_float);
            const unsigned j = first + half.h;
            const Doubles tmax = Doubles::widen(packed.tmax + j);
            const unsigned take = half.hit & ~bits((t_rounded < tmin) | (t_rounded > tmax));
            const DoubleMask m = DoubleMask::from_bits(take);
            store(packed.tmax + j, narrow(select(m, t_rounded, tmax)));
            store(packed.hit_u + j, select(m, half.u, Doubles::load(packed.hit_u + j)));
            store(packed.hit_v + j, select(m, half.v, Doubles::load(packed.hit_v + j)));
            store(packed.hit_w + j, select(m, half.w, Doubles::load(packed.hit_w + j)));
            store(packed.hit_primitive + j,
                  select(m, Doubles::broadcast(double(primitive)), Doubles::load(packed.hit_primitive + j)));
            taken |= take << half.h;
        };
        finish_lanes<W>(packed.dx + first, packed.dy + first, packed.dz + first, packed.tmax + first, tile.tmin(),
                        keep, sheared, normal, n_dot_p, done, take_hits);
        // Through an edge or a vertex: finish_triangle_hit() itself (the tie-break).
        for (unsigned m = done.on_edge; m != 0; m &= m - 1) {
            const unsigned i = unsigned(std::countr_zero(m));
            const unsigned j = first + i;
            TriangleHit th;
            if (!finish_triangle_hit(rays.ray(packed.lane[j]), sheared.lane(i), v0, normal, packed.tmax[j], th))
                continue;
            packed.tmax[j] = th.t;
            packed.hit_u[j] = sheared.u[i];
            packed.hit_v[j] = sheared.v[i];
            packed.hit_w[j] = sheared.w[i];
            packed.hit_primitive[j] = double(primitive);
            done.front = (done.front & ~(1u << i)) | (unsigned(th.front_face) << i);
            taken |= 1u << i;
        }
        unsigned& front = packed.hit_front[first / W];
        front = (front & ~taken) | (done.front & taken);
        packed.hit_found[first / W] |= taken;
    }
}

}  // namespace smoketrace
