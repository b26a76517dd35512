#pragma once
// Contract: each ray's candidates (as a set, bit for bit) and commit are textbook::trace's, as trace()'s are
// (below); its counters are its own. tests/test_textbook_trace.cpp holds camera tiles there.
// trace_tile(): trace() (trace.hpp) for the rays of a tile, up to kTileRays camera rays from one eye through a
// grid of image-plane points (geometry/ray_tile.hpp), traced together. What each ray sees is exactly what
// trace() would show it:
//
//   results[i] == trace(scene, tile.ray(i), flags, inclusion_mask, any_hit_i, limits), where
//   any_hit_i(hit) = any_hit(i, hit),
//
// with every DXR rule of trace.hpp, the cutoff and SKIP_CLOSEST_HIT_SHADER applied to each ray on its own (a
// ray that ends its search drops out, the others go on). The candidates of one ray and their t are those
// trace() reports, bit for bit; only their order may differ (DXR gives none). Where two opaque hits of a ray
// lie at exactly the same t, which of them is committed depends on the order they are met, as between
// trace()'s two top-level walks. Counters: tlas_nodes and boxes_tested count the tile's one walk, shared by
// its rays; a world_triangles instance counts (as a BLAS node, an instance and its triangles) for every ray
// it was tested for, which is every ray under its shadow whose tmax reaches it, a few more than trace()'s
// box test admits; the rest count each ray's own work, as in trace().
//
// How: the top level is walked once for the tile (accel/tile_traversal.hpp), culling nodes against the tile's
// frustum, and the instances it reaches that rules 1-3 admit are gathered and sorted by their distance from
// the eye. Then each instance is tested for the rays under its shadow on the image plane only
// (RayTile::shadow_lanes()), skipping rays whose tmax already lies before it: near to far, a ray whose
// any-hit callback ends or shrinks it early (a pixel gone opaque) stops meeting what lies behind. A
// world_triangles instance (every billboard, the ground) is tested for a block of rays at once
// (geometry/ray_triangle_tile.hpp) and each ray's hits are handed to its RaySearch (ray_search.hpp), the code
// trace() runs, as is every other kind of instance, one ray at a time.
#include <smoketrace/accel/accel_scene.hpp>
#include <smoketrace/accel/tile_traversal.hpp>
#include <smoketrace/core/simd/lanes.hpp>
#include <smoketrace/geometry/ray_tile.hpp>
#include <smoketrace/geometry/ray_triangle_tile.hpp>
#include <smoketrace/trace/ray_search.hpp>
#include <smoketrace/accel/trace_types.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <memory>
#include <new>
#include <type_traits>
#include <vector>

namespace smoketrace {

// Each ray's result (trace()'s for it). A ray the tile's walk brought to no instance searched nothing and
// kept no state: its result is made when asked for, so that a tile of mostly empty sky writes little.
class TileResults {
public:
    [[nodiscard]] TraceResult operator[](unsigned lane) const {
        TraceResult r;
        if (searched(lane)) {
            r = results_[lane];
        } else {
            r.counters.tlas_nodes = tlas_.nodes_visited;
            r.counters.boxes_tested = tlas_.boxes_tested;
        }
        // The world_triangles instances the tile tested for this ray, counted as trace() counts a visit.
        r.counters.blas_nodes += world_instances_[lane];
        r.counters.instances_entered += world_instances_[lane];
        r.counters.primitives_tested += world_triangles_[lane];
        return r;
    }
    // Whether ray `lane` committed a hit, and its t (the ray's tmax when it did not).
    [[nodiscard]] bool hit(unsigned lane) const { return searched(lane) && results_[lane].hit; }
    [[nodiscard]] float t(unsigned lane) const { return results_[lane].committed.t; }

    // For trace_tile(): a new tile's walk, the world-triangles tests per ray, then each searched ray's result.
    void start(const TraversalStats& tlas) {
        tlas_ = tlas;
        for (TileLineSet& s : searched_) s = 0;
        for (std::uint32_t& n : world_instances_) n = 0;
        for (std::uint32_t& n : world_triangles_) n = 0;
    }
    // One world_triangles instance of `triangles` triangles tested for the lanes `lanes` from `first` on.
    template <unsigned W>
    [[gnu::always_inline]] void count_world_triangles(unsigned first, unsigned lanes, std::uint32_t triangles) {
        using UInts = simd::UInts<W>;
        const auto m = simd::Mask<std::uint32_t, W>::from_bits(lanes);
        store(world_instances_ + first,
              simd::masked_add(UInts::load(world_instances_ + first), m, UInts::broadcast(1u)));
        store(world_triangles_ + first,
              simd::masked_add(UInts::load(world_triangles_ + first), m, UInts::broadcast(triangles)));
    }
    void set(unsigned lane, const TraceResult& r) {
        results_[lane] = r;
        searched_[lane / kTileColumns] |= 1u << (lane % kTileColumns);
    }

private:
    [[nodiscard]] bool searched(unsigned lane) const {
        return searched_[lane / kTileColumns] >> (lane % kTileColumns) & 1u;
    }

    std::array<TraceResult, kTileRays> results_;
    TileLineSet searched_[kTileRows] = {};
    TraversalStats tlas_;
    alignas(64) std::uint32_t world_instances_[kTileRays] = {};
    alignas(64) std::uint32_t world_triangles_[kTileRays] = {};
};

// What trace_tile() keeps between calls, so that a tile allocates nothing once it has met its largest list:
// one per thread.
struct TileScratch {
    struct Candidate {
        std::uint32_t index;  // instance
        bool opaque;          // its final opacity (rule 2)
        float distance;       // distance_to_box() from the eye
    };
    std::vector<Candidate> candidates;
};

namespace detail {
// A RaySearch per ray, each made in place (they are neither copied nor moved) when its ray first reaches an
// instance: most rays of a tile over open sky never do. Trivially destroyed.
template <class AnyHit>
class TileSearches {
public:
    using Search = RaySearch<LaneAnyHit<AnyHit>>;
    static_assert(std::is_trivially_destructible_v<Search>);

    TileSearches(const AccelScene& scene, RayTile& tile, std::uint32_t flags, AnyHit& any_hit,
                 const TraceLimits& limits)
        : scene_(scene), tile_(tile), flags_(flags), any_hit_(any_hit), limits_(limits) {}
    TileSearches(const TileSearches&) = delete;
    TileSearches& operator=(const TileSearches&) = delete;

    [[gnu::always_inline]] Search& operator[](unsigned lane) {
        TileLineSet& made = made_[lane / kTileColumns];
        const TileLineSet bit = 1u << (lane % kTileColumns);
        if (!(made & bit)) {
            made |= bit;
            hits_[lane] = {&any_hit_, lane};
            new (&storage_[lane]) Search(scene_, tile_.ray(lane), flags_, hits_[lane], limits_, tile_.tmax_ref(lane));
        }
        return *std::launder(reinterpret_cast<Search*>(&storage_[lane]));
    }
    [[nodiscard]] TileLineSet made(unsigned row) const { return made_[row]; }

private:
    const AccelScene& scene_;
    RayTile& tile_;
    std::uint32_t flags_;
    AnyHit& any_hit_;
    const TraceLimits& limits_;
    TileLineSet made_[kTileRows] = {};
    std::array<LaneAnyHit<AnyHit>, kTileRays> hits_;
    struct alignas(Search) Slot {
        unsigned char bytes[sizeof(Search)];
    };
    std::array<Slot, kTileRays> storage_;
};
}  // namespace detail

// any_hit(unsigned lane, const TraceHit&) -> AnyHitDecision, for every candidate of every ray. The tile's
// rays must have unit directions (as a camera's do); their tmax is the tile's (RayTile::set_tmax()), and
// the search lowers it as trace() lowers a ray's.
template <class AnyHit>
void trace_tile(const AccelScene& scene, RayTile& tile, std::uint32_t flags, std::uint8_t inclusion_mask,
                AnyHit&& any_hit, TileResults& results, TileScratch& scratch, const TraceLimits& limits = {}) {
    using Callback = std::remove_reference_t<AnyHit>;
    using Floats = simd::Floats<simd::kFloatLanes>;
    constexpr unsigned W = simd::kFloatLanes;
    static_assert(kTileColumns % W == 0);
    constexpr unsigned kBlockBits = W == 32 ? ~0u : (1u << W) - 1u;

    detail::TileSearches<Callback> searches(scene, tile, flags, any_hit, limits);
    const TileTriangleRays triangle_rays(tile);
    const InstanceFilter filter(flags, inclusion_mask);

    // The rays still searching, a set of columns per row.
    TileLineSet alive[kTileRows] = {};
    // The farthest any ray reaches (lanes outside the grid repeat its first ray, so all lanes may count).
    Floats reach_lanes = Floats::broadcast(0.0f);
    for (unsigned r = 0; r < tile.rows(); ++r) {
        alive[r] = tile.all_columns();
        for (unsigned b = 0; b < kTileColumns / W; ++b)
            reach_lanes = simd::max(reach_lanes, Floats::load(tile.tmax_data() + RayTile::lane(b * W, r)));
    }
    alignas(64) float reach_of[W];
    store(reach_of, reach_lanes);
    const float reach = *std::max_element(reach_of, reach_of + W);

    // The instances the tile can see, near to far.
    std::vector<TileScratch::Candidate>& candidates = scratch.candidates;
    candidates.clear();
    TraversalStats tlas_stats;
    const Bvh& tlas = scene.tlas();
    const std::uint8_t* node_masks = scene.tlas_node_masks().data();
    traverse_bvh_tile(
        tlas, tile, reach,
        [&](std::uint32_t first, std::uint32_t count) {
            for (std::uint32_t k = first; k < first + count; ++k) {
                const std::uint32_t index = tlas.prim_indices[k];
                bool opaque;
                if (!filter.admits(scene.leaf_record(k), opaque)) continue;  // rules 1-3, once for the tile
                candidates.push_back({index, opaque, distance_to_box(tile.origin(), scene.instance_bounds(index))});
            }
        },
        tlas_stats, [&](std::uint32_t node) { return (node_masks[node] & inclusion_mask) != 0; });
    std::sort(candidates.begin(), candidates.end(),
              [](const TileScratch::Candidate& a, const TileScratch::Candidate& b) {
                  return a.distance < b.distance || (a.distance == b.distance && a.index < b.index);
              });

    results.start(tlas_stats);
    const float* tmax = tile.tmax_data();
    for (const TileScratch::Candidate& cand : candidates) {
        TileLineSet columns, rows;
        if (!tile.shadow_lanes(scene.instance_bounds(cand.index), columns, rows)) continue;
        const InstanceRecord& inst = scene.record(cand.index);
        const Floats distance = Floats::broadcast(cand.distance);
        // The rays of row r and block b under the shadow, still searching, whose tmax reaches the instance.
        auto block_lanes = [&](unsigned r, unsigned b) {
            const unsigned first = RayTile::lane(b * W, r);
            const unsigned in_shadow = ((columns & alive[r]) >> (b * W)) & kBlockBits;
            if (in_shadow == 0) return 0u;
            return in_shadow & bits(Floats::load(tmax + first) >= distance);
        };
        // A ray whose search has ended.
        auto end_lane = [&](unsigned lane) { alive[lane / kTileColumns] &= ~(1u << (lane % kTileColumns)); };

        if (inst.path == InstancePath::world_triangles && triangle_rays.shared_axes) {
            const MeshBlas::Triangle* tris = scene.world_triangles() + inst.other.first_world_triangle;
            // The rays the instance is tested for, counted as trace() counts a visit.
            unsigned tested[kTileRows][kTileColumns / W] = {};
            for (TileLineSet rs = rows; rs != 0; rs &= rs - 1) {
                const unsigned r = unsigned(std::countr_zero(rs));
                for (unsigned b = 0; b < kTileColumns / W; ++b) {
                    tested[r][b] = block_lanes(r, b);
                    if (tested[r][b] != 0)
                        results.count_world_triangles<W>(RayTile::lane(b * W, r), tested[r][b],
                                                         inst.other.world_triangle_count);
                }
            }
            for (std::uint32_t k = 0; k < inst.other.world_triangle_count; ++k) {
                const MeshBlas::Triangle& tri = tris[k];
                triangle_tile_hits<W>(
                    tile, triangle_rays, rows, TriangleVertices{tri.v0, tri.v1, tri.v2},
                    // Tested once and still searching (an earlier triangle may have ended a ray).
                    [&](unsigned r, unsigned blk) { return tested[r][blk] & (alive[r] >> (blk * W)) & kBlockBits; },
                    [&](unsigned lane, const TriangleHit& th) {
                        if (searches[lane].report_world_triangle(cand.index, inst, cand.opaque, k, th)) end_lane(lane);
                    });
            }
        } else {
            for (TileLineSet rs = rows; rs != 0; rs &= rs - 1) {
                const unsigned r = unsigned(std::countr_zero(rs));
                for (unsigned blk = 0; blk < kTileColumns / W; ++blk) {
                    const unsigned first = RayTile::lane(blk * W, r);
                    for (unsigned m = block_lanes(r, blk); m != 0; m &= m - 1) {
                        const unsigned lane = first + unsigned(std::countr_zero(m));
                        if (searches[lane].visit(cand.index, inst, cand.opaque)) end_lane(lane);
                    }
                }
            }
        }
    }

    for (unsigned r = 0; r < kTileRows; ++r)
        for (TileLineSet m = searches.made(r); m != 0; m &= m - 1) {
            const unsigned lane = RayTile::lane(unsigned(std::countr_zero(m)), r);
            results.set(lane, searches[lane].finish(tlas_stats));
        }
}

}  // namespace smoketrace
