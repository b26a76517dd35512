// Section "view": the view pass and the whole frame at 1024×1024 (thesis tables B.1 and B.3 on the CPU):
// the tiled compositor (the default) against the per-ray one-traversal compositor at one thread and at all
// threads, anti-aliasing's cost, the per-ray one-traversal compositor against the thesis's re-trace loop, and
// the density kernels' shadow rays (every particle toward the light summed) against uniform's nearest one.
//
// Every configuration renders the animated two-tube scene (bench_util.hpp: the light turns, particles
// drift and spin, so each frame refits the TLAS and traces 1/G of the optical depths). The configurations
// compared with each other render the same frames in turns, each inside a TBB arena of its thread count
// (frame_runs.hpp).
#include "bench_registry.hpp"
#include "bench_util.hpp"
#include "frame_runs.hpp"
#include "timing.hpp"

#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/io/scene_file.hpp>

#include <tbb/info.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace smoketrace::bench {
namespace {

constexpr int kSize = 1024;

using Config = FrameConfig;
using Run = FrameRun;

struct ImageDifference {
    double largest = 0;     // of one channel
    std::size_t off = 0;    // pixels with a channel off by more than the threshold
};

ImageDifference image_difference(const ImageRgba& a, const ImageRgba& b, double threshold) {
    ImageDifference d;
    for (std::size_t i = 0; i < a.pixels.size(); ++i) {
        const glm::vec4 e = glm::abs(a.pixels[i] - b.pixels[i]);
        const double m = std::max({e.x, e.y, e.z});
        d.largest = std::max(d.largest, m);
        d.off += m > threshold ? 1 : 0;
    }
    return d;
}

const char* name_of(RenderMode m) {
    return m == RenderMode::basic ? "basic" : m == RenderMode::simple_shadow ? "simple-shadow" : "full";
}

const char* name_of(CompositorKind c) {
    return c == CompositorKind::tiled ? "tiled" : c == CompositorKind::one_traversal ? "one_traversal" : "retrace";
}

// The run of `runs` with this configuration (the groups are not compared: every call's runs differ without them).
const Run& find(const std::vector<Run>& runs, const char* experiment, RenderMode mode, CompositorKind compositor,
                int threads, std::uint32_t spp = 1) {
    for (const Run& r : runs)
        if (std::string_view(r.config.experiment) == experiment && r.config.mode == mode &&
            r.config.compositor == compositor && r.config.threads == threads && r.config.spp == spp)
            return r;
    throw std::logic_error("bench view: no such configuration");
}

void run_view(const BenchOptions& options) {
    const int frames = options.quick ? 3 : std::max(5, options.repeats);
    const std::vector<std::uint32_t> counts = options.quick ? std::vector<std::uint32_t>{250, 750, 1500, 10'000}
                                                            : std::vector<std::uint32_t>{250, 500, 750, 1000, 1500,
                                                                                         10'000};
    const std::vector<std::uint32_t> group_counts =
        options.quick ? std::vector<std::uint32_t>{1, 4, 32} : std::vector<std::uint32_t>{1, 2, 4, 8, 16, 32};
    const int all = tbb::info::default_concurrency();
    Arenas arenas;
    std::vector<int> thread_counts = {1};
    if (all > 1) thread_counts.push_back(all);
    const SixwayTexture& texture = bench_texture(options);

    CsvFile csv("experiment,particles,groups,mode,compositor,threads,spp,frames,view_ms_median,view_ms_min,"
                "view_ms_max,total_ms_median,total_ms_min,total_ms_max,tlas_update_ms,od_pass_ms,resolve_ms,"
                "cpu_per_wall,caller_cpu_share,kernel");
    auto record = [&](std::uint32_t n, const Run& r) {
        const Config& c = r.config;
        csv.row(c.experiment, n, c.groups, name_of(c.mode), name_of(c.compositor), c.threads, c.spp, frames,
                r.view.median, r.view.min, r.view.max, r.total.median, r.total.min, r.total.max, r.tlas.median,
                r.od.median, r.resolve.median, r.cpu_per_wall, r.caller_cpu_share, c.kernel.name());
        std::printf("  %-10s n=%-5u G=%-2u %-13s %-13s thr=%d spp=%-2u %-8s view %8.1f ms  total %8.1f ms  (tlas "
                    "%.2f, od %.2f, resolve %.2f)  cpu/wall %.2f, caller %.2f\n",
                    c.experiment, n, c.groups, name_of(c.mode), name_of(c.compositor), c.threads, c.spp,
                    c.kernel.name().c_str(), r.view.median, r.total.median, r.tlas.median, r.od.median,
                    r.resolve.median, r.cpu_per_wall, r.caller_cpu_share);
        std::fflush(stdout);
    };

    std::printf("view: %d×%d, medians over %d frames after the first; the configurations of each particle count "
                "take turns frame by frame; threads 1 and %d\n",
                kSize, kSize, frames, all);
    // Table B.1 shape: particle count. Full mode with both compositors at every thread count; basic and
    // simple-shadow with the default (tiled) at all threads; at 750, anti-aliasing (spp 4) as well.
    struct Line {
        std::uint32_t n;
        double view[2][2], total[2][2], cpu_per_wall[2][2];  // [tiled, per-ray][one thread, all threads]
    };
    std::vector<Line> lines;
    std::vector<double> xs, view_ms;
    double worst_tiled = 0, worst_threads = 0, lowest_one_thread_share = 1;
    std::size_t off_tiled = 0, off_threads = 0;
    for (std::uint32_t n : counts) {
        const SceneDescription scene = animated_scene(options, n, kSize);
        std::vector<Config> configs;
        for (CompositorKind k : {CompositorKind::tiled, CompositorKind::one_traversal})
            for (int t : thread_counts) configs.push_back({"particles", RenderMode::full, k, t});
        configs.push_back({"particles", RenderMode::basic, CompositorKind::tiled, all});
        configs.push_back({"particles", RenderMode::simple_shadow, CompositorKind::tiled, all});
        if (n == kThesisParticleCount) configs.push_back({"spp", RenderMode::full, CompositorKind::tiled, all, 1, 4});
        const std::vector<Run> runs = render_frames(scene, texture, kSize, configs, frames, arenas);
        for (const Run& r : runs) {
            record(n, r);
            if (r.config.threads == 1) lowest_one_thread_share = std::min(lowest_one_thread_share, r.caller_cpu_share);
        }

        Line line{n, {}, {}, {}};
        for (int k = 0; k < 2; ++k)
            for (std::size_t t = 0; t < thread_counts.size(); ++t) {
                const Run& r = find(runs, "particles", RenderMode::full,
                                    k == 0 ? CompositorKind::tiled : CompositorKind::one_traversal, thread_counts[t]);
                line.view[k][t] = r.view.median;
                line.total[k][t] = r.total.median;
                line.cpu_per_wall[k][t] = r.cpu_per_wall;
            }
        lines.push_back(line);

        // The tiled image is the per-ray one bit for bit, and neither depends on the thread count.
        const Run& tiled = find(runs, "particles", RenderMode::full, CompositorKind::tiled, all);
        for (int t : thread_counts) {
            const ImageDifference d = image_difference(
                tiled.last, find(runs, "particles", RenderMode::full, CompositorKind::one_traversal, t).last,
                2.0 / 255.0);
            worst_tiled = std::max(worst_tiled, d.largest);
            off_tiled += d.off;
            if (t == all) continue;
            const ImageDifference e = image_difference(
                tiled.last, find(runs, "particles", RenderMode::full, CompositorKind::tiled, t).last, 2.0 / 255.0);
            worst_threads = std::max(worst_threads, e.largest);
            off_threads += e.off;
        }

        if (n < kLargeSceneFrom) {
            xs.push_back(n);
            view_ms.push_back(tiled.view.median);
        }
        if (n == kThesisParticleCount) {
            const Run& tiled_1 = find(runs, "particles", RenderMode::full, CompositorKind::tiled, 1);
            const Run& per_ray = find(runs, "particles", RenderMode::full, CompositorKind::one_traversal, all);
            const Run& spp4 = find(runs, "spp", RenderMode::full, CompositorKind::tiled, all, 4);
            report("frame_ms_full_750_1024", tiled.total.median);
            report("view_ms_full_750_1024", tiled.view.median);
            report("view_ms_full_750_1024_1t", tiled_1.view.median);
            if (all > 1) report("view_thread_speedup_750", tiled_1.view.median / tiled.view.median);
            report("tiled_speedup_vs_per_ray_750", per_ray.view.median / tiled.view.median);
            report("spp4_over_spp1_750", spp4.view.median / tiled.view.median);
            const Run& basic = find(runs, "particles", RenderMode::basic, CompositorKind::tiled, all);
            report("basic_mode_od_pass_ms", basic.od.median);
        }
        if (n == 10'000) report("frame_ms_full_10k_1024", tiled.total.median);
    }

    // Side by side: full mode, ms (medians), tiled against per-ray at each thread count.
    std::printf("  full mode, ms   |");
    for (const char* what : {"view", "frame"})
        for (const char* k : {"tiled", "per-ray"})
            for (int t : thread_counts) {
                char label[32];
                std::snprintf(label, sizeof label, "%s %s %dt", what, k, t);
                std::printf(" %16s", label);
            }
    std::printf(" | per-ray/tiled view, %dt | cpu/wall (below the thread count: the machine was busy)\n", all);
    for (const Line& l : lines) {
        std::printf("  %7u particles|", l.n);
        for (const auto* v : {&l.view, &l.total})
            for (int k = 0; k < 2; ++k)
                for (std::size_t t = 0; t < thread_counts.size(); ++t) std::printf(" %16.1f", (*v)[k][t]);
        std::printf(" | %20.2f |", l.view[1][thread_counts.size() - 1] / l.view[0][thread_counts.size() - 1]);
        for (int k = 0; k < 2; ++k)
            for (std::size_t t = 0; t < thread_counts.size(); ++t) std::printf(" %.2f", l.cpu_per_wall[k][t]);
        std::printf("\n");
    }
    std::printf("  tiled vs per-ray images (every count, every thread count): largest channel difference %.3g, pixels "
                "off by more than 2/255: %zu (both 0 by design)\n",
                worst_tiled, off_tiled);
    if (all > 1)
        std::printf("  tiled at 1 thread vs %d threads: largest channel difference %.3g, pixels off by more than "
                    "2/255: %zu (both 0 by design)\n",
                    all, worst_threads, off_threads);
    std::printf("  one-thread configurations: the calling thread's share of the CPU time, lowest of any frame %.2f "
                "(1.00 = no other thread worked)\n",
                lowest_one_thread_share);
    report("tiled_vs_per_ray_max_channel_difference", worst_tiled);
    report("view_growth_exponent_vs_particles", fit_exponent(xs, view_ms));

    // Table B.3 shape: particle groups (750 particles, full mode, tiled, all threads).
    const SceneDescription scene750 = animated_scene(options, kThesisParticleCount, kSize);
    {
        std::vector<Config> configs;
        for (std::uint32_t g : group_counts)
            configs.push_back({"groups", RenderMode::full, CompositorKind::tiled, all, g});
        for (const Run& r : render_frames(scene750, texture, kSize, configs, frames, arenas))
            record(kThesisParticleCount, r);
    }

    // The per-ray one-traversal compositor against the thesis's re-trace loop, same frames, same image.
    {
        const Config configs[] = {{"compositor", RenderMode::full, CompositorKind::one_traversal, all},
                                  {"compositor", RenderMode::full, CompositorKind::retrace, all}};
        const std::vector<Run> runs = render_frames(scene750, texture, kSize, configs, frames, arenas);
        for (const Run& r : runs) record(kThesisParticleCount, r);
        const Run& one = runs[0];
        const Run& re = runs[1];
        const ImageDifference d = image_difference(one.last, re.last, 1.0 / 255.0);
        std::printf("  one-traversal vs re-trace: view speed-up %.2f×, largest channel difference %.2e, pixels off by "
                    "more than 1/255: %.4f%%\n",
                    re.view.median / one.view.median, d.largest,
                    100.0 * double(d.off) / double(one.last.pixels.size()));
        report("one_traversal_speedup_vs_retrace", re.view.median / one.view.median);
        report("compositor_max_channel_difference", d.largest);
    }

    // The density kernels (full mode, tiled, 750 particles): a smooth kernel's shadow ray walks every stand-in
    // toward the light and integrates each exit's share, where uniform's stops at the nearest. The four
    // kernels take turns frame by frame, at one thread and at all; the view's time against uniform's.
    {
        std::vector<Config> configs;
        for (const DensityKernel& k : {kUniformKernel, kGaussianKernel, kPoly1Kernel, kPoly2Kernel})
            for (int t : thread_counts) {
                Config c{"kernel", RenderMode::full, CompositorKind::tiled, t};
                c.kernel = k;
                configs.push_back(c);
            }
        const std::vector<Run> runs = render_frames(scene750, texture, kSize, configs, frames, arenas);
        for (const Run& r : runs) record(kThesisParticleCount, r);
        auto view_of = [&](const DensityKernel& k, int threads) {
            for (const Run& r : runs)
                if (r.config.kernel == k && r.config.threads == threads) return r.view.median;
            throw std::logic_error("bench view: no such kernel configuration");
        };
        std::vector<std::pair<std::string, double>> ratios;
        std::printf("  kernels' view / uniform's view (the same frames, in turns):");
        for (const DensityKernel& k : {kGaussianKernel, kPoly1Kernel, kPoly2Kernel})
            for (int t : thread_counts) {
                ratios.emplace_back("kernel_view_over_uniform_" + k.name() + (t == 1 ? "_1t" : ""),
                                    view_of(k, t) / view_of(kUniformKernel, t));
                std::printf(" %s %dt %.2f;", k.name().c_str(), t, ratios.back().second);
            }
        std::printf("\n");
        for (const auto& [name, ratio] : ratios) report(name, ratio);
    }

    // A frame where nothing moved (the static default scene, frame 1 after frame 0): no TLAS work and no
    // optical depths, but the view is drawn again for the flipbook's next frame.
    {
        const SceneDescription still = bench_scene_file(options, "two_tubes_above.json");
        RenderOptions o = RenderOptions::from_scene(still);
        o.width = o.height = kSize;
        FrameRenderer renderer(still, o, texture);
        ImageRgba image;
        const FrameReport first = renderer.render(0, image);
        const FrameReport r = renderer.render(1, image);
        std::printf("  still frame: tlas %s, tlas_update %.3f ms, od_pass %.3f ms, resolve %.3f ms, view %.3f ms, "
                    "total %.3f ms (frame 0: total %.3f ms)\n",
                    to_string(r.tlas), r.timings.tlas_update, r.timings.od_pass, r.timings.resolve, r.timings.view,
                    r.timings.total, first.timings.total);
        report("still_frame_tlas_update_ms", r.timings.tlas_update);
        report("still_frame_optical_depth_ms", r.timings.od_pass + r.timings.resolve);
        report("still_frame_total_over_view", r.timings.total / r.timings.view);
    }
    csv.write(std::filesystem::path(options.results_dir) / "view.csv");
}

const RegisterSection kViewSection{{"view",
                                    "view pass and frame at 1024x1024 vs particles (B.1), tiled vs per-ray "
                                    "compositor at 1 and all threads, spp 4, groups (B.3), one-traversal vs "
                                    "re-trace",
                                    &run_view, true}};

}  // namespace
}  // namespace smoketrace::bench
