// Section "view": the view pass and the whole frame at 1024×1024 (thesis tables B.1 and B.3 on the CPU),
// and the one-traversal compositor against the thesis's re-trace loop on the same frames.
//
// Every configuration renders the animated two-tube scene (bench_util.hpp: the light turns, particles
// drift and spin, so each frame refits the TLAS and traces 1/G of the optical depths). Frame 0 traces
// every particle and warms the caches; the statistics are over the frames after it.
#include "bench_registry.hpp"
#include "bench_util.hpp"
#include "timing.hpp"

#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/render/sixway_texture.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/io/sixway_files.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <vector>

namespace smoketrace::bench {
namespace {

constexpr int kSize = 1024;

const SixwayTexture& texture() {
    static const SixwayTexture t = load_sixway_texture(std::filesystem::path(SMOKETRACE_ASSET_DIR) / "sixway.json");
    return t;
}

struct Run {
    Stats view, total, tlas, od, resolve;
    ImageRgba last;  // the last frame, for comparing compositors
};

// Renders frames 0..frames and returns the statistics of frames 1..frames.
Run render_frames(const SceneDescription& scene, RenderMode mode, std::uint32_t groups, CompositorKind compositor,
                  int frames) {
    RenderOptions o = RenderOptions::from_scene(scene);
    o.render.mode = mode;
    o.render.groups = groups;
    o.compositor = compositor;
    o.width = o.height = kSize;
    FrameRenderer renderer(scene, o, texture());
    Run run;
    std::vector<double> view, total, tlas, od, resolve;
    for (int f = 0; f <= frames; ++f) {
        const FrameReport r = renderer.render(std::uint64_t(f), run.last);
        if (f == 0) continue;
        view.push_back(r.timings.view);
        total.push_back(r.timings.total);
        tlas.push_back(r.timings.tlas_update);
        od.push_back(r.timings.od_pass);
        resolve.push_back(r.timings.resolve);
    }
    run.view = stats_of(view);
    run.total = stats_of(total);
    run.tlas = stats_of(tlas);
    run.od = stats_of(od);
    run.resolve = stats_of(resolve);
    return run;
}

// Largest channel difference and the fraction of pixels differing by more than one 8-bit step.
std::pair<double, double> image_difference(const ImageRgba& a, const ImageRgba& b) {
    double worst = 0.0;
    std::size_t off = 0;
    for (std::size_t i = 0; i < a.pixels.size(); ++i) {
        const glm::vec4 d = glm::abs(a.pixels[i] - b.pixels[i]);
        const double m = std::max({d.x, d.y, d.z});
        worst = std::max(worst, m);
        off += m > 1.0 / 255.0 ? 1 : 0;
    }
    return {worst, double(off) / double(a.pixels.size())};
}

const char* name_of(RenderMode m) {
    return m == RenderMode::basic ? "basic" : m == RenderMode::simple_shadow ? "simple-shadow" : "full";
}

void run_view(const BenchOptions& options) {
    const int frames = options.quick ? 3 : std::max(5, options.repeats);
    const std::vector<std::uint32_t> counts =
        options.quick ? std::vector<std::uint32_t>{250, 750, 1500} : std::vector<std::uint32_t>{250, 500, 750, 1000, 1250, 1500};
    const std::vector<std::uint32_t> group_counts =
        options.quick ? std::vector<std::uint32_t>{1, 4, 32} : std::vector<std::uint32_t>{1, 2, 4, 8, 16, 32};
    CsvFile csv("experiment,particles,groups,mode,compositor,frames,view_ms_median,view_ms_min,view_ms_max,"
                "total_ms_median,total_ms_min,total_ms_max,tlas_update_ms,od_pass_ms,resolve_ms");
    auto record = [&](const char* experiment, std::uint32_t n, std::uint32_t g, RenderMode m, const char* comp,
                      const Run& r) {
        csv.row(experiment, n, g, name_of(m), comp, frames, r.view.median, r.view.min, r.view.max, r.total.median,
                r.total.min, r.total.max, r.tlas.median, r.od.median, r.resolve.median);
        std::printf("  %-12s n=%-5u G=%-3u %-13s %-13s view %8.1f ms  total %8.1f ms  (tlas %.2f, od %.2f, resolve %.2f)\n",
                    experiment, n, g, name_of(m), comp, r.view.median, r.total.median, r.tlas.median, r.od.median,
                    r.resolve.median);
    };

    std::printf("view: %d×%d, medians over %d frames after the first\n", kSize, kSize, frames);
    // Table B.1 shape: particle count, all three modes.
    std::vector<double> xs, view_ms;
    for (std::uint32_t n : counts) {
        const SceneDescription scene = animated_scene(n, kSize);
        for (RenderMode m : {RenderMode::basic, RenderMode::simple_shadow, RenderMode::full}) {
            const Run r = render_frames(scene, m, 1, CompositorKind::one_traversal, frames);
            record("particles", n, 1, m, "one_traversal", r);
            if (m == RenderMode::full) {
                xs.push_back(n);
                view_ms.push_back(r.view.median);
                if (n == 750) {
                    report("frame_ms_full_750_1024", r.total.median);
                    report("view_ms_full_750_1024", r.view.median);
                }
            }
            if (m == RenderMode::basic && n == 750) report("basic_mode_od_pass_ms", r.od.median);
        }
    }
    report("view_growth_exponent_vs_particles", fit_exponent(xs, view_ms));

    // Table B.3 shape: particle groups (750 particles, full mode).
    const SceneDescription scene750 = animated_scene(750, kSize);
    for (std::uint32_t g : group_counts) {
        const Run r = render_frames(scene750, RenderMode::full, g, CompositorKind::one_traversal, frames);
        record("groups", 750, g, RenderMode::full, "one_traversal", r);
    }

    // The one-traversal compositor against the thesis's re-trace loop, same frames, same image.
    const Run one = render_frames(scene750, RenderMode::full, 1, CompositorKind::one_traversal, frames);
    const Run re = render_frames(scene750, RenderMode::full, 1, CompositorKind::retrace, frames);
    record("compositor", 750, 1, RenderMode::full, "one_traversal", one);
    record("compositor", 750, 1, RenderMode::full, "retrace", re);
    const auto [worst, fraction] = image_difference(one.last, re.last);
    std::printf("  one-traversal vs re-trace: view speed-up %.2f×, largest channel difference %.2e, pixels off by more "
                "than 1/255: %.4f%%\n",
                re.view.median / one.view.median, worst, 100.0 * fraction);
    report("one_traversal_speedup_vs_retrace", re.view.median / one.view.median);
    report("compositor_max_channel_difference", worst);

    // A frame where nothing moved (the static default scene, frame 1 after frame 0): no TLAS work and no
    // optical depths, but the view is drawn again for the flipbook's next frame.
    {
        const SceneDescription still =
            load_scene_file(std::filesystem::path(SMOKETRACE_ASSET_DIR) / "scenes" / "two_tubes_above.json");
        RenderOptions o = RenderOptions::from_scene(still);
        o.width = o.height = kSize;
        FrameRenderer renderer(still, o, texture());
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
                                    "view pass and frame at 1024x1024 vs particles (B.1), groups (B.3), "
                                    "one-traversal vs re-trace compositor",
                                    &run_view}};

}  // namespace
}  // namespace smoketrace::bench
