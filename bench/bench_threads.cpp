// Section "threads": how each contender's time holds as the threads it may use grow, ours and Embree 3's
// side by side at every thread count of a sweep (--thread-counts; by default 1, 2, 4, ... up to the threads
// this process may run on, tbb::info::default_concurrency(), and that count itself):
//   * the frame: a 1024x1024 `full` frame of the animated scene (bench_util.hpp), the tiled compositor, 750
//     particles (and 10k in the full run), as section "view" renders it; ours alone, its stages beside;
//   * the optical-depth pass + resolve at 10k particles (and 100k in the full run), as section
//     "optical_depth" runs it: ours over spheres against Embree's sphere primitive, ours over icosahedra
//     against Embree's icosahedra (flattened and instanced), single rays and packets of eight;
//   * the camera rays of the smoke scene at 750 particles, as section "view_rays" traces them: closest hits
//     and every billboard layer in front of the ground, ours one ray at a time (trace()) and in 16x16 tiles
//     (trace_tile()) against Embree on the same quads (flattened and instanced, robust and not, single rays
//     and coherent 4x4 packets);
//   * the mesh walks of section "bvh": closest hit and all hits on its sphere over terrain, incoherent rays
//     and a camera's coherent ones (ours: the API's query, for coherent closest hits the tile query; Embree:
//     every configuration, coherent closest hits also in packets of 16).
// Each comparison is ours against Embree's fastest contender at that thread count (it may be another one at
// another count; its name is printed). Every contender runs inside a TBB arena of the count being timed.
// Embree's traversal runs on the calling threads, so the arena limits it as it limits ours; its device is
// made with its default thread count, which sets no limit of its own (a device string with threads=N puts a
// process-wide TBB limit of N on every arena, ours too: the section refuses a sweep beyond such a limit).
// Counts above the process's threads are allowed (oversubscribed, said so) to try the sweep on a small
// machine. Timing: one untimed round at every count (first-use allocations, idle workers), then rounds of
// every count and every contender in turns (each round starting with the next count and contender), medians.
// Every contender's work (hits, statuses and counts; our path lengths and frames bit for bit) must be the
// same at every thread count; the mismatches are counted (threads_work_mismatches, must be 0). Scenes and
// trees are built untimed, in the arena of the largest count.
#include "bench_registry.hpp"
#include "bench_util.hpp"
#include "embree_device.hpp"
#include "frame_runs.hpp"
#include "mesh_ray_contenders.hpp"
#include "optical_depth_contenders.hpp"
#include "timing.hpp"
#include "view_ray_contenders.hpp"

#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>

#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <numeric>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace smoketrace::bench {
namespace {

namespace er = embree_reference;
namespace od = optical_depth;
namespace vr = view_rays;
namespace mr = mesh_rays;

constexpr int kFrameSize = 1024;
constexpr std::uint32_t kViewRayParticles = 750;

// One contender of a sweep: a pass timed at every thread count.
struct Contender {
    std::string name;
    bool ours;
    // One pass, inside the arena of the count being timed; returns a digest of its answers, which must not
    // depend on the thread count.
    std::function<std::uint64_t()> run;
    std::vector<std::vector<double>> ms, cpu_per_wall;  // [count][round]
    std::vector<std::uint64_t> work;                    // [count]: the last pass's digest
};

// What the sweep reports: ours against the fastest of some of the Embree contenders (none: ours alone).
struct Comparison {
    std::string key;  // summary and CSV name: threads_<key>_...
    std::size_t ours;
    std::vector<std::size_t> embree;
};

struct Sweep {
    std::string name, description;
    std::vector<Contender> contenders;
    std::vector<Comparison> comparisons;
    bool warm_up = true;  // false where one pass takes long enough that first-use costs are noise
};

// Digests of answers, combined in a fixed order (FNV-1a over 64-bit words).
class Digest {
public:
    void add(std::uint64_t word) { h_ = (h_ ^ word) * 0x100000001b3ull; }
    [[nodiscard]] std::uint64_t value() const { return h_; }

private:
    std::uint64_t h_ = 0xcbf29ce484222325ull;
};

std::uint64_t depth_digest(const std::vector<DepthStatus>& status, const std::vector<std::uint32_t>& counts,
                           const std::vector<float>* lengths) {
    Digest d;
    for (std::size_t i = 0; i < status.size(); ++i) {
        d.add(std::uint64_t(status[i]) << 32 | counts[i]);
        if (lengths) d.add(std::bit_cast<std::uint32_t>((*lengths)[i]));
    }
    return d.value();
}

double median_of(const std::vector<double>& v) { return stats_of(v).median; }

// The sweep's thread counts, ascending from 1; the contenders' per-count vectors follow their order.
using Counts = std::vector<int>;

// Times every contender of `s` at every count: rounds of (count, contender) in turns, medians later.
void time_sweep(Sweep& s, const Counts& counts, Arenas& arenas, int rounds) {
    const std::size_t n = s.contenders.size(), m = counts.size();
    for (Contender& c : s.contenders) {
        c.ms.assign(m, {});
        c.cpu_per_wall.assign(m, {});
        c.work.assign(m, 0);
    }
    for (int r = s.warm_up ? -1 : 0; r < rounds; ++r) {
        const std::size_t shift = std::size_t(r + 1);
        for (std::size_t i = 0; i < m; ++i) {
            const std::size_t t = (i + shift) % m;
            arenas.of(counts[t]).execute([&] {
                for (std::size_t k = 0; k < n; ++k) {
                    Contender& c = s.contenders[(k + shift) % n];
                    const double process0 = cpu_ms(CLOCK_PROCESS_CPUTIME_ID);
                    const auto wall0 = std::chrono::steady_clock::now();
                    c.work[t] = c.run();
                    const double wall = elapsed_ms(wall0), process = cpu_ms(CLOCK_PROCESS_CPUTIME_ID) - process0;
                    if (r < 0) continue;
                    c.ms[t].push_back(wall);
                    c.cpu_per_wall[t].push_back(wall > 0 ? process / wall : 0.0);
                }
            });
        }
    }
}

// The figures of one comparison at one count.
struct Point {
    Stats ours;
    double ours_cpu_per_wall = 0, ours_speedup = 0, embree_ms = 0, embree_speedup = 0, ratio = 0;
    std::string fastest;  // Embree's fastest contender at this count; empty: ours alone
};

class Report {
public:
    Report(const Counts& counts, const std::string& results_dir) : counts_(counts), results_(results_dir) {}

    // Prints a timed sweep's tables, checks its work, keeps its rows and summary lines.
    void add(const Sweep& s) {
        std::printf("  %s: %s\n", s.name.c_str(), s.description.c_str());
        std::printf("    %-32s", "ms (median)");
        for (const int t : counts_) std::printf(" %8dt", t);
        std::printf("  | speedup over 1 thread:");
        for (std::size_t i = 1; i < counts_.size(); ++i) std::printf(" %5dt", counts_[i]);
        std::printf("  | cpu/wall at %dt\n", counts_.back());
        for (const Contender& c : s.contenders) {
            std::printf("    %-32s", c.name.c_str());
            for (std::size_t t = 0; t < counts_.size(); ++t) std::printf(" %9.3f", median_of(c.ms[t]));
            std::printf("  | %22s", "");
            for (std::size_t t = 1; t < counts_.size(); ++t)
                std::printf(" %6.2f", median_of(c.ms[0]) / median_of(c.ms[t]));
            std::printf("  | %.2f\n", median_of(c.cpu_per_wall.back()));
            for (std::size_t t = 0; t < counts_.size(); ++t) {
                const Stats st = stats_of(c.ms[t]);
                contenders_.row(s.name, c.name, int(c.ours), counts_[t], st.median, st.min, st.max,
                                median_of(c.ms[0]) / st.median, median_of(c.cpu_per_wall[t]), c.work[t]);
                mismatches_ += c.work[t] != c.work[0];
            }
        }
        for (const Comparison& cmp : s.comparisons) {
            std::vector<Point> points(counts_.size());
            for (std::size_t t = 0; t < counts_.size(); ++t) {
                Point& p = points[t];
                const Contender& ours = s.contenders[cmp.ours];
                p.ours = stats_of(ours.ms[t]);
                p.ours_cpu_per_wall = median_of(ours.cpu_per_wall[t]);
                p.ours_speedup = points[0].ours.median / p.ours.median;
                p.embree_ms = std::numeric_limits<double>::infinity();
                for (const std::size_t e : cmp.embree)
                    if (const double ms = median_of(s.contenders[e].ms[t]); ms < p.embree_ms) {
                        p.embree_ms = ms;
                        p.fastest = s.contenders[e].name;
                    }
                if (!cmp.embree.empty()) {
                    p.embree_speedup = points[0].embree_ms / p.embree_ms;
                    p.ratio = p.ours.median / p.embree_ms;
                }
            }
            add(cmp.key, points);
        }
        std::fflush(stdout);
    }

    // The frames of one particle count, one configuration per thread count (render_frames()).
    void add_frames(const std::string& key, const std::vector<FrameRun>& runs) {
        std::printf("  %s: %dx%d full frame, tiled compositor; medians over the frames after the first\n", key.c_str(),
                    kFrameSize, kFrameSize);
        std::printf("    %-10s %10s %10s %10s %10s %9s %9s\n", "threads", "frame ms", "view ms", "od_pass ms",
                    "tlas ms", "cpu/wall", "speedup");
        // The frame's whole time and its two parallel stages: which one stops scaling.
        struct Stage {
            const char* name;
            Stats FrameRun::*stats;
        };
        constexpr Stage kStages[] = {{"smoketrace_frame", &FrameRun::total},
                                     {"smoketrace_view_pass", &FrameRun::view},
                                     {"smoketrace_od_pass", &FrameRun::od}};
        std::vector<Point> points(runs.size());
        for (std::size_t t = 0; t < runs.size(); ++t) {
            const FrameRun& r = runs[t];
            points[t].ours = r.total;
            points[t].ours_cpu_per_wall = r.cpu_per_wall;
            points[t].ours_speedup = runs[0].total.median / r.total.median;
            std::printf("    %-10d %10.2f %10.2f %10.2f %10.2f %9.2f %9.2f\n", counts_[t], r.total.median,
                        r.view.median, r.od.median, r.tlas.median, r.cpu_per_wall, points[t].ours_speedup);
            for (const Stage& stage : kStages) {
                const Stats& st = r.*stage.stats;
                contenders_.row(key, stage.name, 1, counts_[t], st.median, st.min, st.max,
                                (runs[0].*stage.stats).median / st.median, r.cpu_per_wall, "");
            }
            // Every thread count draws the same frame, bit for bit.
            mismatches_ += r.last.pixels != runs[0].last.pixels;
        }
        add(key, points);
        std::fflush(stdout);
    }

    void finish() {
        curves_.write(results_ / "threads.csv");
        contenders_.write(results_ / "threads_contenders.csv");
        for (const auto& [name, value] : summary_) report(name, value);
        report("threads_work_mismatches", double(mismatches_));
    }

private:
    // A comparison's curve: printed, a row per count, summary lines.
    void add(const std::string& key, const std::vector<Point>& points) {
        const bool embree = !points.front().fastest.empty();
        std::printf("    %-32s speedup ours", key.c_str());
        for (const Point& p : points) std::printf(" %5.2f", p.ours_speedup);
        if (embree) {
            std::printf("; Embree's fastest");
            for (const Point& p : points) std::printf(" %5.2f", p.embree_speedup);
            std::printf("; ours/Embree");
            for (const Point& p : points) std::printf(" %5.2f", p.ratio);
            std::printf(" (fastest:");
            for (std::size_t t = 0; t < points.size(); ++t)
                if (t == 0 || points[t].fastest != points[t - 1].fastest)
                    std::printf(" %s from %dt", points[t].fastest.c_str(), counts_[t]);
            std::printf(")");
        }
        std::printf("\n");
        for (std::size_t t = 0; t < points.size(); ++t) {
            const Point& p = points[t];
            const int threads = counts_[t];
            if (embree)
                curves_.row(key, threads, p.ours.median, p.ours.min, p.ours.max, p.ours_speedup, p.embree_ms,
                            p.fastest, p.embree_speedup, p.ratio, p.ours_cpu_per_wall);
            else
                curves_.row(key, threads, p.ours.median, p.ours.min, p.ours.max, p.ours_speedup, "", "", "", "",
                            p.ours_cpu_per_wall);
            const std::string at = "_" + std::to_string(threads) + "t";
            if (t > 0) summary_.emplace_back("threads_" + key + "_speedup" + at, p.ours_speedup);
            if (embree) summary_.emplace_back("threads_" + key + "_ratio_vs_embree" + at, p.ratio);
        }
    }

    const Counts& counts_;
    std::filesystem::path results_;
    CsvFile curves_{"workload,threads,ours_ms,ours_min_ms,ours_max_ms,ours_speedup,embree_ms,embree_fastest,"
                    "embree_speedup,ratio_vs_embree,ours_cpu_per_wall"};
    CsvFile contenders_{"sweep,contender,ours,threads,median_ms,min_ms,max_ms,speedup,cpu_per_wall,work_digest"};
    std::vector<std::pair<std::string, double>> summary_;
    std::size_t mismatches_ = 0;
};

// ---- the sweeps ------------------------------------------------------------------------------------------

void sweep_frames(const BenchOptions& options, const Counts& counts, Arenas& arenas, Report& report) {
    const int frames = options.quick ? 3 : std::max(5, options.repeats);
    std::vector<std::uint32_t> particles = {kThesisParticleCount};
    if (!options.quick) particles.push_back(10'000);
    for (const std::uint32_t n : particles) {
        const SceneDescription scene = animated_scene(options, n, kFrameSize);
        std::vector<FrameConfig> configs;
        for (const int t : counts) configs.push_back({"threads", RenderMode::full, CompositorKind::tiled, t});
        const std::vector<FrameRun> runs =
            render_frames(scene, bench_texture(options), kFrameSize, configs, frames, arenas);
        report.add_frames("frame_" + std::string(n == kThesisParticleCount ? "750" : "10k"), runs);
    }
}

void sweep_optical_depths(const BenchOptions& options, const er::Device& device, const Counts& counts,
                          Arenas& arenas, Report& report) {
    std::vector<std::uint32_t> particles = {10'000};
    if (!options.quick) particles.push_back(od::kLargeCount);
    od::check_embree_spheres(device);
    const glm::vec3 dir = glm::normalize(od::kToLight);
    for (const std::uint32_t n : particles) {
        const std::vector<Particle> ps = generate_tubes(od::tube_settings(n));
        const std::uint32_t cutoff = od::cutoff_for(n);
        std::vector<std::uint32_t> all(n);
        std::iota(all.begin(), all.end(), 0u);
        std::vector<od::Contender> cs;
        arenas.of(counts.back()).execute([&] { cs = od::make_contenders(device, ps, 1); });
        const std::string at = n == od::kLargeCount ? "100k" : "10k";
        Sweep s{"od_" + at,
                std::to_string(n) + " particles, light from above, " +
                    (cutoff ? "cutoff " + std::to_string(cutoff) : std::string("no cutoff")) +
                    "; pass + resolve (Embree: the pass, robust mode, all hits through its filter)",
                {}, {}, n < od::kLargeCount};
        for (od::Contender& c : cs) {
            od::Contender* p = &c;
            s.contenders.push_back({c.tracer + (c.ours ? "_" + c.stand_in : std::string()), bool(c.ours),
                                    [p, &ps, &all, dir, cutoff] {
                                        p->run_once(ps, all, dir, cutoff);
                                        return p->ours ? depth_digest(p->depths->status(), p->depths->hit_counts(),
                                                                      &p->depths->lengths())
                                                       : depth_digest(p->embree_hits.status,
                                                                      p->embree_hits.hit_counts, nullptr);
                                    },
                                    {}, {}, {}});
        }
        for (const int ours : {od::kOursSphere, od::kOursIcosahedron}) {
            Comparison cmp{"od_" + cs[std::size_t(ours)].stand_in + "_" + at, std::size_t(ours), {}};
            for (int k = od::kFirstEmbree; k < od::kContenders; ++k)
                if (cs[std::size_t(k)].stand_in == cs[std::size_t(ours)].stand_in) cmp.embree.push_back(std::size_t(k));
            s.comparisons.push_back(cmp);
        }
        time_sweep(s, counts, arenas, options.repeats);
        report.add(s);
    }
}

void sweep_view_rays(const BenchOptions& options, const er::Device& device, const Counts& counts, Arenas& arenas,
                     Report& report) {
    const int size = options.quick ? 256 : 512;
    const SceneDescription desc = animated_scene(options, kViewRayParticles, size);
    const std::vector<Particle>& ps = desc.smoke.particles;
    const GroundQuad ground{desc.ground->corners};
    const Camera camera = vr::scene_camera(desc, size);
    const vr::CameraRays cam = vr::camera_rays(camera, size);
    std::optional<SmokeScene> smoke;
    std::vector<vr::EmbreeVariant> embree = vr::embree_variants();
    arenas.of(counts.back()).execute([&] {
        smoke.emplace(ps, StandInShape{StandInKind::sphere, 0}, ground, true);
        smoke->update(ps, camera.position());
        for (vr::EmbreeVariant& v : embree) vr::build_scenes(v, device, ps, camera.position(), ground);
    });
    for (const bool closest : {true, false}) {
        std::vector<vr::Contender> cs = vr::measure_contenders(closest, cam, size, smoke->scene(), nullptr, embree);
        const std::string measure = closest ? "view_rays" : "view_layers";
        Sweep s{measure,
                std::to_string(kViewRayParticles) + " particles, " + std::to_string(cam.rays.size()) +
                    " camera rays (" + std::to_string(size) + "x" + std::to_string(size) + "), " +
                    (closest ? "closest hits" : "every billboard layer in front of the ground"),
                {}, {}, true};
        Comparison per_ray{measure, 0, {}}, tiled{measure + "_tiled", 0, {}};
        for (std::size_t k = 0; k < cs.size(); ++k) {
            vr::Contender* c = &cs[k];
            const std::size_t rays = cam.rays.size();
            s.contenders.push_back(
                {c->name, c->ours, [c, rays] { return vr::run_once(*c, true, rays).hits; }, {}, {}, {}});
            if (!c->ours) {
                per_ray.embree.push_back(k);
                tiled.embree.push_back(k);
            } else {
                (c->item_rays == kTileRays ? tiled : per_ray).ours = k;
            }
        }
        s.comparisons = {per_ray, tiled};
        time_sweep(s, counts, arenas, options.repeats);
        report.add(s);
    }
}

void sweep_mesh_rays(const BenchOptions& options, const er::Device& device, const Counts& counts, Arenas& arenas,
                     Report& report) {
    // Quick: smaller than section bvh's quick run, so that the sweep of every count stays short.
    const mr::MeshSizes sizes = options.quick ? mr::MeshSizes{6, 160, 20'000, 256} : mr::bvh_section_sizes(false);
    const TriangleMesh mesh = er::make_sphere_over_terrain(sizes.level, sizes.grid);
    const std::vector<Ray> incoherent = mr::bench_rays(sizes.rays, 2024);
    const std::vector<Ray> coherent = mr::camera_rays(sizes.camera_side);
    const std::vector<RayTile> tiles = mr::camera_tiles(sizes.camera_side);
    std::unique_ptr<MeshBlas> blas;
    std::vector<std::unique_ptr<er::Scene>> scenes;
    arenas.of(counts.back()).execute([&] {
        blas = std::make_unique<MeshBlas>(mesh);
        for (const mr::EmbreeConfig& c : mr::kEmbreeConfigs) {
            scenes.push_back(std::make_unique<er::Scene>(device, c.options));
            scenes.back()->attach_mesh(mesh);
            scenes.back()->commit();
        }
    });
    const std::string what = std::to_string(mesh.triangles.size()) + " triangles, ";
    for (const bool is_coherent : {false, true})
        for (const bool closest : {true, false}) {
            const std::vector<Ray>& rays = is_coherent ? coherent : incoherent;
            const std::string measure =
                std::string("bvh_") + (closest ? "closest" : "all_hits") + (is_coherent ? "_coherent" : "");
            Sweep s{measure,
                    what + std::to_string(rays.size()) +
                        (is_coherent ? " camera rays (" + std::to_string(sizes.camera_side) + "^2)"
                                     : std::string(" incoherent rays")) +
                        (closest ? ", closest hit" : ", all hits"),
                    {}, {}, true};
            const MeshBlas& blas_ref = *blas;
            // A pass over every ray through `walk(rays, from, to)`, in tasks of about 1024 rays.
            const auto pass = [&rays](auto walk) -> std::function<std::uint64_t()> {
                return [&rays, walk] {
                    return mr::run_pass(true, rays.size(), [&](std::size_t from, std::size_t to) {
                               return walk(rays, from, to);
                           }).hits;
                };
            };
            if (is_coherent && closest)
                s.contenders.push_back({"smoketrace_tile", true,
                                        [&blas_ref, &tiles] {
                                            const auto walk = [&](std::size_t from, std::size_t to) {
                                                return mr::ours_closest_tiles(blas_ref, tiles, from, to);
                                            };
                                            return mr::run_pass(true, tiles.size(), walk, kTileRays).hits;
                                        },
                                        {}, {}, {}});
            else if (closest)
                s.contenders.push_back(
                    {"smoketrace", true, pass([&blas_ref](const std::vector<Ray>& r, std::size_t from, std::size_t to) {
                         return mr::ours_closest(blas_ref, r, from, to);
                     }),
                     {}, {}, {}});
            else
                s.contenders.push_back(
                    {"smoketrace", true, pass([&blas_ref](const std::vector<Ray>& r, std::size_t from, std::size_t to) {
                         return mr::ours_all_hits(blas_ref, r, from, to);
                     }),
                     {}, {}, {}});
            Comparison cmp{measure, 0, {}};
            for (std::size_t i = 0; i < std::size(mr::kEmbreeConfigs); ++i) {
                if (!closest && !mr::kEmbreeConfigs[i].options.context_filter) continue;
                const er::Scene& scene = *scenes[i];
                const std::string name = mr::kEmbreeConfigs[i].name;
                const auto add = [&](const std::string& contender, std::function<std::uint64_t()> run) {
                    cmp.embree.push_back(s.contenders.size());
                    s.contenders.push_back({contender, false, std::move(run), {}, {}, {}});
                };
                if (!closest)
                    add(name, pass([&scene](const std::vector<Ray>& r, std::size_t from, std::size_t to) {
                        return mr::embree_all_hits(scene, r, from, to);
                    }));
                if (closest)
                    add(name, pass([&scene](const std::vector<Ray>& r, std::size_t from, std::size_t to) {
                        return mr::embree_closest(scene, r, from, to);
                    }));
                if (closest && is_coherent)
                    add(name + "_p16", pass([&scene](const std::vector<Ray>& r, std::size_t from, std::size_t to) {
                        return mr::embree_closest16(scene, r, from, to);
                    }));
            }
            s.comparisons = {cmp};
            time_sweep(s, counts, arenas, options.repeats);
            report.add(s);
        }
}

void run_threads(const BenchOptions& options) {
    const int cores = tbb::info::default_concurrency();
    const Counts& counts = options.thread_counts;
    if (counts.empty() || counts.front() != 1)
        throw std::logic_error("bench threads: the thread counts must start at 1");
    const int largest = counts.back();
    // Counts above the process's threads need TBB's limit raised for the section (it stays the default else).
    std::optional<tbb::global_control> oversubscribe;
    if (largest > cores) oversubscribe.emplace(tbb::global_control::max_allowed_parallelism, std::size_t(largest));
    const er::Device device = bench_embree_device();
    const std::size_t allowed = tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
    if (allowed < std::size_t(largest))
        throw std::runtime_error("bench threads: TBB lets this process run " + std::to_string(allowed) +
                                 " threads, fewer than the sweep's " + std::to_string(largest) +
                                 " (an Embree device string with threads=N, " + kEmbreeConfigVariable +
                                 ", sets such a limit for the whole process)");
    std::printf("  thread counts:");
    for (const int t : counts) std::printf(" %d", t);
    std::printf(" (this process may run %d%s); medians of %d interleaved rounds (frames: over %d frames); Embree: "
                "one device, its default thread count, its traversal on the arena's threads\n",
                cores, largest > cores ? ", the counts above it oversubscribed" : "", options.repeats,
                options.quick ? 3 : std::max(5, options.repeats));
    std::fflush(stdout);
    Arenas arenas;
    Report report(counts, options.results_dir);
    sweep_frames(options, counts, arenas, report);
    sweep_optical_depths(options, device, counts, arenas, report);
    sweep_view_rays(options, device, counts, arenas, report);
    sweep_mesh_rays(options, device, counts, arenas, report);
    report.finish();
}

const RegisterSection kThreadsSection{{"threads",
                                       "thread sweep (1, 2, 4, ... the cores): frame, optical depths, camera rays and "
                                       "mesh walks, each speedup over 1 thread and ours / Embree at every count",
                                       &run_threads, true}};

}  // namespace
}  // namespace smoketrace::bench
