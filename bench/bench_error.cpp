// Bench section "error": run time against error. Every configuration renders the same animated sequence
// (bench_util.hpp: two tubes seen from view 2, light turning 1°/frame about z, particles drifting) next to
// the exact reference, and is measured on two things: its stage times (tlas_update, od_pass, resolve, view,
// total: median, min and max over the frames after the first) and its error against the reference's
// render of the same frame (error_metrics.hpp: optical path lengths per particle, and the image).
//
// The reference: exact sphere stand-ins, no cutoff, every particle updated every frame (groups 1), the
// over operator, transmittance threshold 0 (every layer composited). The sweeps change ONE knob of it:
//   shape        icosahedron (the thesis's), icosphere:1…3 (sphere = the reference)
//   cutoff       20, 40, 60, 80, 100, 120 hits (none = the reference)
//   groups       2, 4, 8, 16, 32 (1 = the reference): stale optical depths under the turning light
//   threshold    the compositor's early stop at transmittance 1/1024 … 0.2 (0 = the reference)
//   compositing  the thesis's eq. 4.1 (over = the reference)
// and a few combinations: the scene files' defaults (sphere, cutoff 60, threshold 1/255), the thesis's
// configuration (icosahedron, cutoff 60, eq. 4.1) and fast settings for the Pareto front.
//
// Errors are those of frame kEvalFrame = 32 (the thesis compares frame 32, 5.2.2: by then 32 groups have
// each been updated once); error_frames.csv has every frame's. All configurations advance in lockstep,
// frame by frame, in a rotating order, so that the shared machine's slow spells hit them alike.
//
// Outputs (results folder): error_sweeps.csv (one row per configuration), error_frames.csv, and
// images/: every configuration's frame 32 as PNG, the error heat maps of the thesis-like and the best
// configuration (raw float32, width × height, top row first) and grid.txt naming them (scripts/plot.sh).
//
// Section "scaling": the whole frame (scene defaults: sphere, cutoff 60, groups 1) for 250…1500
// particles (tables B.1/B.2), 10k and, in the full run, 100k; 1 thread and every thread; the growth
// exponent of each stage (log-log least squares). The 10k and 100k frames run without a cutoff, on tubes
// whose particle radius shrinks with the count (bench_util.hpp), so that their light rays cross about as
// many surfaces as at 750 instead of being cut off; the mean surfaces per ray is printed beside the times.
// Exponents are fitted over each kind of scene alone. scaling.csv.
#include "bench_registry.hpp"
#include "bench_util.hpp"
#include "error_metrics.hpp"
#include "pareto.hpp"
#include "timing.hpp"

#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/io/png_io.hpp>
#include <smoketrace/render/sixway_texture.hpp>
#include <smoketrace/io/sixway_files.hpp>

#include <tbb/info.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace smoketrace::bench {
namespace {

constexpr std::uint64_t kEvalFrame = 32;
// "Good enough" for the choice of the best configuration: image PSNR at least this (linear values, peak 1).
constexpr double kGoodPsnrDb = 40.0;

// The frame's stages (FrameTimings) and, sixth, "depth" = od_pass + resolve of the same frame: the
// optical-depth work that the shape, cutoff and groups knobs change.
const std::array<const char*, 6> kStageNames = {"tlas_update", "od_pass", "resolve", "view", "total", "depth"};
constexpr std::size_t kTotal = 4, kDepth = 5;

double stage_of(const FrameTimings& t, std::size_t k) {
    switch (k) {
        case 0: return t.tlas_update;
        case 1: return t.od_pass;
        case 2: return t.resolve;
        case 3: return t.view;
        case 4: return t.total;
        default: return t.od_pass + t.resolve;
    }
}

std::array<Stats, 6> stage_stats(const std::vector<FrameTimings>& samples) {
    std::array<Stats, 6> s;
    for (std::size_t k = 0; k < s.size(); ++k) {
        std::vector<double> v;
        for (const FrameTimings& t : samples) v.push_back(stage_of(t, k));
        s[k] = stats_of(v);
    }
    return s;
}

struct Config {
    std::string sweep, value;
    StandInShape shape{StandInKind::sphere, 0};
    std::uint32_t cutoff = 0;
    std::uint32_t groups = 1;
    float threshold = 0.0f;
    Compositing compositing = Compositing::over;

    // "sphere, cutoff none, groups 1, threshold 0, over"
    [[nodiscard]] std::string describe() const;
    [[nodiscard]] std::string id() const {
        std::string s = sweep + "_" + value;
        for (char& c : s)
            if (c == ':' || c == '/' || c == ' ' || c == '+' || c == '=') c = '-';
        return s;
    }
};

struct Run {
    Config config;
    std::unique_ptr<FrameRenderer> renderer;
    ImageRgba image;
    std::vector<FrameTimings> samples;  // frames 1…kEvalFrame
    PathLengthError depth;              // at kEvalFrame
    ImageError picture;
    std::array<Stats, 6> stages{};
    bool pareto = false;        // total time vs image RMSE
    bool pareto_depth = false;  // depth time vs transmittance error (configurations that change depths)
};

std::string threshold_name(float t) {
    if (t == 0.0f) return "0";
    std::ostringstream s;
    if (std::abs(1.0f / t - std::round(1.0f / t)) < 1e-3f * (1.0f / t)) s << "1/" << std::lround(1.0 / t);
    else s << t;
    return s.str();
}

std::string Config::describe() const {
    return shape.name() + ", cutoff " + (cutoff ? std::to_string(cutoff) : std::string("none")) + ", groups " +
           std::to_string(groups) + ", " +
           (compositing == Compositing::thesis ? std::string("eq. 4.1") : "over, threshold " + threshold_name(threshold));
}

std::vector<Config> configurations() {
    const Config ref{"reference", "exact"};
    std::vector<Config> c{ref};
    auto vary = [&](const std::string& sweep, const std::string& value, auto&& change) {
        Config k = ref;
        k.sweep = sweep;
        k.value = value;
        change(k);
        c.push_back(k);
    };
    vary("shape", "icosahedron", [](Config& k) { k.shape = {StandInKind::icosahedron, 0}; });
    for (int level = 1; level <= 3; ++level)
        vary("shape", "icosphere:" + std::to_string(level), [&](Config& k) { k.shape = {StandInKind::icosphere, level}; });
    for (std::uint32_t cutoff : {20u, 40u, 60u, 80u, 100u, 120u})
        vary("cutoff", std::to_string(cutoff), [&](Config& k) { k.cutoff = cutoff; });
    for (std::uint32_t groups : {2u, 4u, 8u, 16u, 32u})
        vary("groups", std::to_string(groups), [&](Config& k) { k.groups = groups; });
    for (float t : {1.0f / 1024, 1.0f / 255, 1.0f / 64, 0.05f, 0.1f, 0.2f})
        vary("threshold", threshold_name(t), [&](Config& k) { k.threshold = t; });
    vary("compositing", "eq4.1", [](Config& k) { k.compositing = Compositing::thesis; });
    // Combinations (not single error sources): what ships, what the thesis ran, and faster settings.
    vary("combined", "defaults", [](Config& k) {  // assets/scenes/*.json: sphere, cutoff 60, threshold 1/255
        k.cutoff = 60;
        k.threshold = 1.0f / 255;
    });
    vary("combined", "thesis", [](Config& k) {  // icosahedron, cutoff 60, eq. 4.1 (thesis 5.1-5.2)
        k.shape = {StandInKind::icosahedron, 0};
        k.cutoff = 60;
        k.compositing = Compositing::thesis;
    });
    vary("combined", "thesis+over", [](Config& k) {
        k.shape = {StandInKind::icosahedron, 0};
        k.cutoff = 60;
        k.threshold = 1.0f / 255;
    });
    vary("combined", "fast", [](Config& k) {
        k.cutoff = 60;
        k.groups = 4;
        k.threshold = 1.0f / 64;
    });
    vary("combined", "faster", [](Config& k) {
        k.cutoff = 40;
        k.groups = 8;
        k.threshold = 0.05f;
    });
    return c;
}

RenderOptions options_of(const SceneDescription& scene, const Config& c) {
    RenderOptions o = RenderOptions::from_scene(scene);
    o.shape = c.shape;
    o.render.cutoff = c.cutoff;
    o.render.groups = c.groups;
    o.render.transmittance_threshold = c.threshold;
    o.render.compositing = c.compositing;
    o.compositor = CompositorKind::one_traversal;
    o.sort = HitSort::adaptive;
    return o;
}

void write_float_map(const std::filesystem::path& path, const std::vector<float>& map) {
    write_output(path, [&](std::ostream& out) {
        out.write(reinterpret_cast<const char*>(map.data()), std::streamsize(map.size() * sizeof(float)));
    });
}

std::string fmt(double v, int precision = 3) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(precision) << v;
    return s.str();
}

void run_error(const BenchOptions& options) {
    // Quick: 160² (the whole program must stay under 3 minutes on 2 cores); full: the scene file's 512².
    const int size = options.quick ? 160 : 512;
    const SceneDescription scene = animated_scene(options, 750, size);
    const SixwayTexture& texture = bench_texture(options);
    std::vector<Run> runs;
    for (const Config& c : configurations()) {
        Run r;
        r.config = c;
        r.renderer = std::make_unique<FrameRenderer>(scene, options_of(scene, c), texture);
        runs.push_back(std::move(r));
    }
    std::cout << "  " << scene.smoke.particles.size() << " particles, " << size << "x" << size << ", light turning "
              << kLightDegreesPerFrame << " deg/frame about z, " << runs.size() << " configurations in lockstep, "
              << "frames 0.." << kEvalFrame << "; times: median [min, max] over frames 1.." << kEvalFrame
              << " (ms); errors at frame " << kEvalFrame << " against the reference\n"
              << std::flush;

    CsvFile frames_csv("config,frame,total_ms,image_rmse,image_psnr_db,opl_rel_mean,transmittance_mean,dark_mismatch");
    Run& ref = runs[0];
    for (std::uint64_t frame = 0; frame <= kEvalFrame; ++frame) {
        for (std::size_t k = 0; k < runs.size(); ++k) {
            Run& r = runs[(k + frame) % runs.size()];
            const FrameReport rep = r.renderer->render(frame, r.image);
            if (frame > 0) r.samples.push_back(rep.timings);
        }
        const float sigma_t = scene.smoke.sigma_t;
        for (Run& r : runs) {
            const PathLengthError d = path_length_error(r.renderer->depths().lengths(), ref.renderer->depths().lengths(), sigma_t);
            const ImageError p = image_error(r.image, ref.image);
            if (frame > 0)
                frames_csv.row(r.config.id(), frame, r.samples.back().total, p.rmse, p.psnr_db, d.rel_mean,
                               d.transmittance_mean, d.dark_mismatch());
            if (frame == kEvalFrame) {
                r.depth = d;
                r.picture = p;
            }
        }
    }
    for (Run& r : runs) r.stages = stage_stats(r.samples);

    // Pareto fronts: total time against image RMSE over every configuration; optical-depth time against
    // the transmittance error over the configurations that change optical depths (threshold and
    // compositing leave them exact and would only add the reference's depth time again, with its noise).
    std::vector<double> total(runs.size()), depth(runs.size()), rmse(runs.size()), terr(runs.size());
    std::vector<bool> all(runs.size(), true), changes_depth(runs.size());
    for (std::size_t i = 0; i < runs.size(); ++i) {
        total[i] = runs[i].stages[kTotal].median;
        depth[i] = runs[i].stages[kDepth].median;
        rmse[i] = runs[i].picture.rmse;
        terr[i] = runs[i].depth.transmittance_mean;
        changes_depth[i] = runs[i].config.sweep != "threshold" && runs[i].config.sweep != "compositing";
    }
    std::vector<bool> front, front_depth;
    mark_pareto(total, rmse, all, front);
    mark_pareto(depth, terr, changes_depth, front_depth);
    for (std::size_t i = 0; i < runs.size(); ++i) {
        runs[i].pareto = front[i];
        runs[i].pareto_depth = front_depth[i];
    }
    // The best configuration: the fastest (median total) whose image is good enough (PSNR >= kGoodPsnrDb);
    // it is on the front by construction. The reference itself if none is.
    std::size_t best = 0;
    for (std::size_t i = 1; i < runs.size(); ++i)
        if (runs[i].picture.psnr_db >= kGoodPsnrDb && (best == 0 || total[i] < total[best])) best = i;
    std::size_t thesis = 0, defaults = 0, groups32 = 0;
    for (std::size_t i = 0; i < runs.size(); ++i) {
        if (runs[i].config.id() == "combined_thesis") thesis = i;
        if (runs[i].config.id() == "combined_defaults") defaults = i;
        if (runs[i].config.id() == "groups_32") groups32 = i;
    }

    // ---- print, one table per sweep (the reference on top of each for context) ----
    std::string current;
    for (std::size_t i = 0; i < runs.size(); ++i) {
        const Run& r = runs[i];
        if (r.config.sweep != current) {
            current = r.config.sweep;
            std::cout << "  -- " << current << "\n"
                      << "  " << std::left << std::setw(22) << "value" << std::right << std::setw(24)
                      << "total [min, max]" << std::setw(8) << "tlas" << std::setw(8) << "od" << std::setw(8)
                      << "resolve" << std::setw(8) << "view" << std::setw(8) << "depth" << " |" << std::setw(9) << "l rel" << std::setw(9)
                      << "p99" << std::setw(9) << "max" << std::setw(6) << "dark" << std::setw(9) << "T err"
                      << " |" << std::setw(9) << "rmse" << std::setw(8) << "psnr" << "\n";
        }
        const auto& s = r.stages;
        std::ostringstream line;
        line << "  " << std::left << std::setw(22)
             << (r.config.value + (r.pareto ? " *" : "") + (r.pareto_depth ? " +" : "")) << std::right
             << std::setw(8) << fmt(s[4].median, 2) << " [" << std::setw(6) << fmt(s[4].min, 2) << ", "
             << std::setw(6) << fmt(s[4].max, 2) << "]" << std::setw(8) << fmt(s[0].median) << std::setw(8)
             << fmt(s[1].median) << std::setw(8) << fmt(s[2].median) << std::setw(8) << fmt(s[3].median, 2)
             << std::setw(8) << fmt(s[kDepth].median) << " |" << std::setw(9) << fmt(r.depth.rel_mean, 5) << std::setw(9) << fmt(r.depth.rel_p99, 4)
             << std::setw(9) << fmt(r.depth.rel_max, 4) << std::setw(6) << r.depth.dark_mismatch() << std::setw(9)
             << fmt(r.depth.transmittance_mean, 5) << " |" << std::setw(9) << fmt(r.picture.rmse, 5) << std::setw(8)
             << fmt(r.picture.psnr_db, 1) << "\n";
        std::cout << line.str();
    }
    std::cout << "  (* = on the Pareto front of total time vs image RMSE, + = of depth time (od + resolve) vs T err; l rel = mean relative optical-path-length "
                 "error, dark = particles fully dark in one run only, T err = mean |T - T_ref|; psnr in dB on "
                 "linear RGB, peak 1)\n";
    std::cout << "  best (fastest with PSNR >= " << kGoodPsnrDb << " dB): " << runs[best].config.sweep << " "
              << runs[best].config.value << " (" << runs[best].config.describe() << "), " << fmt(runs[best].stages[kTotal].median, 2) << " ms vs reference "
              << fmt(ref.stages[kTotal].median, 2) << " ms, PSNR " << fmt(runs[best].picture.psnr_db, 1) << " dB\n";

    // ---- CSV ----
    std::string header = "sweep,value,id,description,shape,cutoff,groups,threshold,compositing,frames";
    for (const char* st : kStageNames)
        header += std::string(",") + st + "_median," + st + "_min," + st + "_max";
    header += ",opl_abs_mean,opl_abs_p99,opl_abs_max,opl_rel_mean,opl_rel_p99,opl_rel_max,opl_compared,both_dark,"
              "false_dark,false_lit,dark_mismatch,transmittance_err_mean,transmittance_err_max,image_rmse,"
              "image_psnr_db,image_max_abs,pareto,pareto_depth,best";
    CsvFile csv(header);
    for (std::size_t i = 0; i < runs.size(); ++i) {
        const Run& r = runs[i];
        const auto& s = r.stages;
        const auto& d = r.depth;
        std::string description = r.config.describe();
        std::replace(description.begin(), description.end(), ',', ';');  // one CSV field
        csv.row(r.config.sweep, r.config.value, r.config.id(), description, r.config.shape.name(), r.config.cutoff,
                r.config.groups, r.config.threshold, to_string(r.config.compositing), r.samples.size(),
                s[0].median, s[0].min, s[0].max, s[1].median, s[1].min, s[1].max, s[2].median, s[2].min, s[2].max,
                s[3].median, s[3].min, s[3].max, s[4].median, s[4].min, s[4].max, s[5].median, s[5].min, s[5].max,
                d.abs_mean, d.abs_p99, d.abs_max,
                d.rel_mean, d.rel_p99, d.rel_max, d.compared, d.both_dark, d.false_dark, d.false_lit,
                d.dark_mismatch(), d.transmittance_mean, d.transmittance_max, r.picture.rmse, r.picture.psnr_db,
                r.picture.max_abs, int(r.pareto), int(r.pareto_depth), int(i == best));
    }
    const std::filesystem::path dir(options.results_dir);
    csv.write(dir / "error_sweeps.csv");
    frames_csv.write(dir / "error_frames.csv");

    // ---- images of frame kEvalFrame, heat maps and the grid's description ----
    const std::filesystem::path images = dir / "images";
    std::filesystem::create_directories(images);
    for (const Run& r : runs) write_png_srgb(images / (r.config.id() + ".png"), r.image);
    const std::vector<float> heat_thesis = pixel_error_map(runs[thesis].image, ref.image);
    const std::vector<float> heat_best = pixel_error_map(runs[best].image, ref.image);
    write_float_map(images / "heat_thesis.f32", heat_thesis);
    write_float_map(images / "heat_best.f32", heat_best);
    const float heat_max = std::max(*std::max_element(heat_thesis.begin(), heat_thesis.end()),
                                    *std::max_element(heat_best.begin(), heat_best.end()));
    write_output(images / "grid.txt", [&](std::ostream& out) {
        out << "size " << size << "\n"
            << "frame " << kEvalFrame << "\n"
            << "reference " << ref.config.id() << "\n"
            << "thesis " << runs[thesis].config.id() << " " << fmt(runs[thesis].picture.psnr_db, 1) << " "
            << fmt(runs[thesis].stages[kTotal].median, 2) << " " << runs[thesis].config.describe() << "\n"
            << "best " << runs[best].config.id() << " " << fmt(runs[best].picture.psnr_db, 1) << " "
            << fmt(runs[best].stages[kTotal].median, 2) << " " << runs[best].config.describe() << "\n"
            << "reference_ms " << fmt(ref.stages[kTotal].median, 2) << "\n"
            << "heat_max " << heat_max << "\n"
            << "best_heat_max " << *std::max_element(heat_best.begin(), heat_best.end()) << "\n";
    });

    report("error_reference_frame_ms", ref.stages[kTotal].median);
    report("error_defaults_psnr_db", runs[defaults].picture.psnr_db);
    report("error_defaults_speedup_vs_reference", ref.stages[kTotal].median / runs[defaults].stages[kTotal].median);
    report("error_thesis_psnr_db", runs[thesis].picture.psnr_db);
    report("error_thesis_opl_rel_p99", runs[thesis].depth.rel_p99);
    report("error_groups32_psnr_db", runs[groups32].picture.psnr_db);
    report("error_best_speedup_vs_reference", ref.stages[kTotal].median / runs[best].stages[kTotal].median);
    report("error_best_psnr_db", runs[best].picture.psnr_db);
}

// ---- scaling --------------------------------------------------------------------------------------------

void run_scaling(const BenchOptions& options) {
    std::vector<std::uint32_t> counts = {250, 500, 750, 1000, 1250, 1500, 10'000};
    if (!options.quick) counts.push_back(100'000);
    const int size = 256;
    const int all_threads = tbb::info::default_concurrency();
    std::vector<int> thread_counts = {1};
    if (all_threads > 1) thread_counts.push_back(all_threads);
    std::vector<std::unique_ptr<tbb::task_arena>> arenas;
    for (int t : thread_counts) arenas.push_back(std::make_unique<tbb::task_arena>(t));
    const SixwayTexture& texture = bench_texture(options);

    std::cout << "  whole frames of the animated scene, scene defaults (sphere, cutoff 60, groups 1, threshold 1/255), "
              << size << "x" << size << ";\n  from " << kLargeSceneFrom
              << " particles on no cutoff and radius 0.35*sqrt(750/N); ms, median over frames 1..n (frame 0, the "
                 "first build, excluded);\n  1 thread and "
              << all_threads << " threads alternate frame by frame; surfaces per light ray (a cut-off ray counts\n"
              << "  cutoff + 1) and rays cut off, in the last frame\n";
    std::cout << "  " << std::setw(7) << "count" << std::setw(4) << "thr";
    for (const char* st : kStageNames) std::cout << std::setw(12) << st;
    std::cout << std::setw(10) << "surf/ray" << std::setw(9) << "cut off" << "\n";

    CsvFile csv([] {
        std::string h = "particles,radius,cutoff,threads,size,frames";
        for (const char* st : kStageNames) h += std::string(",") + st + "_median," + st + "_min," + st + "_max";
        return h + ",hits_per_ray,cut_off";
    }());
    // fit[thread index][stage] = medians over counts
    std::vector<std::array<std::vector<double>, 6>> fit(thread_counts.size());
    std::vector<double> fit_counts;
    double total_750[2] = {0, 0};
    double largest_hits_per_ray = 0;
    for (const std::uint32_t n : counts) {
        const SceneDescription scene = animated_scene(options, n, size);
        RenderOptions o = RenderOptions::from_scene(scene);
        o.width = o.height = size;
        const int frames = n >= 100'000 ? 2 : n >= 10'000 ? 3 : options.quick ? 6 : std::max(options.repeats, 10);
        std::vector<std::unique_ptr<FrameRenderer>> renderers;
        std::vector<ImageRgba> images(thread_counts.size());
        std::vector<std::vector<FrameTimings>> samples(thread_counts.size());
        for (std::size_t t = 0; t < thread_counts.size(); ++t)
            renderers.push_back(std::make_unique<FrameRenderer>(scene, o, texture));
        for (int f = 0; f <= frames; ++f)
            for (std::size_t k = 0; k < thread_counts.size(); ++k) {
                const std::size_t t = (k + std::size_t(f)) % thread_counts.size();
                FrameReport rep;
                arenas[t]->execute([&] { rep = renderers[t]->render(std::uint64_t(f), images[t]); });
                if (f > 0) samples[t].push_back(rep.timings);
            }
        fit_counts.push_back(n);
        const float radius = scene.smoke.tubes->particle_radius;
        for (std::size_t t = 0; t < thread_counts.size(); ++t) {
            const auto s = stage_stats(samples[t]);
            const OpticalPathLengths& depths = renderers[t]->depths();
            std::size_t cut_off = 0;
            for (const DepthStatus st : depths.status()) cut_off += st == DepthStatus::cutoff;
            const double hits_per_ray = mean_of(depths.hit_counts());
            std::ostringstream line;
            line << "  " << std::setw(7) << n << std::setw(4) << thread_counts[t];
            for (const Stats& st : s) line << std::setw(12) << fmt(st.median);
            line << std::setw(10) << fmt(hits_per_ray, 2) << std::setw(9) << cut_off;
            std::cout << line.str() << "\n" << std::flush;
            csv.row(n, radius, o.render.cutoff, thread_counts[t], size, samples[t].size(), s[0].median, s[0].min,
                    s[0].max, s[1].median, s[1].min, s[1].max, s[2].median, s[2].min, s[2].max, s[3].median, s[3].min,
                    s[3].max, s[4].median, s[4].min, s[4].max, s[5].median, s[5].min, s[5].max, hits_per_ray, cut_off);
            if (n == counts.back()) largest_hits_per_ray = hits_per_ray;
            for (std::size_t k = 0; k < s.size(); ++k) fit[t][k].push_back(s[k].median);
            if (n == 750) total_750[t] = s[kTotal].median;
        }
    }
    csv.write(std::filesystem::path(options.results_dir) / "scaling.csv");

    // Growth exponents over each kind of scene alone: the thesis's 250…1500 (radius kept, cutoff 60: the
    // surfaces per ray grow with the count) and the large counts (radius shrunk, no cutoff: about as many
    // surfaces per ray at every count), the latter only with two counts or more (the full run).
    std::cout << "  growth exponent b of ms ~ count^b (log-log least squares):\n";
    const auto b1_end = std::size_t(std::find_if(counts.begin(), counts.end(), [](std::uint32_t n) {
                                        return n >= kLargeSceneFrom;
                                    }) - counts.begin());
    auto part = [](const std::vector<double>& v, std::size_t from, std::size_t to) {
        return std::vector<double>(v.begin() + std::ptrdiff_t(from), v.begin() + std::ptrdiff_t(to));
    };
    const bool large_fit = counts.size() - b1_end >= 2;
    std::array<double, 6> b1_exponent{}, large_exponent{};
    for (std::size_t t = 0; t < thread_counts.size(); ++t) {
        std::ostringstream small, large;
        small << "    " << thread_counts[t] << " thr, 250..1500 (cutoff 60):";
        large << "    " << thread_counts[t] << " thr, " << counts[b1_end] << ".." << counts.back() << " (no cutoff):";
        for (std::size_t k = 0; k < kStageNames.size(); ++k) {
            const double e1 = fit_exponent(part(fit_counts, 0, b1_end), part(fit[t][k], 0, b1_end));
            const double e2 =
                fit_exponent(part(fit_counts, b1_end, counts.size()), part(fit[t][k], b1_end, counts.size()));
            small << "  " << kStageNames[k] << " " << fmt(e1, 2);
            large << "  " << kStageNames[k] << " " << fmt(e2, 2);
            if (t + 1 == thread_counts.size()) {
                b1_exponent[k] = e1;
                large_exponent[k] = e2;
            }
        }
        std::cout << small.str() << "\n";
        if (large_fit) std::cout << large.str() << "\n";
    }
    report("scaling_exponent_total_b1", b1_exponent[kTotal]);
    report("scaling_exponent_od_pass_b1", b1_exponent[1]);
    report("scaling_exponent_view_b1", b1_exponent[3]);
    if (large_fit) {
        report("scaling_exponent_total_large", large_exponent[kTotal]);
        report("scaling_exponent_od_pass_large", large_exponent[1]);
    }
    report("scaling_hits_per_ray_" + std::to_string(counts.back() / 1000) + "k", largest_hits_per_ray);
    report("frame_ms_750", total_750[thread_counts.size() - 1]);
    if (thread_counts.size() > 1) report("frame_thread_speedup_750", total_750[0] / total_750[1]);
}

const RegisterSection kErrorSection{{"error",
                                     "run time against error: exact reference, sweeps of stand-in shape, cutoff, "
                                     "groups, compositor threshold, eq. 4.1 vs over",
                                     &run_error, true}};
const RegisterSection kScalingSection{{"scaling",
                                       "whole-frame stage times vs particle count (250..1500, 10k, 100k), 1 and all "
                                       "threads, growth exponents",
                                       &run_scaling, true}};

}  // namespace
}  // namespace smoketrace::bench
