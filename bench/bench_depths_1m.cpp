// Bench section "depths_1m": the compute side of `smoketrace depths` at a million particles (issue 12), in
// process and stage by stage, at one thread and at two (each inside a TBB arena of that size):
//  * scene: SmokeScene construction (instances, their world boxes and records),
//  * tlas: its first update, the TLAS build (binned SAH grouped by mask, then the 4-wide collapse),
//  * build alone: build_grouped_bvh() over the same world boxes, and WideBvh::collapse() of its tree,
//  * pass and resolve: the optical-depth pass and the hit resolver, from above and with no cutoff.
// The scene is the thesis's two tubes with radius 0.35·√(750/N) (bench_particle_radius), 10⁶ particles
// (10⁵ with --quick), so that a light ray crosses about 18 surfaces. Also the TLAS's SAH cost, the
// surfaces per ray and the peak resident memory of the stages (VmHWM, reset before each run where the
// kernel allows it): what `smoketrace depths` adds to the scene file's reading and the CSV's writing. Beside
// each stage's wall time, its minor page faults and system time (the process's, getrusage()): where the stages
// first touch fresh memory, which on a virtual machine can cost as much as their work.
#include "bench_registry.hpp"
#include "bench_util.hpp"
#include "timing.hpp"

#include <smoketrace/accel/bvh_builder.hpp>
#include <smoketrace/core/frame_timings.hpp>
#include <smoketrace/smoke/optical_path_lengths.hpp>
#include <smoketrace/smoke/particle_groups.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>
#include <smoketrace/smoke/tube_generator.hpp>

#include <tbb/task_arena.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <sys/resource.h>
#include <vector>

namespace smoketrace::bench {
namespace {

// Peak resident memory of the process so far, in MiB: VmHWM where /proc has it (Linux), else getrusage()'s
// ru_maxrss, which counts KiB on Linux and the BSDs but bytes on macOS, and which nothing can reset.
double peak_rss_mib() {
    std::ifstream status("/proc/self/status");
    std::string line;
    while (std::getline(status, line))
        if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
    rusage usage{};
    if (::getrusage(RUSAGE_SELF, &usage) != 0) return 0.0;
#if defined(__APPLE__)
    return double(usage.ru_maxrss) / (1024.0 * 1024.0);
#else
    return double(usage.ru_maxrss) / 1024.0;
#endif
}

// Resets VmHWM to the current resident size (Linux: "5" to /proc/self/clear_refs); false where not allowed,
// and on every other system, where the peak then is the process's since its start.
bool reset_peak_rss() {
    std::ofstream clear("/proc/self/clear_refs");
    clear << "5";
    clear.flush();
    return bool(clear);
}

struct StageTimes {
    double scene = 0, tlas = 0, build = 0, collapse = 0, pass = 0, resolve = 0, peak_mib = 0;
    // The same stages' CPU time and page faults.
    ProcessUsage scene_usage, tlas_usage, build_usage, collapse_usage, pass_usage, resolve_usage;
    [[nodiscard]] double compute() const { return scene + tlas + pass + resolve; }
    [[nodiscard]] double compute_minor_faults() const {
        return double(scene_usage.minor_faults + tlas_usage.minor_faults + pass_usage.minor_faults +
                      resolve_usage.minor_faults);
    }
    [[nodiscard]] double compute_system_ms() const {
        return scene_usage.system_ms + tlas_usage.system_ms + pass_usage.system_ms + resolve_usage.system_ms;
    }
};

// fn()'s wall time in ms, and what the process spent over it in `usage`.
template <class Fn>
double measure_ms(ProcessUsage& usage, Fn&& fn) {
    StageClock clock;
    fn();
    return clock.lap_ms(usage);
}

// One run of the pipeline as `smoketrace depths` runs it (plus the build alone, timed on the side).
// `peak_reset`: whether the peak memory could be reset before it (else it is the process's since its start).
StageTimes run_once(std::span<const Particle> particles, const glm::vec3& eye, double& sah, double& surfaces,
                    bool& peak_reset) {
    StageTimes t;
    peak_reset = reset_peak_rss();
    std::optional<GroundQuad> ground = GroundQuad{{glm::vec3(-5, -3, -5), glm::vec3(-5, -3, 5), glm::vec3(5, -3, 5),
                                                   glm::vec3(5, -3, -5)}};
    std::unique_ptr<SmokeScene> smoke;
    t.scene = measure_ms(t.scene_usage,
                         [&] { smoke = std::make_unique<SmokeScene>(particles, StandInShape{}, ground, false); });
    t.tlas = measure_ms(t.tlas_usage, [&] { smoke->update(particles, eye); });
    sah = smoke->scene().tlas_sah_cost();

    auto depths = std::make_unique<OpticalPathLengths>(particles.size());
    const std::vector<std::uint32_t> all = particle_group(particles.size(), 1, 0);
    FrameTimings ft;
    depths->update(*smoke, particles, all, glm::vec3(0, 1, 0), OpticalDepthSettings{}, HitSort::adaptive, ft);
    t.pass = ft.od_pass;
    t.resolve = ft.resolve;
    t.pass_usage = ft.usage.od_pass;
    t.resolve_usage = ft.usage.resolve;
    double hits = 0;
    for (const std::uint32_t h : depths->hit_counts()) hits += h;
    surfaces = hits / double(particles.size());
    t.peak_mib = peak_rss_mib();
    depths.reset();

    // The build alone, over the scene's own world boxes and masks.
    const AccelScene& scene = smoke->scene();
    std::vector<Aabb> boxes(scene.instance_count());
    std::vector<std::uint32_t> masks(scene.instance_count());
    for (std::uint32_t i = 0; i < scene.instance_count(); ++i) {
        boxes[i] = scene.instance_bounds(i);
        masks[i] = scene.instance(i).mask;
    }
    smoke.reset();
    Bvh bvh;
    t.build = measure_ms(t.build_usage,
                         [&] { bvh = build_grouped_bvh(boxes, masks, BvhBuildSettings{.max_leaf_size = 1}); });
    const std::vector<std::uint8_t> node_masks(bvh.nodes.size(), 0xFF);
    WideBvh wide;
    t.collapse = measure_ms(t.collapse_usage, [&] { wide.collapse(bvh, node_masks); });
    return t;
}

void run(const BenchOptions& o) {
    const std::uint32_t count = o.quick ? 100'000 : 1'000'000;
    TubeSettings tubes;
    tubes.particles = count;
    tubes.particle_radius = bench_particle_radius(count, tubes.particle_radius);
    const std::vector<Particle> particles = generate_tubes(tubes);
    const glm::vec3 eye(0, 6, 15);
    const int repeats = std::max(1, std::min(o.repeats, o.quick ? 3 : 5));

    CsvFile csv("particles,threads,repeat,scene_ms,tlas_ms,build_ms,collapse_ms,pass_ms,resolve_ms,compute_ms,"
                "peak_mib,tlas_sah,surfaces_per_ray,scene_minor_faults,tlas_minor_faults,build_minor_faults,"
                "collapse_minor_faults,pass_minor_faults,resolve_minor_faults,scene_system_ms,tlas_system_ms,"
                "build_system_ms,collapse_system_ms,pass_system_ms,resolve_system_ms");
    std::cout << "particles " << count << ", radius " << tubes.particle_radius << ", light from above, no cutoff\n";
    std::cout << "threads  scene   tlas  (build collapse)   pass  resolve  compute   peak MiB\n";
    tbb::task_arena arena_1(1), arena_2(2);
    std::vector<StageTimes> runs[3];
    double sah = 0, surfaces = 0;
    bool peak_reset = true;
    for (int r = 0; r < repeats; ++r)
        for (const int threads : {1, 2}) {
            StageTimes t;
            bool reset = false;
            (threads == 1 ? arena_1 : arena_2).execute([&] { t = run_once(particles, eye, sah, surfaces, reset); });
            peak_reset = peak_reset && reset;
            runs[threads].push_back(t);
            csv.row(count, threads, r, t.scene, t.tlas, t.build, t.collapse, t.pass, t.resolve, t.compute(), t.peak_mib,
                    sah, surfaces, t.scene_usage.minor_faults, t.tlas_usage.minor_faults, t.build_usage.minor_faults,
                    t.collapse_usage.minor_faults, t.pass_usage.minor_faults, t.resolve_usage.minor_faults,
                    t.scene_usage.system_ms, t.tlas_usage.system_ms, t.build_usage.system_ms,
                    t.collapse_usage.system_ms, t.pass_usage.system_ms, t.resolve_usage.system_ms);
        }
    StageTimes med[3];
    // Medians of the page faults and system time of the stages, per thread count: [threads][stage].
    constexpr ProcessUsage StageTimes::*kStages[] = {&StageTimes::scene_usage, &StageTimes::tlas_usage,
                                                     &StageTimes::build_usage, &StageTimes::collapse_usage,
                                                     &StageTimes::pass_usage, &StageTimes::resolve_usage};
    double faults[3][6] = {}, system_ms[3][6] = {};
    double compute_faults[3] = {}, compute_system_ms[3] = {};
    for (const int threads : {1, 2}) {
        auto median_by = [&](auto&& value) {
            std::vector<double> v;
            for (const StageTimes& t : runs[threads]) v.push_back(double(value(t)));
            return stats_of(v).median;
        };
        auto median_of = [&](double StageTimes::*field) {
            return median_by([&](const StageTimes& t) { return t.*field; });
        };
        StageTimes& m = med[threads];
        m.scene = median_of(&StageTimes::scene);
        m.tlas = median_of(&StageTimes::tlas);
        m.build = median_of(&StageTimes::build);
        m.collapse = median_of(&StageTimes::collapse);
        m.pass = median_of(&StageTimes::pass);
        m.resolve = median_of(&StageTimes::resolve);
        m.peak_mib = median_of(&StageTimes::peak_mib);
        for (std::size_t k = 0; k < std::size(kStages); ++k) {
            faults[threads][k] = median_by([&](const StageTimes& t) { return (t.*kStages[k]).minor_faults; });
            system_ms[threads][k] = median_by([&](const StageTimes& t) { return (t.*kStages[k]).system_ms; });
        }
        compute_faults[threads] = median_by([](const StageTimes& t) { return t.compute_minor_faults(); });
        compute_system_ms[threads] = median_by([](const StageTimes& t) { return t.compute_system_ms(); });
        std::cout << std::fixed << std::setprecision(1) << std::setw(7) << threads << std::setw(7) << m.scene
                  << std::setw(7) << m.tlas << "  (" << std::setw(5) << m.build << std::setw(9) << m.collapse << ")"
                  << std::setw(7) << m.pass << std::setw(9) << m.resolve << std::setw(9) << m.compute()
                  << std::setw(11) << m.peak_mib << '\n';
    }
    // The same stages' minor page faults (thousands) and system time (ms), as "faults/system".
    std::cout << "minor page faults (thousands) / system ms, the same stages:\n"
              << "threads     scene        tlas    (build  collapse)       pass    resolve    compute\n";
    for (const int threads : {1, 2}) {
        auto cell = [](double f, double ms, int width) {
            std::ostringstream c;
            c << std::fixed << std::setprecision(1) << f / 1000.0 << '/' << std::setprecision(0) << ms;
            return std::string(std::size_t(std::max(0, width - int(c.str().size()))), ' ') + c.str();
        };
        std::cout << std::setw(7) << threads << cell(faults[threads][0], system_ms[threads][0], 10)
                  << cell(faults[threads][1], system_ms[threads][1], 12) << "  ("
                  << cell(faults[threads][2], system_ms[threads][2], 7)
                  << cell(faults[threads][3], system_ms[threads][3], 10) << ")"
                  << cell(faults[threads][4], system_ms[threads][4], 10)
                  << cell(faults[threads][5], system_ms[threads][5], 11)
                  << cell(compute_faults[threads], compute_system_ms[threads], 11) << '\n';
    }
    std::cout << std::setprecision(6) << "TLAS SAH cost " << sah << ", surfaces per ray " << surfaces << '\n';
    if (!peak_reset)
        std::cout << "peak MiB: the process's since its start (this system does not let it be reset per run)\n";
    csv.write(o.results_dir + "/depths_1m.csv");
    report("depths_1m_tlas_build_ms_1t", med[1].build);
    report("depths_1m_tlas_build_ms_2t", med[2].build);
    report("depths_1m_compute_ms_1t", med[1].compute());
    report("depths_1m_compute_ms_2t", med[2].compute());
    report("depths_1m_pass_ms_1t", med[1].pass);
    report("depths_1m_pass_ms_2t", med[2].pass);
    report("depths_1m_peak_mib_1t", med[1].peak_mib);
    report("depths_1m_peak_mib_2t", med[2].peak_mib);
    report("depths_1m_tlas_sah", sah);
    report("depths_1m_minor_faults_2t", compute_faults[2]);
    report("depths_1m_system_ms_2t", compute_system_ms[2]);
}

const RegisterSection kRegister{{"depths_1m",
                                 "smoketrace depths' compute at 10^6 particles: scene, TLAS build and collapse, pass, "
                                 "resolve, their page faults and system time, peak memory, 1 and 2 threads",
                                 &run}};

}  // namespace
}  // namespace smoketrace::bench
