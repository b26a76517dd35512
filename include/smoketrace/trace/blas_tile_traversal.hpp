#pragma once
// Closest hit of a tile of camera rays (geometry/ray_tile.hpp) against a mesh BLAS: the rays traced together,
// as Embree traces a packet. Rays from one eye through neighbouring pixels meet the same nodes and the same
// triangles, so the tile walks the wide tree once (accel/tile_traversal.hpp: a node is entered unless the
// tile's frustum excludes its box or the box lies beyond every ray's tmax, nearest box first), and each
// triangle of a leaf it reaches is tested against the rays under the leaf box's shadow on the image plane,
// a row of lanes at a time (geometry/ray_triangle_tile.hpp: shear and finish in lanes, bit for bit the scalar
// watertight test).
//
// Contract: for every ray of the grid, the hit is what closest_hit(blas, tile.ray(lane)) finds: the same t,
// barycentrics and facing bit for bit, and the same triangle unless two triangles are hit at the same t
// (then either may be reported, as either walk order may meet them first). A tile whose rays do not share
// their dominant axes (the few on which the camera's dominant axis changes) is traced ray by ray.
#include <smoketrace/accel/tile_traversal.hpp>
#include <smoketrace/core/simd/lanes.hpp>
#include <smoketrace/geometry/ray_tile.hpp>
#include <smoketrace/geometry/ray_triangle_tile.hpp>
#include <smoketrace/trace/blas_traversal.hpp>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>

namespace smoketrace {

// Per ray of a tile: its closest hit, when found (bit c of found[r] for lane (c, r)).
struct BlasTileHits {
    BlasHit hit[kTileRays];
    TileLineSet found[kTileRows] = {};

    [[nodiscard]] bool found_at(unsigned lane) const {
        return (found[lane / kTileColumns] >> (lane % kTileColumns)) & 1u;
    }
};

// Traces every ray of the tile (unit directions, as a camera's; its intervals [tmin, tmax(lane)]) to its
// closest hit, lowering the tile's tmax to each hit. `stats` counts the tile's walk: nodes and leaves visited
// and child boxes tested once for the whole tile, and for each ray the triangles of every leaf whose box it
// enters (as the single-ray walk counts them).
inline void closest_hit(const MeshBlas& blas, RayTile& tile, BlasTileHits& hits, TraversalStats& stats) {
    using Floats = simd::Floats<simd::kFloatLanes>;
    constexpr unsigned W = simd::kFloatLanes;
    static_assert(kTileColumns % W == 0);
    constexpr unsigned kBlockBits = W == 32 ? ~0u : (1u << W) - 1u;
    for (TileLineSet& f : hits.found) f = 0;

    const TileTriangleRays rays(tile);
    if (!rays.shared_axes) {
        for (unsigned r = 0; r < tile.rows(); ++r)
            for (unsigned c = 0; c < tile.columns(); ++c) {
                const unsigned lane = RayTile::lane(c, r);
                BlasCounters counters;
                if (closest_hit(blas, tile.ray(lane), hits.hit[lane], counters)) {
                    hits.found[r] |= 1u << c;
                    tile.set_tmax(lane, hits.hit[lane].t);
                }
                stats.nodes_visited += counters.traversal.nodes_visited;
                stats.boxes_tested += counters.traversal.boxes_tested;
                stats.primitives_tested += counters.traversal.primitives_tested;
            }
        return;
    }

    // The farthest any ray of the grid reaches (lanes outside the grid repeat its first ray).
    auto farthest = [&] {
        Floats m = Floats::broadcast(0.0f);
        for (unsigned r = 0; r < tile.rows(); ++r)
            for (unsigned b = 0; b < kTileColumns / W; ++b)
                m = simd::max(m, Floats::load(tile.tmax_data() + RayTile::lane(b * W, r)));
        alignas(64) float lanes[W];
        store(lanes, m);
        return *std::max_element(lanes, lanes + W);
    };
    float reach = farthest();
    const TriangleBlock* blocks = blas.blocks();

    // Each ray's slab-test set-up (BoxRay's reciprocals), so that a leaf is tested only for the rays that
    // enter its box: the shadow on the image plane is a rectangle around the box's outline.
    alignas(64) float inv[3][kTileRays], inv_far[3][kTileRays];
    unsigned unbounded[kTileRows][kTileColumns / W] = {};  // rays with a non-finite reciprocal: never culled
    {
        const float* d[3] = {tile.direction_x(), tile.direction_y(), tile.direction_z()};
        const Floats one = Floats::broadcast(1.0f), scale = Floats::broadcast(kSlabFarScale);
        const Floats big = Floats::broadcast(std::numeric_limits<float>::max());
        for (unsigned r = 0; r < kTileRows; ++r)
            for (unsigned blk = 0; blk < kTileColumns / W; ++blk) {
                const unsigned first = RayTile::lane(blk * W, r);
                for (int a = 0; a < 3; ++a) {
                    const Floats q = one / Floats::load(d[a] + first);
                    store(inv[a] + first, q);
                    store(inv_far[a] + first, q * scale);
                    unbounded[r][blk] |= ~bits(abs(q) <= big) & kBlockBits;
                }
            }
    }
    const Floats tmin = Floats::broadcast(tile.tmin());

    auto leaf = [&](std::uint32_t first_block, std::uint32_t count, const Aabb& box) {
        TileLineSet columns, rows;
        if (!tile.shadow_lanes(box, columns, rows)) return false;
        const float* lo = &box.lo.x;
        const float* hi = &box.hi.x;
        // The rays under the shadow that enter the box before their tmax: the scalar slab test's numbers
        // (intersect(), aabb.hpp), the near and far planes picked by min and max, which is the sign's pick
        // for a finite reciprocal.
        auto enter = [&](unsigned r, unsigned blk) {
            const unsigned under = (columns >> (blk * W)) & kBlockBits;
            if (under == 0) return 0u;
            const unsigned first = RayTile::lane(blk * W, r);
            Floats t0 = tmin, t1 = Floats::load(tile.tmax_data() + first) * Floats::broadcast(kSlabFarScale);
            for (int a = 0; a < 3; ++a) {
                const Floats o = Floats::broadcast((&tile.origin().x)[a]);
                const Floats dl = Floats::broadcast(lo[a]) - o, dh = Floats::broadcast(hi[a]) - o;
                const Floats q = Floats::load(inv[a] + first), qf = Floats::load(inv_far[a] + first);
                t0 = simd::max(simd::min(dl * q, dh * q), t0);
                t1 = simd::min(simd::max(dl * qf, dh * qf), t1);
            }
            return under & (bits(t0 <= t1) | unbounded[r][blk]);
        };
        // Decided once per leaf: a hit on one of its triangles lowers a ray's tmax, which the triangle test
        // itself then applies.
        unsigned entering[kTileRows][kTileColumns / W];
        TileLineSet active = 0;  // the rows with a ray entering
        for (TileLineSet rs = rows; rs != 0; rs &= rs - 1) {
            const unsigned r = unsigned(std::countr_zero(rs));
            unsigned any_lane = 0;
            for (unsigned blk = 0; blk < kTileColumns / W; ++blk) {
                entering[r][blk] = enter(r, blk);
                any_lane |= entering[r][blk];
                stats.primitives_tested += count * unsigned(std::popcount(entering[r][blk]));
            }
            if (any_lane != 0) active |= TileLineSet(1) << r;
        }
        if (active == 0) return false;
        bool any = false;
        auto lanes_of = [&](unsigned r, unsigned blk) { return entering[r][blk]; };
        for (std::uint32_t k = 0; k < count; ++k) {
            const TriangleBlock& b = blocks[first_block + k / kTriangleBlockLanes];
            const unsigned i = k % kTriangleBlockLanes;
            triangle_tile_hits<W>(tile, rays, active, BlockLaneVertices{b, i}, lanes_of,
                                  [&](unsigned lane, const TriangleHit& th) {
                                      hits.hit[lane] = BlasHit{th.t, th.barycentrics, b.primitive[i], th.front_face};
                                      hits.found[lane / kTileColumns] |= 1u << (lane % kTileColumns);
                                      tile.set_tmax(lane, th.t);
                                      any = true;
                                  });
        }
        if (any) reach = farthest();
        return false;
    };
    traverse_blas_wide_tile(blas.wide(), tile, reach, leaf, stats);
}

}  // namespace smoketrace
