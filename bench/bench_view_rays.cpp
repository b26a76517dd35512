// Bench section "view_rays": the view pass's rays (thesis 4.3.5) on the smoke scene, smoketrace's trace()
// against Embree 3 on the same triangles and the same camera rays, in one run:
//   * build: our billboards-only scene (quad BLAS, n+1 instances, TLAS; everything timed) against Embree's
//     commit of the same billboard quads and ground (its vertex and instance set-up untimed; also written
//     with the set-up timed); our whole SmokeScene (stand-ins too, 2n+1 instances) printed beside;
//   * closest hit: one ray per pixel, billboards taken as opaque (ours: ray_flag_force_opaque, mask ~1 in
//     the SmokeScene, whose stand-ins the masks skip), the nearest billboard or the ground;
//   * layers: what the one-traversal compositor really asks, every billboard in front of the ground
//     (ours: any-hit that records and ignores, the ground opaque; Embree: a context filter that records and
//     rejects billboard hits and accepts the ground's).
// Embree runs with its default build quality (medium), in two layouts (flattened: one mesh of world-space
// quads; instanced: one quad, an instance per particle, like ours), without and with RTC_SCENE_FLAG_ROBUST,
// and with two kinds of query: one ray per rtcIntersect1 (x1), or a 4x4 tile of pixels per rtcIntersect16
// with the coherent context flag (x16: Embree's packets, made for camera rays; the layers through the same
// context filter, per lane). The fastest of these is the reference of each ratio ("Embree at its best for
// speed"), and its name is printed. Every packet contender's answers are checked against the same scene's
// single rays: per ray the nearest t, or the layers in front of the ground and the ground's t. Closest-hit
// scenes carry no filter flag (Embree's leanest). Ratios are time ours / time Embree: above 1 means we are
// slower. Headline figures are single-threaded (the stable ones on a shared machine); all-thread rows are
// printed and written too. From 10k particles on (the full run) the particle radius shrinks with the count
// (bench_util.hpp), so that a ray meets about as many billboards as at 750; layers per ray are printed.
// Ours also runs tiled, as the tiled compositor does: the same rays 16x16 pixels at a time through trace_tile()
// (trace_tile.hpp), the same flags, masks and any-hit work as our single rays, timed in the same rounds. Each
// tile is made from the camera before timing, as the rays are, and copied per trace (trace_tile() lowers its
// tmax), as Embree's packets are loaded from the rays. Its answers are checked against our single rays: per
// ray the closest hit's t (bit for bit) and instance, the ground's t and the layers in front of it.
// view_rays.csv's ours_over_this is our single rays' time over the row's, tiled_over_this our tiled time.
#include "bench_registry.hpp"
#include "bench_util.hpp"
#include "embree_device.hpp"
#include "support/embree_reference.hpp"
#include "timing.hpp"
#include "view_ray_contenders.hpp"

#include <smoketrace/render/camera.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>
#include <smoketrace/trace/trace.hpp>
#include <smoketrace/trace/trace_tile.hpp>

#include <tbb/info.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace smoketrace::bench {
namespace {

namespace er = embree_reference;
using namespace view_rays;

std::string fmt(double v, int precision = 3) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(precision) << v;
    return s.str();
}

void run_view_rays(const BenchOptions& options) {
    const int size = 512;
    const std::vector<std::uint32_t> counts = options.quick ? std::vector<std::uint32_t>{750}
                                                            : std::vector<std::uint32_t>{750, 1500, 10'000};
    const int repeats = std::max(options.repeats, 3);
    const int all_threads = tbb::info::default_concurrency();
    const er::Device device = bench_embree_device();
    CsvFile csv("particles,measure,implementation,robust,threads,rays,median_ms,min_ms,max_ms,ours_over_this,work,"
                "tiled_over_this");
    // Headline figures (750 particles, one thread): ours / the best Embree contender, over every one, over
    // the robust ones, over single rays only; whether the best one is a packet query; layers per ray. Ours
    // tiled: its time over the best Embree contender's, its rays per second (millions); at one thread and
    // at all threads (_mt).
    struct Headline {
        double ratio = 0, ratio_robust = 0, ratio_x1 = 0, best_is_packet = 0;
        double tiled_ratio = 0, tiled_mrays = 0, tiled_ratio_mt = 0, tiled_mrays_mt = 0;
    } headline_closest, headline_layers;
    double headline_build = 0, headline_layers_per_ray = 0;
    std::size_t disagreements_total = 0, packet_disagreements_total = 0, tiled_disagreements_total = 0,
                tiled_ties_total = 0;
    // The contenders' order: ours first (per ray, then tiled; the smoke scene, then billboards only).
    constexpr std::size_t kOurs = 0, kOursBillboards = 1, kOursTiled = 2, kOursBillboardsTiled = 3;

    for (const std::uint32_t n : counts) {
        const SceneDescription desc = animated_scene(options, n, size);
        const std::vector<Particle>& ps = desc.smoke.particles;
        const GroundQuad ground{desc.ground->corners};
        const Camera camera = scene_camera(desc, size);
        const glm::vec3 eye = camera.position();
        const CameraRays cam = camera_rays(camera, size);
        const std::vector<Ray>& rays = cam.rays;
        const std::vector<RayTile>& ray_tiles = cam.tiles;
        std::cout << "  " << n << " particles, " << rays.size() << " camera rays (" << size << "x" << size
                  << ", two_tubes_right.json's camera); ms, medians of " << repeats << " round-robin repeats\n";

        // ---- builds (all threads) ----
        std::optional<SmokeScene> smoke;
        std::unique_ptr<OursBillboards> billboards;
        std::vector<EmbreeVariant> embree = embree_variants();
        // build_ms[0]: our SmokeScene, [1]: our billboards-only scene, [2 + k]: Embree variant k's commit,
        // setup_ms[k]: the same with its set-up (world vertices or instance geometries, then the commit).
        std::vector<std::vector<double>> build_ms(2 + embree.size()), setup_ms(embree.size());
        for (int r = 0; r < repeats; ++r) {
            build_ms[0].push_back(time_ms(1, [&] {
                smoke.reset();
                smoke.emplace(ps, StandInShape{StandInKind::sphere, 0}, ground, true);
                smoke->update(ps, eye);
            }).median);
            build_ms[1].push_back(time_ms(1, [&] {
                billboards.reset();
                billboards = std::make_unique<OursBillboards>(ps, eye, ground);
            }).median);
            for (std::size_t k = 0; k < embree.size(); ++k) {
                EmbreeVariant& v = embree[k];
                const auto t0 = std::chrono::steady_clock::now();
                v.closest.reset();
                v.closest = std::make_unique<EmbreeBillboards>(device, ps, eye, ground, v.layout, v.robust, false);
                const auto t1 = std::chrono::steady_clock::now();
                v.closest->commit();
                const auto t2 = std::chrono::steady_clock::now();
                build_ms[2 + k].push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
                setup_ms[k].push_back(std::chrono::duration<double, std::milli>(t2 - t0).count());
            }
        }
        for (EmbreeVariant& v : embree) {
            v.layers = std::make_unique<EmbreeBillboards>(device, ps, eye, ground, v.layout, v.robust, true);
            v.layers->commit();
        }
        const double ours_build = stats_of(build_ms[0]).median, ours_bb_build = stats_of(build_ms[1]).median;
        double best_embree_build = std::numeric_limits<double>::infinity();
        std::cout << "    build, all threads (ms): smoketrace smoke scene (stand-ins, billboards, ground) " << fmt(ours_build)
                  << ", billboards and ground only " << fmt(ours_bb_build) << "; Embree commit (with set-up):";
        csv.row(n, "build", "smoketrace_smoke_scene", 0, all_threads, 0, ours_build, stats_of(build_ms[0]).min,
                stats_of(build_ms[0]).max, 1.0, 0);
        csv.row(n, "build", "smoketrace_billboards", 0, all_threads, 0, ours_bb_build, stats_of(build_ms[1]).min,
                stats_of(build_ms[1]).max, 1.0, 0);
        for (std::size_t k = 0; k < embree.size(); ++k) {
            const Stats s = stats_of(build_ms[2 + k]), w = stats_of(setup_ms[k]);
            std::cout << " " << embree[k].name << " " << fmt(s.median) << " (" << fmt(w.median) << ")";
            csv.row(n, "build", embree[k].name, int(embree[k].robust), all_threads, 0, s.median, s.min, s.max,
                    ours_bb_build / s.median, 0);
            csv.row(n, "build_with_setup", embree[k].name, int(embree[k].robust), all_threads, 0, w.median, w.min,
                    w.max, ours_bb_build / w.median, 0);
            best_embree_build = std::min(best_embree_build, s.median);
        }
        std::cout << "\n    billboards-only build / fastest Embree commit: " << fmt(ours_bb_build / best_embree_build, 2)
                  << "\n";

        // ---- the same answers? untimed. Closest hit per ray: each Embree variant's single rays against
        // ours, and its packets against its single rays; all layers: its packets against its single rays.
        std::vector<float> ours_t(rays.size()), other_t(rays.size());
        for (std::size_t i = 0; i < rays.size(); ++i) {
            const TraceResult r = trace(smoke->scene(), rays[i], ray_flag_force_opaque, kViewRayMask);
            ours_t[i] = r.hit ? r.committed.t : std::numeric_limits<float>::infinity();
        }
        const std::size_t tiles = rays.size() / kPacket;
        std::vector<std::size_t> differ(embree.size(), 0), packet_differ(embree.size(), 0);
        for (std::size_t k = 0; k < embree.size(); ++k) {
            for (std::size_t i = 0; i < rays.size(); ++i) {
                float t;
                other_t[i] = embree[k].closest->closest(rays[i], t) ? t : std::numeric_limits<float>::infinity();
                differ[k] += !same_t(ours_t[i], other_t[i]);
            }
            disagreements_total += differ[k];
            const auto records = std::make_unique<LayerRecord[]>(kPacket);
            LayerRecord single;
            std::array<float, kPacket> packet_t, ground_t;
            for (std::size_t tile = 0; tile < tiles; ++tile) {
                const std::array<const Ray*, kPacket> lanes = tile_rays(rays, size, tile);
                embree[k].closest->closest16(lanes, packet_t);
                for (int l = 0; l < kPacket; ++l) {
                    const std::size_t i = std::size_t(lanes[std::size_t(l)] - rays.data());
                    packet_differ[k] += !same_t(other_t[i], packet_t[std::size_t(l)]);
                }
                for (int l = 0; l < kPacket; ++l) records[std::size_t(l)].count = 0;
                embree[k].layers->layers16(lanes, records.get(), ground_t);
                for (int l = 0; l < kPacket; ++l) {
                    single.count = 0;
                    const float ground = embree[k].layers->layers(*lanes[std::size_t(l)], single);
                    packet_differ[k] += !same_layers(single, ground, records[std::size_t(l)], ground_t[std::size_t(l)]);
                }
            }
            packet_disagreements_total += packet_differ[k];
        }
        // Ours tiled against our single rays, on both our scenes: the closest hit bit for bit, and its
        // instance (the same t on another instance is a tie at exactly that t, which trace_tile() may commit
        // in another order: counted apart); the ground's t and every layer in front of it, t bit for bit
        // (which layers behind the ground a ray meets before it commits the ground depends on the order).
        struct TiledCheck {
            std::size_t closest = 0, ties = 0, layers = 0;
        } tiled_check;
        {
            TileState st;
            st.records = std::make_unique<LayerRecord[]>(kTileRays);
            LayerRecord single;
            for (const auto& [s, mask] : {std::pair<const AccelScene*, std::uint8_t>{&smoke->scene(), kViewRayMask},
                                          {&billboards->scene, std::uint8_t(0xFF)}})
                for (std::size_t k = 0; k < ray_tiles.size(); ++k) {
                    RayTile tile = ray_tiles[k];
                    trace_tile(*s, tile, ray_flag_force_opaque, mask, AcceptEvery{}, st.results, st.scratch);
                    for (unsigned lane = 0; lane < kTileRays; ++lane) {
                        const TraceResult alone =
                            trace(*s, rays[tile_pixel(size, k, lane)], ray_flag_force_opaque, mask);
                        const TraceResult tiled = st.results[lane];
                        if (tiled.hit != alone.hit || (alone.hit && !same_bits(tiled.committed.t, alone.committed.t)))
                            ++tiled_check.closest;
                        else if (alone.hit && tiled.committed.instance_index != alone.committed.instance_index)
                            ++tiled_check.ties;
                    }
                    tile = ray_tiles[k];
                    LayerRecord* records = st.records.get();
                    for (unsigned lane = 0; lane < kTileRays; ++lane) records[lane].count = 0;
                    trace_tile(*s, tile, ray_flag_none, mask,
                               [records](unsigned lane, const TraceHit& h) {
                                   records[lane].add(h.t);
                                   return AnyHitDecision::ignore;
                               },
                               st.results, st.scratch);
                    for (unsigned lane = 0; lane < kTileRays; ++lane) {
                        single.count = 0;
                        const TraceResult alone = trace(*s, rays[tile_pixel(size, k, lane)], ray_flag_none, mask,
                                                        [&single](const TraceHit& h) {
                                                            single.add(h.t);
                                                            return AnyHitDecision::ignore;
                                                        });
                        const TraceResult tiled = st.results[lane];
                        const float ground = alone.hit ? alone.committed.t : std::numeric_limits<float>::infinity();
                        const std::vector<float> a = single.sorted_in_front(ground),
                                                 b = records[lane].sorted_in_front(ground);
                        bool same = tiled.hit == alone.hit && (!alone.hit || same_bits(tiled.committed.t, ground)) &&
                                    a.size() == b.size();
                        for (std::size_t i = 0; same && i < a.size(); ++i) same = same_bits(a[i], b[i]);
                        tiled_check.layers += !same;
                    }
                }
            tiled_disagreements_total += tiled_check.closest + tiled_check.layers;
            tiled_ties_total += tiled_check.ties;
        }

        // ---- traversal: closest and layers, 1 thread and all threads ----
        for (const char* measure : {"closest", "layers"}) {
            const bool closest = std::string(measure) == "closest";
            for (int threads : {1, all_threads}) {
                if (threads == all_threads && all_threads == 1) break;
                std::vector<Contender> cs =
                    measure_contenders(closest, cam, size, smoke->scene(), &billboards->scene, embree);
                tbb::task_arena arena(threads);
                arena.execute([&] { time_round_robin(cs, repeats, threads > 1, rays.size()); });
                const double ours = stats_of(cs[kOurs].ms).median, tiled = stats_of(cs[kOursTiled].ms).median;
                double best = std::numeric_limits<double>::infinity(), best_robust = best, best_x1 = best;
                const Contender* best_one = nullptr;
                std::ostringstream line;
                line << "    " << std::left << std::setw(8) << measure << std::right << std::setw(2) << threads
                     << " thr:";
                for (std::size_t k = 0; k < cs.size(); ++k) {
                    const Stats s = stats_of(cs[k].ms);
                    line << (k > 0 && k % 4 == 0 ? "\n       " : "") << "  " << cs[k].name << " " << fmt(s.median, 2);
                    csv.row(n, measure, cs[k].name, int(cs[k].robust && !cs[k].ours), threads, rays.size(), s.median,
                            s.min, s.max, ours / s.median, cs[k].work.hits, tiled / s.median);
                    if (!cs[k].ours) {
                        if (s.median < best) best_one = &cs[k];
                        best = std::min(best, s.median);
                        if (cs[k].robust) best_robust = std::min(best_robust, s.median);
                        if (!cs[k].packets) best_x1 = std::min(best_x1, s.median);
                    }
                }
                line << "\n      ours/best Embree " << fmt(ours / best, 2) << " (best: " << best_one->name
                     << "; robust " << fmt(ours / best_robust, 2) << ", single rays " << fmt(ours / best_x1, 2)
                     << "), billboards-only ours/best " << fmt(stats_of(cs[kOursBillboards].ms).median / best, 2)
                     << "\n      tiled ours/best Embree " << fmt(tiled / best, 2) << " (" << best_one->name << "; "
                     << fmt(double(rays.size()) / tiled / 1e3, 1) << " Mrays/s, " << fmt(ours / tiled, 2)
                     << "x our single rays), billboards-only tiled ours/best "
                     << fmt(stats_of(cs[kOursBillboardsTiled].ms).median / best, 2) << "; work:";
                for (const Contender& c : cs) line << " " << c.work.hits;
                if (!closest)
                    line << " (" << fmt(double(cs[kOurs].work.hits) / double(rays.size()), 2) << " layers per ray)";
                std::cout << line.str() << "\n" << std::flush;
                if (n == 750) {
                    Headline& h = closest ? headline_closest : headline_layers;
                    const double mrays = double(rays.size()) / tiled / 1e3;
                    if (threads == 1) {
                        h.ratio = ours / best;
                        h.ratio_robust = ours / best_robust;
                        h.ratio_x1 = ours / best_x1;
                        h.best_is_packet = best_one->packets ? 1.0 : 0.0;
                        h.tiled_ratio = tiled / best;
                        h.tiled_mrays = mrays;
                        if (!closest) headline_layers_per_ray = double(cs[kOurs].work.hits) / double(rays.size());
                    } else {
                        h.tiled_ratio_mt = tiled / best;
                        h.tiled_mrays_mt = mrays;
                    }
                }
            }
        }
        std::cout << "    closest-hit answers differing from ours (|dt| > 1e-4 relative):";
        for (std::size_t k = 0; k < embree.size(); ++k) std::cout << " " << embree[k].name << " " << differ[k];
        std::cout << " of " << rays.size() << "\n    packet answers differing from the same scene's single rays "
                  << "(closest t, or layers and ground t):";
        for (std::size_t k = 0; k < embree.size(); ++k) std::cout << " " << embree[k].name << " " << packet_differ[k];
        std::cout << " of " << 2 * rays.size() << "\n    tiled answers differing from our single rays (both our scenes;"
                  << " t bit for bit): closest hit " << tiled_check.closest << " (and " << tiled_check.ties
                  << " ties: another instance at the same t), layers " << tiled_check.layers << ", of "
                  << 2 * rays.size() << " each\n";
        if (n == 750) headline_build = ours_bb_build / best_embree_build;
    }
    csv.write(std::filesystem::path(options.results_dir) / "view_rays.csv");
    report("view_rays_ratio_vs_embree", headline_closest.ratio);
    report("view_rays_ratio_vs_embree_robust", headline_closest.ratio_robust);
    report("view_rays_ratio_vs_embree_x1", headline_closest.ratio_x1);
    report("view_rays_embree_best_is_packet", headline_closest.best_is_packet);
    report("view_layers_ratio_vs_embree", headline_layers.ratio);
    report("view_layers_ratio_vs_embree_x1", headline_layers.ratio_x1);
    report("view_layers_embree_best_is_packet", headline_layers.best_is_packet);
    report("view_layers_per_ray", headline_layers_per_ray);
    report("smoke_build_ratio_vs_embree", headline_build);
    report("view_rays_embree_disagreements", double(disagreements_total));
    report("view_rays_embree_packet_disagreements", double(packet_disagreements_total));
    report("view_rays_tiled_ratio_vs_embree", headline_closest.tiled_ratio);
    report("view_rays_tiled_mrays_per_s", headline_closest.tiled_mrays);
    report("view_layers_tiled_ratio_vs_embree", headline_layers.tiled_ratio);
    report("view_layers_tiled_mrays_per_s", headline_layers.tiled_mrays);
    if (all_threads > 1) {
        // Named by the thread count: _2t on a two-core machine.
        const std::string t = "_" + std::to_string(all_threads) + "t";
        report("view_rays_tiled_ratio_vs_embree" + t, headline_closest.tiled_ratio_mt);
        report("view_rays_tiled_mrays_per_s" + t, headline_closest.tiled_mrays_mt);
        report("view_layers_tiled_ratio_vs_embree" + t, headline_layers.tiled_ratio_mt);
        report("view_layers_tiled_mrays_per_s" + t, headline_layers.tiled_mrays_mt);
    }
    report("view_rays_tiled_disagreements", double(tiled_disagreements_total));
    report("view_rays_tiled_ties", double(tiled_ties_total));
}

const RegisterSection kViewRaysSection{{"view_rays",
                                        "view-pass rays on the smoke scene vs Embree 3 on the same quads (single "
                                        "rays and 4x4 packets): build, closest hit, all layers in front of the ground",
                                        &run_view_rays, true}};

}  // namespace
}  // namespace smoketrace::bench
