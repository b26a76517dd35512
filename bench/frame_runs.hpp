#pragma once
// Whole frames of one scene under several configurations, rendered in turns (sections "view" and "threads"):
// frame f of every configuration before frame f + 1 of any, so that a change in the shared machine's load
// reaches them all alike; each configuration renders inside a TBB arena of its thread count. Frame 0 traces
// every particle and warms the caches; the statistics are over the frames after it.
#include "timing.hpp"

#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/render/sixway_texture.hpp>

#include <tbb/task_arena.h>
#include <time.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <utility>
#include <vector>

namespace smoketrace::bench {

// One TBB arena per thread count, made when first asked for: work run inside of(n) takes at most n threads
// (of(1): the calling thread alone).
class Arenas {
public:
    tbb::task_arena& of(int threads) {
        for (auto& [t, arena] : arenas_)
            if (t == threads) return *arena;
        arenas_.emplace_back(threads, std::make_unique<tbb::task_arena>(threads));
        return *arenas_.back().second;
    }

private:
    std::vector<std::pair<int, std::unique_ptr<tbb::task_arena>>> arenas_;
};

// CPU time of `clock` (CLOCK_PROCESS_CPUTIME_ID: every thread of the process; CLOCK_THREAD_CPUTIME_ID: this
// thread), ms.
inline double cpu_ms(clockid_t clock) {
    timespec t{};
    clock_gettime(clock, &t);
    return 1e3 * double(t.tv_sec) + 1e-6 * double(t.tv_nsec);
}

struct FrameConfig {
    const char* experiment;
    RenderMode mode = RenderMode::full;
    CompositorKind compositor = CompositorKind::tiled;
    int threads = 1;
    std::uint32_t groups = 1;
    std::uint32_t spp = 1;
    DensityKernel kernel{};
};

struct FrameRun {
    FrameConfig config;
    Stats view, total, tlas, od, resolve;
    // The process's CPU time over a frame's wall time (median over frames): up to the thread count, less
    // when the machine is loaded. The calling thread's share of the process's CPU time (the lowest of any
    // frame): 1 when every frame ran on the calling thread alone (what a one-thread configuration must show,
    // whatever the load), about 1/threads when all threads shared the work.
    double cpu_per_wall = 0, caller_cpu_share = 0;
    ImageRgba last;  // the last frame, for comparing configurations' images
};

// Renders frames 0..frames of every configuration at `size`², round-robin (frame f of each in turn, starting
// each round with the next configuration), and returns the statistics of frames 1..frames of each.
inline std::vector<FrameRun> render_frames(const SceneDescription& scene, const SixwayTexture& texture, int size,
                                           std::span<const FrameConfig> configs, int frames, Arenas& arenas) {
    std::vector<std::unique_ptr<FrameRenderer>> renderers;
    std::vector<FrameRun> runs(configs.size());
    std::vector<std::vector<FrameTimings>> samples(configs.size());
    std::vector<std::vector<double>> cpu_per_wall(configs.size()), caller_share(configs.size());
    for (std::size_t c = 0; c < configs.size(); ++c) {
        RenderOptions o = RenderOptions::from_scene(scene);
        o.render.mode = configs[c].mode;
        o.render.groups = configs[c].groups;
        o.render.spp = configs[c].spp;
        o.compositor = configs[c].compositor;
        o.kernel = configs[c].kernel;
        o.width = o.height = std::uint32_t(size);
        renderers.push_back(std::make_unique<FrameRenderer>(scene, o, texture));
        runs[c].config = configs[c];
    }
    for (int f = 0; f <= frames; ++f)
        for (std::size_t k = 0; k < configs.size(); ++k) {
            const std::size_t c = (k + std::size_t(f)) % configs.size();
            FrameReport r;
            const double process0 = cpu_ms(CLOCK_PROCESS_CPUTIME_ID), caller0 = cpu_ms(CLOCK_THREAD_CPUTIME_ID);
            const auto wall0 = std::chrono::steady_clock::now();
            arenas.of(configs[c].threads).execute([&] { r = renderers[c]->render(std::uint64_t(f), runs[c].last); });
            const double wall = elapsed_ms(wall0);
            const double process = cpu_ms(CLOCK_PROCESS_CPUTIME_ID) - process0;
            const double caller = cpu_ms(CLOCK_THREAD_CPUTIME_ID) - caller0;
            if (f == 0) continue;
            samples[c].push_back(r.timings);
            cpu_per_wall[c].push_back(wall > 0 ? process / wall : 0.0);
            caller_share[c].push_back(process > 0 ? caller / process : 0.0);
        }
    for (std::size_t c = 0; c < configs.size(); ++c) {
        std::vector<double> view, total, tlas, od, resolve;
        for (const FrameTimings& t : samples[c]) {
            view.push_back(t.view);
            total.push_back(t.total);
            tlas.push_back(t.tlas_update);
            od.push_back(t.od_pass);
            resolve.push_back(t.resolve);
        }
        runs[c].view = stats_of(view);
        runs[c].total = stats_of(total);
        runs[c].tlas = stats_of(tlas);
        runs[c].od = stats_of(od);
        runs[c].resolve = stats_of(resolve);
        runs[c].cpu_per_wall = stats_of(cpu_per_wall[c]).median;
        runs[c].caller_cpu_share = stats_of(caller_share[c]).min;
    }
    return runs;
}

}  // namespace smoketrace::bench
