// Bench section "bvh": smoketrace's mesh BLAS against Embree 3 on the same mesh and the same rays, in one
// run: build (triangles per second; our SAH cost), refit of a deformed copy against its rebuild, closest hit and
// all hits (rays per second).
//
// Embree at its best for speed: its default (medium) and its high-quality (spatial split) builds, each
// with and without RTC_SCENE_FLAG_ROBUST; closest hit also on scenes without the context-filter flag.
// Embree's build time is its rtcCommitScene alone (vertex and index buffers are shared, set up untimed);
// ours is the whole MeshBlas constructor (boxes, degenerate check, tree, leaf-ordered triangle copy); either's
// release of the previous repeat's tree is untimed.
// Builds run at one thread and at two, each inside a TBB arena of that many threads, ours and Embree's
// alike (Embree's builds run in the caller's arena. A "threads=1" Embree device is no limit while another
// device with the default thread count exists: Embree sizes its tasking for the largest of its live
// devices, so such a device's builds took both threads of this machine.) The build's headline is
// Embree's default build, medium quality, without the robust flag; the high-quality build and the robust
// variants are extra rows. Traversal runs on one thread (the headline figures) and on all threads (extra
// rows). All hits: Embree's intersection-filter path (a context filter that records the hit and rejects
// it) against our any-hit traversal with a callback that records the hit and ignores it; both record
// into the same fixed per-ray buffer, so neither allocates.
//
// Rays: incoherent (random, below) and coherent (a pinhole camera's 1024×1024 pixel rays in 8×8 tiles, the
// order a tiled renderer traces them; Embree also gets them as rtcIntersect16 packets of 4×4 pixels with
// RTC_INTERSECT_CONTEXT_FLAG_COHERENT, closest hit only). Two meshes: the sphere over terrain (the build
// rows' mesh) and "objects", many small icospheres merged into one mesh (overlapping boxes, empty space).
// Our rows: "smoketrace" is the API (closest_hit / any_hit_traversal, the 8-wide tree); extra rows walk the
// 4-wide tree ("smoketrace_wide4") and the binary tree ("smoketrace_binary", the walk before the wide tree).
// On coherent rays "smoketrace_tile" is the tile query over the same pixels in 16×16 tiles, against Embree's
// rtcIntersect16 packets: each API traces its largest bundle of rays, and the rays are the same bit for bit.
//
// Headline ratios (report()):
//   build_ratio_vs_embree_medium_1t  our build time / Embree medium build time, one thread
//   build_ratio_vs_embree_medium_2t  the same at two threads
//   build_ratio_vs_embree_high_1t, build_ratio_vs_embree_high_2t: against the high-quality build (extra)
//   refit_ratio_vs_rebuild_1t, _2t  MeshBlas::update_vertices (forced refit) time / a build of the deformed mesh
//   refit_sah_ratio_vs_at_build     the refit tree's SAH cost / its cost at build (the rebuild policy's ratio)
//   closest_hit_ratio_vs_embree  our rays/s / the fastest Embree configuration's   (target ≥ 1)
//   all_hits_ratio_vs_embree     our rays/s / the fastest Embree configuration's   (target ≥ 1)
//   closest_hit_coherent_ratio_vs_embree  coherent rays: our tile query (16×16 camera rays walked together,
//                                         trace/blas_tile_traversal.hpp) / Embree's best, packets included
//   closest_hit_coherent_single_ratio_vs_embree_single: our single-ray query / Embree's best single-ray one
//   all_hits_coherent_ratio_vs_embree: all hits on coherent rays (single rays both)
//   *_objects_*: the same on the second mesh; *_binary_*: the binary walk's ratio (before the wide tree)
#include "bench_registry.hpp"
#include "bench_util.hpp"
#include "embree_device.hpp"
#include "mesh_ray_contenders.hpp"
#include "timing.hpp"

#include "support/embree_reference.hpp"

#include <smoketrace/core/prng.hpp>
#include <smoketrace/trace/blas_traversal.hpp>
#include <smoketrace/smoke/stand_in_shapes.hpp>

#include <tbb/info.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstddef>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace smoketrace::bench {
namespace {

namespace er = smoketrace::embree_reference;
using namespace mesh_rays;

// SMOKETRACE_BVH_ONLY=measure[,measure...] (e.g. "all_hits,closest_coherent"): for iterating on one walk.
// Only those traversal measures run, at one thread, without the 4-wide and binary rows; the builds and the
// refit are made once untimed. Unset (the normal run), every row is timed as documented above.
std::vector<std::string> only_measures() {
    std::vector<std::string> out;
    const char* env = std::getenv("SMOKETRACE_BVH_ONLY");
    if (env == nullptr) return out;
    std::stringstream list(env);
    for (std::string m; std::getline(list, m, ',');)
        if (!m.empty()) out.push_back(m);
    return out;
}

// The second mesh: `count` small closed icospheres (level 2, 320 triangles each, radii 0.02–0.12) at random
// places in the box [−3, 3]² × [−2, 1], merged into one mesh: many disjoint objects with overlapping
// boxes and empty space between them, unlike the two large connected surfaces of the first.
TriangleMesh make_many_objects(int count, std::uint64_t seed) {
    const TriangleMesh ico = make_icosphere(2, 1.0f);
    Pcg32 rng(seed);
    TriangleMesh m;
    for (int k = 0; k < count; ++k) {
        const glm::vec3 c(rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-2, 1));
        const float r = rng.uniform(0.02f, 0.12f);
        const auto base = static_cast<std::uint32_t>(m.vertices.size());
        for (const glm::vec3& v : ico.vertices) m.vertices.push_back(c + r * v);
        for (const glm::uvec3& t : ico.triangles) m.triangles.push_back(t + glm::uvec3(base));
    }
    return m;
}

// The same queries through a given walk of the mesh's trees: the binary tree (the walk before the wide
// tree) or a wide tree of another width than the API's.
template <class Walk>
PassResult ours_closest_walk(const MeshBlas& blas, const std::vector<Ray>& rays, std::size_t begin, std::size_t end,
                             const Walk& walk) {
    PassResult res;
    for (std::size_t i = begin; i < end; ++i) {
        const BlasRay r(rays[i]);
        float tmax = rays[i].tmax;
        bool hit = false;
        TraversalStats stats;
        walk(BoxRay(rays[i]), tmax, [&](std::uint32_t f, std::uint32_t c) {
            return mesh_leaf_hits(blas, r, tmax, f, c, stats, [&](const BlasHit& h) {
                tmax = h.t;
                hit = true;
                return false;
            });
        }, stats);
        if (hit) {
            ++res.hits;
            res.t_sum += tmax;
        }
    }
    return res;
}

template <class Walk>
PassResult ours_all_hits_walk(const MeshBlas& blas, const std::vector<Ray>& rays, std::size_t begin, std::size_t end,
                              const Walk& walk) {
    PassResult res;
    HitRecord record;
    for (std::size_t i = begin; i < end; ++i) {
        record.count = 0;
        const BlasRay r(rays[i]);
        const float tmax = rays[i].tmax;
        TraversalStats stats;
        walk(BoxRay(rays[i]), tmax, [&](std::uint32_t f, std::uint32_t c) {
            return mesh_leaf_hits(blas, r, tmax, f, c, stats, [&](const BlasHit& h) {
                record.add(h.primitive, h.t);
                return false;
            });
        }, stats);
        res.hits += record.count;
        if (record.count) res.t_sum += record.t[0];
    }
    return res;
}

// --- timing -------------------------------------------------------------------------------------------
//
// The machine is shared and its load drifts over the minutes a run takes, so contenders are timed
// round-robin (repeat 1 of every contender, then repeat 2, ...) and compared by their medians: a slow
// phase then hits all of them alike instead of whichever happened to run during it.

// Something to time: one call is one repeat (a build, or a pass over all rays). std::function is fine
// here: it is called once per repeat, the hot loops inside are templates.
struct Contender {
    std::string name;
    int threads;
    std::function<PassResult()> run;
    std::function<void()> prepare;  // untimed set-up before each repeat (Embree's scene and its buffers)
    std::vector<double> ms{};
    PassResult result{};

    Contender(std::string n, int t, std::function<PassResult()> r, std::function<void()> p = [] {})
        : name(std::move(n)), threads(t), run(std::move(r)), prepare(std::move(p)) {}
};

void time_round_robin(std::vector<Contender>& contenders, int repeats) {
    for (int k = 0; k < repeats; ++k)
        for (Contender& c : contenders) {
            c.prepare();
            const auto t0 = std::chrono::steady_clock::now();
            c.result = c.run();
            const auto t1 = std::chrono::steady_clock::now();
            c.ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
        }
}

struct Row {
    std::string measure, implementation;
    int threads;
    std::size_t triangles, rays;
    Stats ms;
    double per_second;        // triangles/s (build) or rays/s (traversal)
    double ours_over_this;    // build: our time / this time; traversal: our rays/s / this rays/s
    std::uint64_t work;       // traversal: hits (closest) or reported candidates (all hits)
};

// Formats through a local stream so std::cout's flags (the summary's format) are left alone.
void print_row(const Row& r) {
    std::ostringstream line;
    line << "  " << std::left << std::setw(10) << r.measure << std::setw(24) << r.implementation << std::right
         << std::setw(4) << r.threads << std::setw(11) << std::fixed << std::setprecision(2) << r.ms.median
         << std::setw(14) << std::setprecision(3) << r.per_second / 1e6 << std::setw(10) << r.ours_over_this
         << std::setw(12) << r.work << "\n";
    std::cout << line.str();
}

struct TraversalContext {
    int all_threads, repeats;
    std::vector<Row>& rows;
};

// Our rays/s over the fastest Embree configuration's, one thread: the API's and the binary walk's.
// For coherent rays given as tiles too, `closest` is the tile query's against Embree's best of single rays and
// packets, and `closest_single` our single-ray query's against Embree's best single-ray configuration.
struct Ratios {
    double closest = 0, all = 0, closest_binary = 0, all_binary = 0, closest_single = 0;
};

// Closest hit and all hits over one mesh and one ray set, at one thread and at all: our API, the 4-wide
// and binary walks, every Embree configuration (and, for coherent rays, every one in packets of 16).
// Rows are named measure + suffix ("closest_coherent", ...).
Ratios run_traversal(const TraversalContext& ctx, const std::string& suffix, const MeshBlas& blas,
                     const std::vector<std::unique_ptr<er::Scene>>& scenes, const std::vector<Ray>& rays,
                     bool coherent, std::size_t tris, const std::vector<RayTile>* tiles = nullptr) {
    BlasWideBvh<4> wide4;
    wide4.collapse(blas.bvh(), blas.leaf_blocks());
    // The binary tree's leaf callback is given a leaf's range; its blocks are looked up (a binary search
    // over the leaves, a small part of a leaf visit).
    const auto binary = [&](const BoxRay& br, const float& tmax, auto&& leaf, TraversalStats& st) {
        traverse_bvh(blas.bvh(), br, tmax, [&](std::uint32_t f, std::uint32_t c) { return leaf(blas.leaf_block(f), c); },
                     st);
    };
    const auto wide4_nearest = [&](const BoxRay& br, const float& tmax, auto&& leaf, TraversalStats& st) {
        traverse_blas_wide<BlasWalkOrder::nearest_first>(wide4, br, tmax, leaf, st);
    };
    const auto wide4_any = [&](const BoxRay& br, const float& tmax, auto&& leaf, TraversalStats& st) {
        traverse_blas_wide<BlasWalkOrder::any_order>(wide4, br, tmax, leaf, st);
    };
    const std::size_t n = rays.size();
    const std::vector<std::string> only = only_measures();
    Ratios ratios;
    for (int threads : {1, ctx.all_threads}) {
        if (threads == ctx.all_threads && (ctx.all_threads == 1 || !only.empty())) break;
        const bool parallel = threads > 1;
        for (const bool closest : {true, false}) {
            const std::string measure = (closest ? "closest" : "all_hits") + suffix;
            if (!only.empty() && std::find(only.begin(), only.end(), measure) == only.end()) continue;
            std::vector<Contender> passes;
            auto ours = [&](const char* name, auto closest_pass, auto all_pass) {
                passes.push_back({name, threads, [=, &rays] {
                                      return closest ? run_pass(parallel, n,
                                                                [&](std::size_t b, std::size_t e) {
                                                                    return closest_pass(rays, b, e);
                                                                })
                                                     : run_pass(parallel, n, [&](std::size_t b, std::size_t e) {
                                                           return all_pass(rays, b, e);
                                                       });
                                  }});
            };
            ours("smoketrace",
                 [&](const std::vector<Ray>& r, std::size_t b, std::size_t e) { return ours_closest(blas, r, b, e); },
                 [&](const std::vector<Ray>& r, std::size_t b, std::size_t e) { return ours_all_hits(blas, r, b, e); });
            const bool extra_walks = only.empty();
            if (extra_walks) ours(
                "smoketrace_wide4",
                [&](const std::vector<Ray>& r, std::size_t b, std::size_t e) {
                    return ours_closest_walk(blas, r, b, e, wide4_nearest);
                },
                [&](const std::vector<Ray>& r, std::size_t b, std::size_t e) {
                    return ours_all_hits_walk(blas, r, b, e, wide4_any);
                });
            if (extra_walks) ours(
                "smoketrace_binary",
                [&](const std::vector<Ray>& r, std::size_t b, std::size_t e) {
                    return ours_closest_walk(blas, r, b, e, binary);
                },
                [&](const std::vector<Ray>& r, std::size_t b, std::size_t e) {
                    return ours_all_hits_walk(blas, r, b, e, binary);
                });
            const bool tiled = closest && tiles != nullptr;
            const std::size_t tile_index = passes.size(), binary_index = extra_walks ? 2 : 0;
            if (tiled)
                passes.push_back({"smoketrace_tile", threads, [&, parallel] {
                                      return run_pass(
                                          parallel, tiles->size(),
                                          [&](std::size_t b, std::size_t e) {
                                              return ours_closest_tiles(blas, *tiles, b, e);
                                          },
                                          kTileRays);
                                  }});
            const std::size_t ours_count = passes.size();
            for (std::size_t i = 0; i < std::size(kEmbreeConfigs); ++i) {
                if (!closest && !kEmbreeConfigs[i].options.context_filter) continue;
                const er::Scene& scene = *scenes[i];
                passes.push_back({kEmbreeConfigs[i].name, threads, [&, closest, parallel] {
                                      return closest ? run_pass(parallel, n,
                                                                [&](std::size_t b, std::size_t e) {
                                                                    return embree_closest(scene, rays, b, e);
                                                                })
                                                     : run_pass(parallel, n, [&](std::size_t b, std::size_t e) {
                                                           return embree_all_hits(scene, rays, b, e);
                                                       });
                                  }});
                if (closest && coherent)
                    passes.push_back({std::string(kEmbreeConfigs[i].name) + "_p16", threads, [&, parallel] {
                                          return run_pass(parallel, n, [&](std::size_t b, std::size_t e) {
                                              return embree_closest16(scene, rays, b, e);
                                          });
                                      }});
            }
            time_round_robin(passes, ctx.repeats);
            // "ours/this" is the headline API's: the tile query's where there is one.
            const double ours_rps = n / (stats_of(passes[tiled ? tile_index : 0].ms).median * 1e-3);
            double best = 0, best_single = 0;
            for (const Contender& c : passes) {
                const Stats st = stats_of(c.ms);
                const double rps = n / (st.median * 1e-3);
                ctx.rows.push_back({measure, c.name, threads, tris, n, st, rps, ours_rps / rps, c.result.hits});
                print_row(ctx.rows.back());
                if (&c - passes.data() < std::ptrdiff_t(ours_count)) continue;
                best = std::max(best, rps);
                if (!c.name.ends_with("_p16")) best_single = std::max(best_single, rps);
            }
            if (threads == 1) {
                const double single_rps = n / (stats_of(passes[0].ms).median * 1e-3);
                const double binary_rps = n / (stats_of(passes[binary_index].ms).median * 1e-3);
                (closest ? ratios.closest : ratios.all) = ours_rps / best;
                (closest ? ratios.closest_binary : ratios.all_binary) = binary_rps / best;
                if (closest) ratios.closest_single = single_rps / best_single;
            }
        }
    }
    return ratios;
}

void run_bvh(const BenchOptions& options) {
    const MeshSizes sizes = bvh_section_sizes(options.quick);
    const int level = sizes.level, grid = sizes.grid;
    const std::size_t ray_count = sizes.rays;
    const TriangleMesh mesh = er::make_sphere_over_terrain(level, grid);
    const std::vector<Ray> rays = bench_rays(ray_count, 2024);
    const std::size_t tris = mesh.triangles.size();
    const int all_threads = tbb::info::default_concurrency();
    std::cout << "  mesh: icosphere level " << level << " over a " << grid << "x" << grid << " height field, " << tris
              << " triangles; " << ray_count << " incoherent rays; medians of " << options.repeats
              << " round-robin repeats\n";
    std::cout << "  " << std::left << std::setw(10) << "measure" << std::setw(24) << "implementation" << std::right
              << std::setw(4) << "thr" << std::setw(11) << "median ms" << std::setw(14) << "M tris|rays/s"
              << std::setw(10) << "ours/this" << std::setw(12) << "work" << "\n";
    std::vector<Row> rows;

    // ---- build: ours and every Embree configuration at two threads, ours, medium and high at one ----
    // The default thread count: the arenas below set each build's (SMOKETRACE_EMBREE_CONFIG, embree_device.hpp,
    // may set other things).
    er::Device device = bench_embree_device();
    tbb::task_arena arena_1(1), arena_2(2);
    // Each build is timed alone: the previous repeat's tree is freed in the untimed set-up, as Embree's
    // scenes are (freeing a tree's arrays gives their pages back to the kernel, which is not the build).
    std::unique_ptr<MeshBlas> blas;    // the two-thread build's, traversed below
    std::unique_ptr<MeshBlas> blas_1;  // the one-thread build's
    std::vector<std::unique_ptr<er::Scene>> scenes(std::size(kEmbreeConfigs));  // the two-thread builds'
    std::vector<Contender> builds;
    builds.push_back({"smoketrace", 2,
                      [&] {
                          arena_2.execute([&] { blas = std::make_unique<MeshBlas>(mesh); });
                          return PassResult{};
                      },
                      [&] { blas.reset(); }});
    builds.push_back({"smoketrace", 1,
                      [&] {
                          arena_1.execute([&] { blas_1 = std::make_unique<MeshBlas>(mesh); });
                          return PassResult{};
                      },
                      [&] { blas_1.reset(); }});
    for (std::size_t i = 0; i < std::size(kEmbreeConfigs); ++i) {
        const EmbreeConfig& c = kEmbreeConfigs[i];
        auto commit = [&, i] {
            arena_2.execute([&] { scenes[i]->commit(); });
            return PassResult{};
        };
        builds.push_back({c.name, 2, commit, [&, i] {
                              scenes[i] = std::make_unique<er::Scene>(device, c.options);
                              scenes[i]->attach_mesh(mesh);
                          }});
    }
    std::unique_ptr<er::Scene> scene_1;
    for (const EmbreeConfig* c : {&kEmbreeConfigs[0], &kEmbreeConfigs[2]})
        builds.push_back({c->name, 1,
                          [&] {
                              arena_1.execute([&] { scene_1->commit(); });
                              return PassResult{};
                          },
                          [&, c] {
                              scene_1 = std::make_unique<er::Scene>(device, c->options);
                              scene_1->attach_mesh(mesh);
                          }});
    const int build_repeats = only_measures().empty() ? options.repeats : 1;
    time_round_robin(builds, build_repeats);
    scene_1.reset();
    blas_1.reset();
    const double ours_build_2 = stats_of(builds[0].ms).median, ours_build_1 = stats_of(builds[1].ms).median;
    double embree_medium_ms[3] = {0, 0, 0}, embree_high_ms[3] = {0, 0, 0};  // [threads]
    for (const Contender& c : builds) {
        const Stats st = stats_of(c.ms);
        const double ours = c.threads == 1 ? ours_build_1 : ours_build_2;
        rows.push_back({"build", c.name, c.threads, tris, 0, st, tris / (st.median * 1e-3), ours / st.median, 0});
        print_row(rows.back());
        if (c.name == "embree_medium") embree_medium_ms[c.threads] = st.median;
        if (c.name == "embree_high") embree_high_ms[c.threads] = st.median;
    }
    const double sah = blas->bvh().sah_cost();
    std::cout << "  smoketrace SAH cost " << sah << " (" << blas->bvh().node_count() << " nodes, depth "
              << blas->bvh().depth() << ")\n";

    // ---- refit: the same mesh deformed (every vertex moved by a smooth field of 1 % of the sphere's
    // radius), MeshBlas::update_vertices forced to refit, against building the deformed mesh anew ----
    TriangleMesh deformed = mesh;
    for (glm::vec3& v : deformed.vertices)
        v += 0.01f * glm::vec3(std::sin(3.0f * v.y), std::sin(3.0f * v.z), std::sin(3.0f * v.x));
    std::unique_ptr<MeshBlas> refit_blas, rebuilt_blas;
    BlasUpdate refit_outcome = BlasUpdate::rebuild;
    std::vector<Contender> refits;
    for (int threads : {1, 2}) {
        tbb::task_arena& arena = threads == 1 ? arena_1 : arena_2;
        refits.push_back({"smoketrace_refit", threads,
                          [&] {
                              arena.execute([&] {
                                  constexpr double kAlwaysRefit = std::numeric_limits<double>::infinity();
                                  refit_outcome = refit_blas->update_vertices(deformed.vertices, kAlwaysRefit);
                              });
                              return PassResult{};
                          },
                          [&] { arena_2.execute([&] { refit_blas = std::make_unique<MeshBlas>(mesh); }); }});
        refits.push_back({"smoketrace_rebuild", threads,
                          [&] {
                              arena.execute([&] { rebuilt_blas = std::make_unique<MeshBlas>(deformed); });
                              return PassResult{};
                          },
                          [&] { rebuilt_blas.reset(); }});
    }
    time_round_robin(refits, build_repeats);
    rebuilt_blas.reset();
    const double refit_sah = refit_blas->sah_cost(), refit_sah_at_build = refit_blas->sah_cost_at_build();
    const double fresh_sah = MeshBlas(deformed).sah_cost();
    double refit_ms[3] = {0, 0, 0}, rebuild_ms[3] = {0, 0, 0};  // [threads]
    for (const Contender& c : refits)
        (c.name == "smoketrace_refit" ? refit_ms : rebuild_ms)[c.threads] = stats_of(c.ms).median;
    for (const Contender& c : refits) {
        const Stats st = stats_of(c.ms);
        rows.push_back(
            {"refit", c.name, c.threads, tris, 0, st, tris / (st.median * 1e-3), refit_ms[c.threads] / st.median, 0});
        print_row(rows.back());
    }
    std::cout << "  refit (" << to_string(refit_outcome) << "): SAH cost with the mesh build's cost constants "
              << refit_sah << " = " << refit_sah / refit_sah_at_build
              << " x its cost at build (the policy rebuilds past "
              << kRebuildSahRatio << "); a fresh build's " << fresh_sah << "\n";


    // ---- traversal: two meshes, incoherent and coherent rays, closest hit and all hits ----
    const TraversalContext ctx{all_threads, options.repeats, rows};
    const std::vector<Ray> camera = camera_rays(sizes.camera_side);
    std::cout << "  coherent rays: " << camera.size() << " pinhole camera rays in 8x8 tiles\n";
    const Ratios incoherent = run_traversal(ctx, "", *blas, scenes, rays, false, tris);
    const std::vector<RayTile> tiles = camera_tiles(sizes.camera_side);
    const Ratios coherent = run_traversal(ctx, "_coherent", *blas, scenes, camera, true, tris, &tiles);

    const TriangleMesh objects = make_many_objects(options.quick ? 400 : 2000, 7);
    const std::size_t object_tris = objects.triangles.size();
    std::unique_ptr<MeshBlas> object_blas;
    arena_2.execute([&] { object_blas = std::make_unique<MeshBlas>(objects); });
    std::vector<std::unique_ptr<er::Scene>> object_scenes(std::size(kEmbreeConfigs));
    for (std::size_t i = 0; i < std::size(kEmbreeConfigs); ++i) {
        object_scenes[i] = std::make_unique<er::Scene>(device, kEmbreeConfigs[i].options);
        object_scenes[i]->attach_mesh(objects);
        arena_2.execute([&] { object_scenes[i]->commit(); });
    }
    std::cout << "  second mesh \"objects\": " << objects.triangles.size() / 320
              << " level-2 icospheres merged, " << object_tris << " triangles\n";
    const Ratios objects_incoherent =
        run_traversal(ctx, "_objects", *object_blas, object_scenes, rays, false, object_tris);
    const Ratios objects_coherent =
        run_traversal(ctx, "_objects_coherent", *object_blas, object_scenes, camera, true, object_tris, &tiles);

    // ---- CSV (written whole or not at all) ----
    CsvFile file("measure,implementation,threads,triangles,rays,median_ms,min_ms,max_ms,per_second,ours_over_this,work");
    for (const Row& r : rows)
        file.row(r.measure, r.implementation, r.threads, r.triangles, r.rays, r.ms.median, r.ms.min, r.ms.max,
                 r.per_second, r.ours_over_this, r.work);
    file.row("sah_cost", "smoketrace", "", tris, "", sah, "", "", "", "", "");
    file.row("sah_cost", "smoketrace_refit", "", tris, "", refit_sah, "", "", "", "", "");
    file.row("sah_cost", "smoketrace_rebuild", "", tris, "", fresh_sah, "", "", "", "", "");
    file.write(std::filesystem::path(options.results_dir) / "bvh.csv");

    report("bvh_triangles", double(tris));
    report("bvh_sah_cost", sah);
    report("build_ratio_vs_embree_medium_1t", ours_build_1 / embree_medium_ms[1]);
    report("build_ratio_vs_embree_medium_2t", ours_build_2 / embree_medium_ms[2]);
    report("build_ratio_vs_embree_high_1t", ours_build_1 / embree_high_ms[1]);
    report("build_ratio_vs_embree_high_2t", ours_build_2 / embree_high_ms[2]);
    report("refit_ratio_vs_rebuild_1t", refit_ms[1] / rebuild_ms[1]);
    report("refit_ratio_vs_rebuild_2t", refit_ms[2] / rebuild_ms[2]);
    report("refit_sah_ratio_vs_at_build", refit_sah / refit_sah_at_build);
    report("closest_hit_ratio_vs_embree", incoherent.closest);
    report("all_hits_ratio_vs_embree", incoherent.all);
    report("closest_hit_coherent_ratio_vs_embree", coherent.closest);
    report("all_hits_coherent_ratio_vs_embree", coherent.all);
    report("closest_hit_objects_ratio_vs_embree", objects_incoherent.closest);
    report("all_hits_objects_ratio_vs_embree", objects_incoherent.all);
    report("closest_hit_objects_coherent_ratio_vs_embree", objects_coherent.closest);
    report("all_hits_objects_coherent_ratio_vs_embree", objects_coherent.all);
    report("closest_hit_coherent_single_ratio_vs_embree_single", coherent.closest_single);
    report("closest_hit_objects_coherent_single_ratio_vs_embree_single", objects_coherent.closest_single);
    report("closest_hit_binary_ratio_vs_embree", incoherent.closest_binary);
    report("all_hits_binary_ratio_vs_embree", incoherent.all_binary);
    report("closest_hit_coherent_binary_ratio_vs_embree", coherent.closest_binary);
}

const RegisterSection kBvhSection{{"bvh",
                                   "mesh BLAS vs Embree 3: build (tris/s, SAH), closest hit and all hits (rays/s)",
                                   &run_bvh}};

}  // namespace
}  // namespace smoketrace::bench
