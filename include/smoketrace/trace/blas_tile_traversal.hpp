#pragma once
// Contract: closest_hit()'s hits (below), and so textbook::trace's for one instance of the BLAS under the identity.
// Closest hit of a tile of camera rays (geometry/ray_tile.hpp) against a mesh BLAS: the rays traced together,
// as Embree traces a packet. Rays from one eye through neighbouring pixels meet the same nodes and the same
// triangles, so the tile walks the wide tree once (accel/tile_traversal.hpp: a node is entered unless the
// tile's frustum excludes its box or the box lies beyond every ray's tmax, nearest box first). A leaf it
// reaches is tested for the rays under its box's shadow on the image plane that enter the box, packed side
// by side so that they fill the lanes (geometry/ray_triangle_tile.hpp: a sieve, then shear and finish in
// lanes, bit for bit the scalar watertight test); rays of different dominant axes (on the few tiles where
// the camera's dominant axis changes) in separate packs.
//
// Contract: for every ray of the grid, the hit is what closest_hit(blas, tile.ray(lane)) finds: the same t,
// barycentrics and facing bit for bit, and the same triangle unless two triangles are hit at the same t
// (then either may be reported, as either walk order may meet them first).
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
    PackedTileRays<W> packed;  // a leaf's rays (reused: no zero-fill per leaf)

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
        // itself then applies. The rays that enter are packed side by side, so that each triangle is tested
        // on full blocks of lanes; rays of different axes (axis groups, TileTriangleRays) apart.
        bool any = false;
        for (unsigned axis_groups = rays.groups; axis_groups != 0; axis_groups &= axis_groups - 1) {
            const unsigned group = unsigned(std::countr_zero(axis_groups));
            packed.count = 0;
            for (TileLineSet rs = rows; rs != 0; rs &= rs - 1) {
                const unsigned r = unsigned(std::countr_zero(rs));
                for (unsigned blk = 0; blk < kTileColumns / W; ++blk) {
                    const unsigned entering = enter(r, blk) & (rays.group_columns[group][r] >> (blk * W));
                    if (entering == 0) continue;
                    stats.primitives_tested += count * unsigned(std::popcount(entering));
                    packed.add(tile, rays, RayTile::lane(blk * W, r), entering);
                }
            }
            if (packed.count == 0) continue;
            packed.close();
            // Each block of triangles is sifted first (shear_sieve(): a pass without branches over its
            // triangles and the packed blocks of rays), then the few (triangle, rays) that pass are tested in
            // full, in the same order as without the sieve.
            const unsigned ray_blocks = (packed.count + W - 1) / W;
            unsigned block_lanes[kTileRays / W];
            for (unsigned g = 0; g < ray_blocks; ++g)
                block_lanes[g] = packed.count - g * W >= W ? kBlockBits : (1u << (packed.count - g * W)) - 1u;
            for (std::uint32_t k0 = 0; k0 < count; k0 += kTriangleBlockLanes) {
                const TriangleBlock& b = blocks[first_block + k0 / kTriangleBlockLanes];
                const RelativeBlock relative(axes_of_group(group), tile.origin(), b);
                const unsigned lanes = std::min(count - k0, kTriangleBlockLanes);
                unsigned sieved[kTriangleBlockLanes][kTileRays / W];
                unsigned passing = 0;  // the triangles with a block of rays that passed
                for (unsigned i = 0; i < lanes; ++i) {
                    const RelativeTriangle t = relative.lane(i);
                    unsigned any_lane = 0;
                    for (unsigned g = 0; g < ray_blocks; ++g) {
                        sieved[i][g] = shear_sieve<W>(packed.sx + g * W, packed.sy + g * W, block_lanes[g], t);
                        any_lane |= sieved[i][g];
                    }
                    passing |= unsigned(any_lane != 0) << i;
                }
                for (unsigned m = passing; m != 0; m &= m - 1) {
                    const unsigned i = unsigned(std::countr_zero(m));
                    closest_packed_hits<W>(tile, rays, packed, BlockLaneVertices{b, relative, i}, b.primitive[i],
                                           sieved[i]);
                }
            }
            // The leaf's hits into the tile.
            for (unsigned g = 0; g < ray_blocks; ++g)
                for (unsigned m = packed.hit_found[g]; m != 0; m &= m - 1) {
                    const unsigned j = g * W + unsigned(std::countr_zero(m));
                    const unsigned lane = packed.lane[j];
                    hits.hit[lane] = BlasHit{packed.tmax[j], packed.hit_barycentrics(j),
                                             std::uint32_t(packed.hit_primitive[j]), packed.hit_front_face(j)};
                    hits.found[lane / kTileColumns] |= 1u << (lane % kTileColumns);
                    tile.set_tmax(lane, packed.tmax[j]);
                    any = true;
                }
        }
        if (any) reach = farthest();
        return false;
    };
    traverse_blas_wide_tile(blas.wide(), tile, reach, leaf, stats, MeshLeafPrefetch{blas});
}

}  // namespace smoketrace
