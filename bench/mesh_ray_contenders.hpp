#pragma once
// Rays against one triangle mesh, ours against Embree 3 (sections "bvh" and "threads"): the mesh and the
// rays (incoherent; a pinhole camera's pixels, coherent, also as our 16x16 tiles), Embree's configurations,
// and the closest-hit and all-hits passes of each side over a range of rays. bench_bvh.cpp says what each
// does and why it is the same work.
#include "support/embree_reference.hpp"

#include <smoketrace/core/prng.hpp>
#include <smoketrace/render/camera.hpp>
#include <smoketrace/trace/blas_tile_traversal.hpp>
#include <smoketrace/trace/blas_traversal.hpp>

#include <glm/geometric.hpp>
#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace smoketrace::bench::mesh_rays {

namespace er = embree_reference;

// The section's sizes: the sphere over terrain at icosphere `level` over a `grid`² height field, `rays`
// incoherent rays, a camera of `camera_side`² pixels.
struct MeshSizes {
    int level, grid;
    std::size_t rays;
    int camera_side;
};
inline MeshSizes bvh_section_sizes(bool quick) {
    return quick ? MeshSizes{6, 160, 50'000, 512} : MeshSizes{7, 384, 500'000, 1024};
}

struct EmbreeConfig {
    const char* name;
    er::SceneOptions options;
};
inline const EmbreeConfig kEmbreeConfigs[] = {
    {"embree_medium", {RTC_BUILD_QUALITY_MEDIUM, false, true}},
    {"embree_medium_robust", {RTC_BUILD_QUALITY_MEDIUM, true, true}},
    {"embree_high", {RTC_BUILD_QUALITY_HIGH, false, true}},
    {"embree_high_robust", {RTC_BUILD_QUALITY_HIGH, true, true}},
    // Closest hit only: the leanest scenes, without the context-filter flag.
    {"embree_medium_nofilter", {RTC_BUILD_QUALITY_MEDIUM, false, false}},
    {"embree_high_nofilter", {RTC_BUILD_QUALITY_HIGH, false, false}},
};

// Rays from random points on a sphere of radius 6 around the mesh, aimed at random points of the box
// around it: incoherent, most hit the sphere or the terrain (the Embree tests use the same recipe).
inline std::vector<Ray> bench_rays(std::size_t n, std::uint64_t seed) {
    Pcg32 rng(seed);
    const glm::vec3 centre(0.0f, 0.0f, -0.5f);
    std::vector<Ray> rays;
    rays.reserve(n);
    while (rays.size() < n) {
        const glm::vec3 u(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        if (glm::length(u) < 0.1f || glm::length(u) > 1.0f) continue;
        Ray r;
        r.origin = centre + 6.0f * glm::normalize(u);
        const glm::vec3 target = centre + 2.5f * glm::vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        r.direction = target - r.origin;
        rays.push_back(r);
    }
    return rays;
}

// A pinhole camera's pixel rays, side × side, looking at the mesh from above one side, in 8×8 tiles (row by
// row inside a tile, tiles row by row): neighbouring rays in the array are neighbours in the image.
inline Camera bench_camera(int side) {
    return Camera({0.0f, -6.5f, 2.5f}, {0.0f, 0.0f, -0.8f}, {0.0f, 0.0f, 1.0f}, 45.0f, side, side);
}
inline std::vector<Ray> camera_rays(int side) {
    const Camera camera = bench_camera(side);
    constexpr int kTile = 8;
    std::vector<Ray> rays;
    rays.reserve(std::size_t(side) * std::size_t(side));
    for (int ty = 0; ty < side; ty += kTile)
        for (int tx = 0; tx < side; tx += kTile)
            for (int y = ty; y < std::min(ty + kTile, side); ++y)
                for (int x = tx; x < std::min(tx + kTile, side); ++x) rays.push_back(camera.ray(x, y, 0.0f));
    return rays;
}

// The same pixels' rays as tiles of kTileColumns × kTileRows (geometry/ray_tile.hpp), for the tile query: lane by
// lane bit for bit camera_rays()' rays.
inline std::vector<RayTile> camera_tiles(int side) {
    const Camera camera = bench_camera(side);
    std::vector<RayTile> tiles;
    for (int ty = 0; ty < side; ty += int(kTileRows))
        for (int tx = 0; tx < side; tx += int(kTileColumns))
            tiles.push_back(camera.tile(tx, ty, std::min(int(kTileColumns), side - tx),
                                        std::min(int(kTileRows), side - ty), glm::vec2(0.5f), 0.0f));
    return tiles;
}

// Per-ray hit record with a fixed capacity: both tracers write every candidate here (beyond the
// capacity only counted), so the all-hits work is identical and allocation-free.
struct HitRecord {
    static constexpr std::uint32_t kCapacity = 64;
    std::array<std::uint32_t, kCapacity> prim;
    std::array<float, kCapacity> t;
    std::uint32_t count = 0;
    void add(std::uint32_t p, float tt) {
        if (count < kCapacity) {
            prim[count] = p;
            t[count] = tt;
        }
        ++count;
    }
};

// What a traversal pass returns: its work, so the optimiser cannot drop it and the two tracers can be
// seen to do the same job.
struct PassResult {
    std::uint64_t hits = 0;  // closest: rays that hit; all hits: candidates reported
    double t_sum = 0.0;
};

// --- smoketrace ---------------------------------------------------------------------------------------

inline PassResult ours_closest(const MeshBlas& blas, const std::vector<Ray>& rays, std::size_t begin, std::size_t end) {
    PassResult res;
    for (std::size_t i = begin; i < end; ++i) {
        BlasHit hit;
        BlasCounters counters;
        if (closest_hit(blas, rays[i], hit, counters)) {
            ++res.hits;
            res.t_sum += hit.t;
        }
    }
    return res;
}

inline PassResult ours_all_hits(const MeshBlas& blas, const std::vector<Ray>& rays, std::size_t begin, std::size_t end) {
    PassResult res;
    HitRecord record;
    for (std::size_t i = begin; i < end; ++i) {
        record.count = 0;
        BlasHit committed;
        BlasCounters counters;
        any_hit_traversal(blas, rays[i], [&](const BlasHit& h) {
            record.add(h.primitive, h.t);
            return AnyHitDecision::ignore;
        }, committed, counters);
        res.hits += record.count;
        if (record.count) res.t_sum += record.t[0];
    }
    return res;
}

// The tile query (trace/blas_tile_traversal.hpp) over tiles [begin, end).
inline PassResult ours_closest_tiles(const MeshBlas& blas, const std::vector<RayTile>& tiles, std::size_t begin,
                              std::size_t end) {
    PassResult res;
    BlasTileHits hits;
    for (std::size_t i = begin; i < end; ++i) {
        RayTile tile = tiles[i];
        TraversalStats stats;
        closest_hit(blas, tile, hits, stats);
        for (unsigned r = 0; r < tile.rows(); ++r)
            for (TileLineSet m = hits.found[r]; m != 0; m &= m - 1) {
                ++res.hits;
                res.t_sum += hits.hit[RayTile::lane(unsigned(std::countr_zero(m)), r)].t;
            }
    }
    return res;
}

// --- Embree -------------------------------------------------------------------------------------------

inline PassResult embree_closest(const er::Scene& scene, const std::vector<Ray>& rays, std::size_t begin, std::size_t end) {
    PassResult res;
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    for (std::size_t i = begin; i < end; ++i) {
        const Ray& r = rays[i];
        RTCRayHit rh = er::to_rtc_ray_hit(r);
        rtcIntersect1(scene.handle(), &context, &rh);
        if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
            ++res.hits;
            res.t_sum += rh.ray.tfar;
        }
    }
    return res;
}

// Closest hit in packets of 16 rays (consecutive rays: a 4×4 block of an 8×8 tile when the rays come from
// camera_rays()), with the coherent flag.
inline PassResult embree_closest16(const er::Scene& scene, const std::vector<Ray>& rays, std::size_t begin, std::size_t end) {
    PassResult res;
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    for (std::size_t i0 = begin; i0 < end; i0 += 16) {
        alignas(64) RTCRayHit16 rh;
        alignas(64) int valid[16];
        for (unsigned j = 0; j < 16; ++j) {
            const std::size_t i = i0 + j;
            valid[j] = i < end ? -1 : 0;
            const Ray& r = rays[i < end ? i : begin];
            rh.ray.org_x[j] = r.origin.x;
            rh.ray.org_y[j] = r.origin.y;
            rh.ray.org_z[j] = r.origin.z;
            rh.ray.tnear[j] = r.tmin;
            rh.ray.dir_x[j] = r.direction.x;
            rh.ray.dir_y[j] = r.direction.y;
            rh.ray.dir_z[j] = r.direction.z;
            rh.ray.time[j] = 0.0f;
            rh.ray.tfar[j] = r.tmax;
            rh.ray.mask[j] = ~0u;
            rh.ray.id[j] = j;
            rh.ray.flags[j] = 0;
            rh.hit.geomID[j] = RTC_INVALID_GEOMETRY_ID;
            rh.hit.primID[j] = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0][j] = RTC_INVALID_GEOMETRY_ID;
        }
        rtcIntersect16(valid, scene.handle(), &context, &rh);
        for (unsigned j = 0; j < 16; ++j)
            if (valid[j] && rh.hit.geomID[j] != RTC_INVALID_GEOMETRY_ID) {
                ++res.hits;
                res.t_sum += rh.ray.tfar[j];
            }
    }
    return res;
}

inline PassResult embree_all_hits(const er::Scene& scene, const std::vector<Ray>& rays, std::size_t begin, std::size_t end) {
    PassResult res;
    HitRecord record;
    for (std::size_t i = begin; i < end; ++i) {
        record.count = 0;
        scene.all_hits(rays[i], [&](const er::EmbreeHit& h) { record.add(h.primitive, h.t); });
        res.hits += record.count;
        if (record.count) res.t_sum += record.t[0];
    }
    return res;
}

// --- passes over all rays ----------------------------------------------------------------------------

// One pass over `items` items (rays, or tiles of `item_rays` rays), on this thread or on the threads of the
// arena it runs in, about 1024 rays per task whatever the item: with 1024 tiles per task, a 1024x1024 image's
// 4096 tiles would keep at most four threads busy.
template <class Pass>
PassResult run_pass(bool all_threads, std::size_t items, const Pass& pass, std::size_t item_rays = 1) {
    if (!all_threads) return pass(std::size_t(0), items);
    tbb::combinable<PassResult> partial;
    const std::size_t grain = std::max<std::size_t>(1, 1024 / item_rays);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, items, grain), [&](const tbb::blocked_range<std::size_t>& r) {
        const PassResult p = pass(r.begin(), r.end());
        PassResult& acc = partial.local();
        acc.hits += p.hits;
        acc.t_sum += p.t_sum;
    });
    return partial.combine([](PassResult a, const PassResult& b) {
        a.hits += b.hits;
        a.t_sum += b.t_sum;
        return a;
    });
}

}  // namespace smoketrace::bench::mesh_rays
