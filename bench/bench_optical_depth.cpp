// Bench section "optical_depth": the optical-depth pass (thesis 4.3.2) and resolve (4.3.3) for the particle
// counts of table B.1 (250…1500) and for 10k and 100k particles, against Embree 3 doing the same all-hits
// work over the same stand-in shape in the same run.
//
// Scene: the thesis's two tubes, the ground under them, light from above. Up to 1500 particles the
// TubeSettings defaults with only the count changed (table B.1 varies nothing else) and the thesis's
// default cutoff of 60 hits (4.4.3); at 10k and 100k no cutoff, and the particle radius shrinks with the
// count (bench_util.hpp, bench_particle_radius) so that a ray crosses about as many surfaces as at 750.
// The mean surfaces per ray and the cut-off rays are printed beside every time. Ours runs with sphere and
// with icosahedron stand-ins, Embree over the same two shapes, and each of ours is compared with the
// fastest Embree contender over its own shape (ours over spheres against Embree's sphere primitive is the
// headline; ours over spheres against Embree over icosahedra is printed too, but is not the same work).
// Embree's stand-ins:
//   * spheres: its own sphere primitive, one RTC_GEOMETRY_TYPE_SPHERE_POINT geometry of every particle's
//     (centre, radius). Its intersector hands the filter a sphere's entry and its exit as two hits (the
//     filter rejects the first, so the second follows; the duplicate filter below never fires on a
//     sphere): check_embree_spheres() verifies that before any sphere figure is taken;
//   * icosahedra, flattened: one mesh of every particle's world-space triangles (vertices
//     translate(centre)·scale(radius) in double, rounded once), a one-level BVH;
//   * icosahedra, instanced: one icosahedron, one RTC_GEOMETRY_TYPE_INSTANCE per particle, a two-level BVH
//     like ours.
// Each is asked in two ways:
//   * x1: one ray per rtcOccluded1; x8: packets of eight parallel neighbours per rtcOccluded8 with the
//     coherent context flag, Embree's answer to what our bundles do (ray_bundle.hpp). Not 16 as our
//     bundles: Debian's Embree 3.13.5 looped forever inside rtcOccluded16 on valid rays of this pass
//     (instanced layout, robust mode), reproducibly once other sections had run before this one, and
//     packets of 8 were no faster than single rays anyway (1.2-1.4x slower, measured here).
// Both tracers take the rays in bundle_order() in tasks of 16. Embree's work per ray is what our pass does:
// every crossing goes through a filter that records (t, ±1) and rejects it so the traversal goes on;
// Embree reports a ray through a shared edge or vertex on every triangle there, so the filter drops a
// second same-facing crossing of one particle (a convex stand-in is entered once and left once); at the
// (K+1)-th crossing it accepts, which ends the ray's occlusion query; a cut-off ray is followed by a
// ground-only query, as in ours; the hits land in one flat buffer of per-particle lists.
// Default build quality (RTC_BUILD_QUALITY_MEDIUM), robust mode on: without it Embree misses some of the
// exact edge crossings of this scene (its speed and its wrong answers are printed at 750 particles), so it
// would not be doing the same job. Times are medians over interleaved rounds; builds are timed separately
// (table B.1's "build AS" column) except in od_100k_ms. Every count checks that both did the same work:
// statuses, hit counts and path lengths of ours against every Embree contender over the same shape.
#include "bench_registry.hpp"
#include "bench_util.hpp"
#include "embree_device.hpp"
#include "support/embree_reference.hpp"
#include "optical_depth_contenders.hpp"
#include "timing.hpp"

#include <smoketrace/smoke/density_kernel.hpp>
#include <smoketrace/smoke/optical_path_lengths.hpp>
#include <smoketrace/smoke/stand_in_shapes.hpp>
#include <smoketrace/smoke/tube_generator.hpp>

#include <tbb/info.h>
#include <tbb/task_arena.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <numeric>
#include <iterator>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace smoketrace::bench {
namespace {

namespace er = embree_reference;
using namespace optical_depth;

constexpr int kSmallCountRounds = 25;  // rounds of the comparison up to 1500 particles (see run_optical_depth)
constexpr std::uint32_t kReportCount = 750;
// Lengths of the two tracers are compared (a check that both did the same work, not a test) to this
// relative difference; see tests/embree_optical_depth.cpp for why it holds.
constexpr double kAgreementTolerance = 1e-4;

struct CsvRow {
    std::uint32_t particles;
    float radius;
    std::uint32_t cutoff;  // 0: none
    std::string tracer;
    std::string stand_in;
    int threads;
    Times t;
    double ratio_vs_embree;  // total / the fastest Embree contender over the same stand-in, same count and threads
    Work work;
};

// How many particles two answers disagree on: status, hit count, or length beyond kAgreementTolerance.
// One kind is counted apart: an ok ray with the same length whose hit counts differ by an even number
// grazed a corner or an edge of one tracer's icosahedron and missed the other's, an entry and an exit at
// one point. Embree's flattened layout rounds every vertex to float in world space, so its icosahedra
// are not ours to the last bit (the instanced layout's are): at 100k particles of radius 0.03 a few of
// the 100k rays pass within that rounding of an edge.
struct Disagreements {
    std::size_t differ = 0;
    std::size_t grazing = 0;
    [[nodiscard]] std::size_t total() const { return differ + grazing; }
    Disagreements& operator+=(const Disagreements& o) {
        differ += o.differ;
        grazing += o.grazing;
        return *this;
    }
};

Disagreements disagreements(const OpticalPathLengths& ours, OpticalDepthHits& embree) {
    std::vector<float> lengths(embree.status.size());
    resolve_optical_path_lengths(embree.lists, embree.status, lengths, HitSort::adaptive);
    Disagreements d;
    for (std::size_t i = 0; i < lengths.size(); ++i) {
        const bool same_status = ours.status()[i] == embree.status[i];
        const bool same_length = embree.status[i] != DepthStatus::ok ||
                                 std::abs(double(ours.lengths()[i]) - double(lengths[i])) <=
                                     kAgreementTolerance * double(lengths[i]);
        const std::uint32_t a = ours.hit_counts()[i], b = embree.hit_counts[i];
        if (same_status && same_length && a == b) continue;
        const bool grazing = same_status && same_length && embree.status[i] == DepthStatus::ok &&
                             (std::max(a, b) - std::min(a, b)) % 2 == 0;
        (grazing ? d.grazing : d.differ) += 1;
    }
    return d;
}

// The smooth density kernels (density_kernel.hpp) on one count's scene: our pass + resolve over spheres with
// the uniform kernel (eq. 3.1: the hits kept, sorted and walked) and with each smooth kernel (the exits'
// closed-form shares summed, nothing kept), against Embree's sphere primitive, one ray per query (the
// faster of its two sphere queries above), doing the same: its filter adds each exit's share (the same
// particle_stretch_integral(), one at a time where ours takes a bundle's exits over lanes). Interleaved
// rounds, medians; both must agree on every status and count, and on every sum to its roundings.
struct KernelTimes {
    double uniform = 0;
    double ours[3] = {}, embree[3] = {};
};
constexpr DensityKernel kBenchKernels[3] = {kGaussianKernel, kPoly1Kernel, kPoly2Kernel};

std::size_t kernel_disagreements(const OpticalPathLengths& ours, const OpticalDepthHits& embree,
                                 const std::vector<float>& embree_sums) {
    std::size_t differ = 0;
    for (std::size_t i = 0; i < embree_sums.size(); ++i) {
        if (ours.status()[i] != embree.status[i] || ours.hit_counts()[i] != embree.hit_counts[i]) {
            ++differ;
            continue;
        }
        if (embree.status[i] != DepthStatus::ok) continue;
        // The same shares summed in another order and rounded to float: 2^-24 of l each, and n·2^-53 of it.
        const double l = embree_sums[i];
        differ += std::abs(double(ours.lengths()[i]) - l) > (0x1p-23 + double(ours.hit_counts()[i]) * 0x1p-53) * l;
    }
    return differ;
}

KernelTimes compare_kernels(tbb::task_arena& arena, const SmokeScene& scene, EmbreePass& embree,
                            const std::vector<Particle>& ps, std::span<const std::uint32_t> all, glm::vec3 dir,
                            std::uint32_t cutoff, int rounds, bool warm_up, std::size_t& disagreements) {
    const std::size_t n = ps.size();
    OpticalPathLengths uniform(n);
    std::vector<OpticalPathLengths> ours;
    for (int k = 0; k < 3; ++k) ours.emplace_back(n);
    OpticalDepthHits embree_hits;
    std::vector<std::vector<float>> embree_sums(3);
    std::vector<double> t_uniform, t_ours[3], t_embree[3];
    auto round = [&](bool keep) {
        FrameTimings ft;
        const double u = time_once_ms([&] {
            uniform.update(scene, ps, all, kToLight, OpticalDepthSettings{cutoff}, HitSort::adaptive, ft);
        });
        if (keep) t_uniform.push_back(u);
        for (int k = 0; k < 3; ++k) {
            OpticalDepthSettings settings{cutoff};
            settings.kernel = kBenchKernels[k];
            const double o = time_once_ms([&] { ours[k].update(scene, ps, all, kToLight, settings, HitSort::adaptive, ft); });
            const double e = time_once_ms(
                [&] { embree.run(ps, dir, cutoff, Query::single, embree_hits, &kBenchKernels[k], &embree_sums[k]); });
            if (keep) t_ours[k].push_back(o), t_embree[k].push_back(e);
            if (keep && t_ours[k].size() == 1) disagreements += kernel_disagreements(ours[k], embree_hits, embree_sums[k]);
        }
    };
    arena.execute([&] {
        if (warm_up) round(false);
        for (int r = 0; r < rounds; ++r) round(true);
    });
    KernelTimes t;
    t.uniform = stats_of(t_uniform).median;
    for (int k = 0; k < 3; ++k) t.ours[k] = stats_of(t_ours[k]).median, t.embree[k] = stats_of(t_embree[k]).median;
    return t;
}

void run_optical_depth(const BenchOptions& options) {
    const std::vector<std::uint32_t> counts =
        options.quick ? std::vector<std::uint32_t>{250, 750, 1500, 10'000, kLargeCount}
                      : std::vector<std::uint32_t>{250, 500, 750, 1000, 1250, 1500, 10'000, kLargeCount};
    const int all_threads = tbb::info::default_concurrency();
    tbb::task_arena one_thread(1);
    tbb::task_arena every_thread(all_threads);
    const er::Device device = bench_embree_device();
    const glm::vec3 dir = glm::normalize(kToLight);
    std::vector<CsvRow> csv;
    const std::ios_base::fmtflags cout_flags = std::cout.flags();  // restored for report() and later sections
    const std::streamsize cout_precision = std::cout.precision();

    check_embree_spheres(device);
    std::cout << "Embree's sphere primitive reports the entry and the exit of each sphere (x1 and x8): checked\n"
              << "Two tubes, ground, light from above; up to 1500 particles TubeSettings defaults and cutoff "
              << kCutoff << ", from 10k on no cutoff and radius 0.35*sqrt(750/N).\nms, medians of "
              << std::max(options.repeats, kSmallCountRounds) << " interleaved rounds up to 1500 particles, "
              << options.repeats << " at 10k and 100k (quick: 1). Embree (robust mode, all hits through a filter):\n"
              << "over icosahedra, flattened / instanced layout; over its sphere primitive; one ray per query (x1)\n"
              << "or packets of eight (x8). Ratios: ours / the fastest Embree contender over the same shape\n";
    std::cout << std::setw(7) << "count" << std::setw(4) << "thr" << " |" << std::setw(27)
              << "sphere: pass resolve total"
              << " |" << std::setw(27) << "icosahedron: pass resolve total" << " |" << std::setw(9) << "ico flat"
              << std::setw(9) << "ico inst" << std::setw(9) << "flat x8" << std::setw(9) << "inst x8" << " |"
              << std::setw(9) << "sph x1" << std::setw(9) << "sph x8" << " |" << std::setw(9) << "sph/Esph"
              << std::setw(9) << "ico/Eico" << "\n";

    std::vector<double> fit_counts, fit_sphere, fit_icosa, fit_embree_icosa, fit_embree_sphere;
    double report_ratio = 0, report_speedup_icosa = 0, report_sphere_ratio = 0, report_embree = 0;
    double large_sphere_ratio = 0, large_ms = 0, large_hits = 0;
    Disagreements icosa_disagreements, sphere_disagreements;
    std::size_t kernel_disagreements_total = 0;
    CsvFile kernel_csv("particles,threads,tracer,kernel,total_ms,ratio_vs_uniform,ratio_vs_embree");
    for (const std::uint32_t n : counts) {
        const bool large = n >= kLargeSceneFrom;
        const TubeSettings settings = tube_settings(n);
        const std::uint32_t cutoff = cutoff_for(n);
        const std::vector<Particle> ps = generate_tubes(settings);
        std::vector<std::uint32_t> all(n);
        std::iota(all.begin(), all.end(), 0u);
        const int build_repeats = large ? 1 : options.repeats;

        // Builds, all threads. Ours: stand-in BLAS + instances + TLAS build (SmokeScene + commit). Embree:
        // each contender its own scene.
        std::vector<Contender> c;
        every_thread.execute([&] { c = make_contenders(device, ps, build_repeats); });

        for (const int threads : {1, all_threads}) {
            tbb::task_arena& arena = threads == 1 ? one_thread : every_thread;
            // Round-robin over the tracers, so that the shared machine's load hits them alike. Small counts
            // get a warm-up round (first-frame allocations, cold caches, idle TBB workers would dominate);
            // at 10k and 100k one pass takes long enough that these are noise, and quick mode runs one round.
            // Up to 1500 particles a round of all of them takes a few ms, so it runs at least
            // kSmallCountRounds rounds: with five, the 750-particle ratio spread over 2.5-3.3x in three runs
            // of the same binary on this shared machine.
            const int rounds =
                large ? (options.quick ? 1 : options.repeats) : std::max(options.repeats, kSmallCountRounds);
            arena.execute([&] {
                if (!large) {
                    for (Contender& k : c) k.run_once(ps, all, dir, cutoff);
                    for (Contender& k : c) k.medians();
                }
                for (int r = 0; r < rounds; ++r)
                    for (Contender& k : c) k.run_once(ps, all, dir, cutoff);
            });
            Times t[kContenders];
            for (int k = 0; k < kContenders; ++k) t[k] = c[k].medians();
            double embree_icosa = std::numeric_limits<double>::infinity(), embree_sphere = embree_icosa;
            for (int k = kFirstEmbree; k < kContenders; ++k) {
                double& best = c[k].layout == Layout::spheres ? embree_sphere : embree_icosa;
                best = std::min(best, t[k].total);
            }
            std::cout << std::setw(7) << n << std::setw(4) << threads << " |" << std::fixed << std::setprecision(3)
                      << std::setw(9) << t[kOursSphere].pass << std::setw(8) << t[kOursSphere].resolve << std::setw(10)
                      << t[kOursSphere].total << " |" << std::setw(9) << t[kOursIcosahedron].pass << std::setw(8)
                      << t[kOursIcosahedron].resolve << std::setw(10) << t[kOursIcosahedron].total << " |";
            for (int k = kFirstEmbree; k < kContenders; ++k)
                std::cout << std::setw(9) << t[k].total << (k == kFirstEmbree + 3 ? " |" : "");
            std::cout << " |" << std::setprecision(2) << std::setw(9) << t[kOursSphere].total / embree_sphere
                      << std::setw(9) << t[kOursIcosahedron].total / embree_icosa << "\n"
                      << std::defaultfloat;
            for (int k = 0; k < kContenders; ++k)
                csv.push_back({n, settings.particle_radius, cutoff, c[k].tracer, c[k].stand_in, threads, t[k],
                               t[k].total / (c[k].stand_in == "sphere" ? embree_sphere : embree_icosa), c[k].work()});
            if (threads == all_threads) {
                fit_counts.push_back(n);
                fit_sphere.push_back(t[kOursSphere].total);
                fit_icosa.push_back(t[kOursIcosahedron].total);
                fit_embree_icosa.push_back(embree_icosa);
                fit_embree_sphere.push_back(embree_sphere);
                if (n == kReportCount) {
                    report_ratio = t[kOursIcosahedron].total / embree_icosa;
                    report_speedup_icosa = embree_icosa / t[kOursSphere].total;
                    report_sphere_ratio = t[kOursSphere].total / embree_sphere;
                    report_embree = embree_icosa;
                }
                if (n == kLargeCount) large_sphere_ratio = t[kOursSphere].total / embree_sphere;
            }
        }
        // Both did the same work: our answers against each Embree contender's over the same shape (last runs).
        Disagreements differ_icosa, differ_sphere;
        for (int k = kFirstEmbree; k < kContenders; ++k) {
            if (c[k].layout == Layout::spheres)
                differ_sphere += disagreements(*c[kOursSphere].depths, c[k].embree_hits);
            else
                differ_icosa += disagreements(*c[kOursIcosahedron].depths, c[k].embree_hits);
        }
        icosa_disagreements += differ_icosa;
        sphere_disagreements += differ_sphere;
        const Work ws = c[kOursSphere].work(), wi = c[kOursIcosahedron].work();
        std::cout << std::fixed << std::setprecision(2) << "        radius " << settings.particle_radius << ", cutoff "
                  << (cutoff ? std::to_string(cutoff) : std::string("none")) << ": surfaces per ray " << ws.hits_per_ray
                  << " (spheres), " << wi.hits_per_ray << " (icosahedra); cut off " << ws.cut_off << " and "
                  << wi.cut_off << " of " << n << "; Embree disagreements " << differ_sphere.differ << " (spheres), "
                  << differ_icosa.differ << " (icosahedra), grazing " << differ_sphere.grazing + differ_icosa.grazing
                  << "\n"
                  << "        builds (all threads, ms): sphere " << c[kOursSphere].build_ms << ", icosahedron "
                  << c[kOursIcosahedron].build_ms << "; embree flattened " << c[kFirstEmbree].build_ms << ", instanced "
                  << c[kFirstEmbree + 1].build_ms << ", spheres " << c[kFirstEmbree + 4].build_ms << "\n"
                  << std::defaultfloat;

        if (n == kReportCount || n == 10'000 || n == kLargeCount) {
            std::cout << "        density kernels over spheres (ms; ours pass + resolve, Embree spheres x1 summing the "
                         "same shares in its filter):\n"
                      << "          thr |  uniform | gaussian    poly1    poly2 | x uniform: gauss  poly1  poly2 | "
                         "embree x1: gauss    poly1    poly2 | ours/embree: gauss poly1 poly2\n";
            for (const int threads : {1, all_threads}) {
                tbb::task_arena& arena = threads == 1 ? one_thread : every_thread;
                const int rounds =
                    large ? (options.quick ? 1 : options.repeats) : std::max(options.repeats, kSmallCountRounds);
                const KernelTimes t = compare_kernels(arena, *c[kOursSphere].ours, *c[kFirstEmbree + 4].embree, ps, all,
                                                      dir, cutoff, rounds, !large, kernel_disagreements_total);
                std::cout << std::fixed << std::setprecision(3) << "          " << std::setw(3) << threads << " |"
                          << std::setw(9) << t.uniform << " |";
                for (const double o : t.ours) std::cout << std::setw(9) << o;
                std::cout << " |           " << std::setprecision(2);
                for (const double o : t.ours) std::cout << std::setw(7) << o / t.uniform;
                std::cout << " |           " << std::setprecision(3);
                for (const double e : t.embree) std::cout << std::setw(9) << e;
                std::cout << " |             " << std::setprecision(2);
                for (int k = 0; k < 3; ++k) std::cout << std::setw(6) << t.ours[k] / t.embree[k];
                std::cout << "\n" << std::defaultfloat;
                kernel_csv.row(n, threads, "smoketrace", "uniform", t.uniform, 1.0, "");
                for (int k = 0; k < 3; ++k) {
                    kernel_csv.row(n, threads, "smoketrace", kBenchKernels[k].name(), t.ours[k], t.ours[k] / t.uniform,
                                   t.ours[k] / t.embree[k]);
                    kernel_csv.row(n, threads, "embree_spheres_x1", kBenchKernels[k].name(), t.embree[k],
                                   t.embree[k] / t.uniform, "");
                    if (threads == all_threads && (n == kReportCount || n == kLargeCount)) {
                        const std::string at = n == kLargeCount ? "_100k" : "";
                        report("od_kernel_" + kBenchKernels[k].name() + "_ratio_vs_uniform" + at, t.ours[k] / t.uniform);
                        report("od_kernel_" + kBenchKernels[k].name() + "_ratio_vs_embree" + at, t.ours[k] / t.embree[k]);
                    }
                }
            }
        }
        if (n == kReportCount) {
            // Why Embree runs in robust mode here: without it, the flattened layout misses crossings of the
            // shared edges every ray leaves its own particle through (light from above). Its speed is shown
            // beside, with the ratio it would give, but it is not the reference: it does not do the same job.
            const double ours_icosa = report_ratio * report_embree;
            for (const Query q : {Query::single, Query::packet8}) {
                EmbreePass fast(device, ps, Layout::flattened, false);
                OpticalDepthHits hits;
                double ms = 0;
                every_thread.execute([&] {
                    ms = time_ms(options.repeats, [&] { fast.run(ps, dir, cutoff, q, hits); }).median;
                });
                std::cout << "        embree flattened " << (q == Query::single ? "x1" : "x8")
                          << " without robust mode: " << std::fixed << std::setprecision(3) << ms << " ms ("
                          << std::setprecision(2) << ms / report_embree
                          << "x the robust reference; ours over icosahedra " << ours_icosa / ms
                          << "x its time), wrong on " << disagreements(*c[kOursIcosahedron].depths, hits).total()
                          << " of " << n << " particles (not used)\n"
                          << std::defaultfloat;
            }
        }
        if (n == kLargeCount) {
            // Cold: scene (BLAS, instances, TLAS build) + pass + resolve, all threads, sphere stand-ins.
            c.clear();  // free the Embree scenes first
            OpticalPathLengths od(n);
            every_thread.execute([&] {
                large_ms = time_ms(options.quick ? 1 : options.repeats, [&] {
                    SmokeScene scene(ps, StandInShape{StandInKind::sphere, 0}, ground_quad(), false);
                    scene.update(ps, glm::vec3(0.0f, 0.0f, 10.0f));
                    FrameTimings ft;
                    od.update(scene, ps, all, kToLight, OpticalDepthSettings{cutoff}, HitSort::adaptive, ft);
                }).median;
            });
            const Work w = work_of(od.status(), od.hit_counts());
            large_hits = w.hits_per_ray;
            std::cout << "        " << n << " particles from scratch (scene, TLAS build, pass, resolve): " << std::fixed
                      << std::setprecision(1) << large_ms << " ms; " << std::setprecision(2) << w.hits_per_ray
                      << " surfaces per ray, " << w.cut_off << " cut off\n"
                      << std::defaultfloat;
        }
    }

    std::cout << "Embree and ours disagree on " << sphere_disagreements.differ << " particle answers over spheres and "
              << icosa_disagreements.differ << " over icosahedra (must be 0); grazing (same length, an entry and an "
              << "exit more in one of them): " << sphere_disagreements.grazing << " and " << icosa_disagreements.grazing
              << " (summed over the contenders)\n";
    // The growth of the cost with the count, separately for the two kinds of scene: table B.1's (the
    // radius kept: surfaces per ray grow with the count) and the large counts' (about as many per ray).
    std::vector<std::size_t> b1, big;
    for (std::size_t i = 0; i < fit_counts.size(); ++i) (fit_counts[i] < kLargeSceneFrom ? b1 : big).push_back(i);
    auto exponent = [&](const std::vector<std::size_t>& which, const std::vector<double>& ms) {
        std::vector<double> x, y;
        for (const std::size_t i : which) {
            x.push_back(fit_counts[i]);
            y.push_back(ms[i]);
        }
        return fit_exponent(x, y);
    };
    std::cout << "Cost exponent (log-log least squares of ms vs count, all threads):\n" << std::fixed
              << std::setprecision(2);
    for (const auto& [label, which] : {std::pair{"  table B.1 counts (cutoff 60):         ", &b1},
                                       std::pair{"  10k, 100k (no cutoff, radius shrunk): ", &big}})
        std::cout << label << "sphere " << exponent(*which, fit_sphere) << ", icosahedron "
                  << exponent(*which, fit_icosa) << ", embree spheres " << exponent(*which, fit_embree_sphere)
                  << ", embree icosahedra " << exponent(*which, fit_embree_icosa) << "\n";
    std::cout.flags(cout_flags);
    std::cout.precision(cout_precision);

    CsvFile file("particles,radius,cutoff,tracer,stand_in,threads,build_ms,pass_ms,resolve_ms,total_ms,"
                 "ratio_vs_embree,hits_per_ray,cut_off");
    for (const CsvRow& r : csv)
        file.row(r.particles, r.radius, r.cutoff, r.tracer, r.stand_in, r.threads, r.t.build, r.t.pass, r.t.resolve,
                 r.t.total, r.ratio_vs_embree, r.work.hits_per_ray, r.work.cut_off);
    file.write(std::filesystem::path(options.results_dir) / "optical_depth.csv");

    report("od_sphere_speedup_vs_embree_sphere", 1.0 / report_sphere_ratio);
    report("od_sphere_ratio_vs_embree_sphere", report_sphere_ratio);
    report("od_pass_ratio_vs_embree", report_ratio);
    report("od_sphere_speedup_vs_embree_icosahedron", report_speedup_icosa);
    report("od_sphere_ratio_vs_embree_sphere_100k", large_sphere_ratio);
    report("od_100k_ms", large_ms);
    report("od_100k_hits_per_ray", large_hits);
    report("od_embree_sphere_disagreements", double(sphere_disagreements.differ));
    report("od_embree_disagreements", double(icosa_disagreements.differ));
    report("od_embree_grazing", double(sphere_disagreements.grazing + icosa_disagreements.grazing));
    std::cout << "Embree and ours disagree on " << kernel_disagreements_total
              << " particles' kernel sums, statuses or counts (must be 0)\n";
    report("od_kernel_embree_disagreements", double(kernel_disagreements_total));
    kernel_csv.write(std::filesystem::path(options.results_dir) / "optical_depth_kernels.csv");
}

const RegisterSection kOpticalDepthSection{{"optical_depth",
                                            "optical-depth pass + resolve (thesis 4.3.2-4.3.3, table B.1 counts, "
                                            "10k, 100k) vs Embree 3 all-hits over spheres and icosahedra",
                                            &run_optical_depth}};

}  // namespace
}  // namespace smoketrace::bench
