// Bench section "truth": run time against error, the error measured against the ground truth (the volume
// the frame depicts, rendered converged by truth/ground_truth.hpp), not against the project's own model.
//
// Scenes: the shipped two_tubes_above.json and two_tubes_right.json (frame 0) and frame kSequenceFrame of
// two_tubes_sequence.json (the thesis compares frame 32, 5.2.2; the scene's motion and turning light go on
// past its 24 frames), at 256² (kTruthSize; SMOKETRACE_TRUTH_SIZE=512 for a larger run; with --quick the
// sequence's frame alone, 32², against a coarse truth: kQuickTruthSize and compute_truth()).
// The truth of each is rendered once per run; its time and its error bound are printed.
//
// Configurations: the scene file's own settings, then ONE knob changed at a time: render mode, stand-in
// shape, cutoff, particle groups (the sequence only: in a still scene every particle is traced at frame 0),
// samples per pixel, compositing rule and transmittance threshold; and named rows: the thesis's settings
// (icosahedron, cutoff 60, one group, eq. 4.1, one sample), the project's own exact model (spheres, no
// cutoff, one group, threshold 0, 16 samples: the `error` section's reference) and the scene's settings
// drawn with the true optical depth of each particle instead of the stand-ins' l·σt, as are the own exact
// model's (the first approximation put back to its exact form; not configurations one can ship: they need
// the truth).
//
// Timing: each repeat builds a fresh FrameRenderer (untimed), brings it to the frame (skip_to, untimed) and
// times render(frame), its stages from FrameTimings; the configurations take turns repeat by repeat in a
// rotating order so that the shared machine's slow spells hit them alike; medians are reported.
//
// Errors against the truth (image_metrics.hpp): RMSE and PSNR (peak 1) on linear RGB; SSIM on the luma of
// the sRGB images; RMSE and PSNR inside the truth's ground-shadow mask alone; per-particle transmittance
// |exp(−σt·l) − exp(−τ_true)| (modes that trace optical depths).
//
// Outputs (results folder): truth_sweeps.csv (one row per scene × configuration), images/truth_SCENE.png
// (the truth), images/truth_SCENE_ID.png and images/truth_heat_SCENE_ID.f32 (raw float32, width × height,
// top row first: per-pixel RMS error) for the scene's settings, the thesis's and the best row at the
// thesis's frame time, and images/truth_grid.txt naming them (scripts/plot.sh).
#include "bench_registry.hpp"
#include "bench_util.hpp"
#include "image_metrics.hpp"
#include "pareto.hpp"
#include "timing.hpp"

#include <smoketrace/io/png_io.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/io/sixway_files.hpp>
#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/render/puff_density.hpp>
#include <smoketrace/render/sixway_texture.hpp>
#include <smoketrace/render/view_compositor.hpp>
#include <smoketrace/truth/ground_truth.hpp>

#include <algorithm>
#include <array>
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
#include <stdexcept>
#include <string>
#include <vector>

namespace smoketrace::bench {
namespace {

constexpr int kTruthSize = 256;
constexpr int kQuickTruthSize = 32;
constexpr std::uint64_t kSequenceFrame = 32;

struct TruthScene {
    const char* name;
    const char* file;
    std::uint64_t frame;
};
constexpr std::array<TruthScene, 3> kScenes = {{{"above", "two_tubes_above.json", 0},
                                                {"right", "two_tubes_right.json", 0},
                                                {"sequence", "two_tubes_sequence.json", kSequenceFrame}}};

// What the configurations are measured against.
struct Truth {
    ImageRgba image;                     // linear radiance
    std::vector<double> tau;             // each particle's optical depth toward the light
    std::vector<std::uint8_t> shadow;    // 1 = ground pixel in the smoke's shadow
    double seconds = 0;                  // all of it: the volume, the image, the depths and the mask
    double render_seconds = 0;           // GroundTruth::render() alone
    double bound = 0;                    // the renderer's error estimate (max over pixels)
    std::uint64_t unconverged = 0;
    std::array<ImageRgba, kTruthRungs> rungs;  // the ladder (GroundTruth::render_ladder)
    LadderReport ladder;
};

// Where a configuration's image comes from: a frame the renderer draws (its optical depths traced, or the
// true ones put in), or a rung of the truth's ladder (TruthRung), which only the truth renderer can draw.
enum class Depths : std::uint8_t { traced, true_tau, rung };

struct Config {
    std::string sweep, value;
    RenderOptions options;
    Depths depths = Depths::traced;
    TruthRung rung = TruthRung::one_transmittance;  // Depths::rung's
    float alpha = -1.0f;                            // >= 0: the scene's alpha replaced (Depths::true_tau)
    [[nodiscard]] std::string id() const {
        std::string s = sweep + "_" + value;
        for (char& c : s)
            if (c == ':' || c == '/' || c == ' ' || c == '+' || c == '=' || c == '.') c = '-';
        return s;
    }
    [[nodiscard]] bool shippable() const { return depths == Depths::traced; }
    [[nodiscard]] bool ladder() const { return depths == Depths::rung; }
};

std::string threshold_name(float t) {
    if (t == 0.0f) return "0";
    std::ostringstream s;
    if (std::abs(1.0f / t - std::round(1.0f / t)) < 1e-3f * (1.0f / t)) s << "1/" << std::lround(1.0 / t);
    else s << t;
    return s.str();
}

std::string describe(const RenderOptions& o) {
    const RenderSettings& r = o.render;
    return std::string(to_string(r.mode)) + ", " + o.shape.name() + ", " + o.kernel.name() + ", cutoff " +
           (r.cutoff ? std::to_string(r.cutoff) : std::string("none")) + ", groups " + std::to_string(r.groups) +
           ", spp " + std::to_string(r.spp) + ", " +
           (r.compositing == Compositing::thesis ? std::string("eq. 4.1") : std::string("over")) + ", threshold " +
           threshold_name(r.transmittance_threshold);
}

// The scene's settings, then one knob at a time (values equal to the scene's are left out), then the named rows.
std::vector<Config> configurations(const RenderOptions& scene, bool animated) {
    std::vector<Config> c{{"scene", "defaults", scene}};
    auto vary = [&](const std::string& sweep, const std::string& value, auto&& change) {
        Config k{sweep, value, scene};
        change(k.options);
        if (sweep != "named" && describe(k.options) == describe(scene)) return;
        c.push_back(k);
    };
    vary("mode", "basic", [](RenderOptions& o) { o.render.mode = RenderMode::basic; });
    vary("mode", "simple-shadow", [](RenderOptions& o) { o.render.mode = RenderMode::simple_shadow; });
    vary("shape", "sphere", [](RenderOptions& o) { o.shape = {StandInKind::sphere, 0}; });
    vary("shape", "icosahedron", [](RenderOptions& o) { o.shape = {StandInKind::icosahedron, 0}; });
    for (int level = 1; level <= 3; ++level)
        vary("shape", "icosphere:" + std::to_string(level), [&](RenderOptions& o) { o.shape = {StandInKind::icosphere, level}; });
    for (const DensityKernelKind kind : {DensityKernelKind::uniform, DensityKernelKind::gaussian, DensityKernelKind::poly1,
                                         DensityKernelKind::poly2})
        vary("kernel", density_kernel(kind).name(), [&](RenderOptions& o) { o.kernel = density_kernel(kind); });
    vary("cutoff", "none", [](RenderOptions& o) { o.render.cutoff = 0; });
    for (std::uint32_t cutoff : {20u, 40u, 60u, 80u, 120u})
        vary("cutoff", std::to_string(cutoff), [&](RenderOptions& o) { o.render.cutoff = cutoff; });
    if (animated)
        for (std::uint32_t groups : {1u, 2u, 4u, 8u, 16u, 32u})
            vary("groups", std::to_string(groups), [&](RenderOptions& o) { o.render.groups = groups; });
    for (std::uint32_t spp : {1u, 4u, 16u})
        vary("spp", std::to_string(spp), [&](RenderOptions& o) { o.render.spp = spp; });
    vary("compositing", "eq4.1", [](RenderOptions& o) { o.render.compositing = Compositing::thesis; });
    for (float t : {0.0f, 1.0f / 255, 1.0f / 64, 0.05f})
        vary("threshold", threshold_name(t), [&](RenderOptions& o) { o.render.transmittance_threshold = t; });
    // The thesis's settings (5.1-5.2): icosahedron stand-ins (DXR traces triangles), cutoff 60, every
    // particle every frame, its compositing rule, one sample per pixel.
    vary("named", "thesis", [](RenderOptions& o) {
        o.shape = {StandInKind::icosahedron, 0};
        o.kernel = kUniformKernel;
        o.render.cutoff = 60;
        o.render.groups = 1;
        o.render.compositing = Compositing::thesis;
        o.render.spp = 1;
    });
    // The project's most exact own model (the `error` section's reference, with 16 samples per pixel).
    vary("named", "own-exact", [](RenderOptions& o) {
        o.shape = {StandInKind::sphere, 0};
        o.kernel = kUniformKernel;
        o.render.cutoff = 0;
        o.render.groups = 1;
        o.render.transmittance_threshold = 0.0f;
        o.render.compositing = Compositing::over;
        o.render.spp = 16;
    });
    // Approximation (a) put back to its exact form: the scene's settings, and the own exact model, drawn with
    // each particle's true optical depth. What is left is the billboard's: one transmittance per billboard,
    // the six-way light map, the billboard instead of the volume.
    // The true-τ frames keep the thesis's ground shadow (eq. 4.3: the nearest particle's transmittance, here
    // its true one), whatever kernel the scene has: the ladder's rungs shade the ground so.
    RenderOptions thesis_shadow = scene;
    thesis_shadow.kernel = kUniformKernel;
    c.push_back({"exact", "true-tau", thesis_shadow, Depths::true_tau});
    Config exact_all = *std::find_if(c.begin(), c.end(), [](const Config& k) { return k.value == "own-exact"; });
    exact_all.sweep = "exact";
    exact_all.value = "true-tau+own-exact";
    exact_all.depths = Depths::true_tau;
    exact_all.options.kernel = kUniformKernel;
    c.push_back(exact_all);
    // The ladder (docs/ground-truth.md): from the truth, the frame's approximations of the light put in one at a
    // time, each rung keeping the ones before it; then the billboards with the true τ (exact true-tau) and the
    // frame (scene defaults) are the last two rungs.
    for (int r = 0; r < kTruthRungs; ++r) {
        Config k{"ladder", to_string(TruthRung(r)), scene, Depths::rung};
        k.rung = TruthRung(r);
        c.push_back(k);
    }
    // The billboards with the true τ and the scene's alpha matched to the volume's opacity: how much of the
    // billboard's error is the opacity the scene gives it (alpha filled in by run_truth()).
    Config matched{"exact", "true-tau+matched-alpha", thesis_shadow, Depths::true_tau};
    matched.alpha = 0.0f;
    c.push_back(matched);
    return c;
}

struct Run {
    Config config;
    ImageRgba image;
    std::vector<float> lengths;  // the optical path lengths the frame was drawn with
    std::vector<FrameTimings> samples;
    std::array<Stats, 5> stages{};  // tlas_update, od_pass, resolve, view, total
    ImageError picture;
    double ssim = 0;
    MaskedImageError shadow;
    TransmittanceError transmittance;
    bool has_depths = false;
    bool pareto = false;
};

std::string fmt(double v, int precision = 3) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(precision) << v;
    return s.str();
}

// The frame of `options` at `frame` from a fresh renderer: the timings of render(frame) alone.
FrameTimings render_once(const SceneDescription& scene, const RenderOptions& options, const SixwayTexture& texture,
                         std::uint64_t frame, ImageRgba& image, std::vector<float>* lengths) {
    FrameRenderer renderer(scene, options, texture);
    renderer.skip_to(frame);
    const FrameTimings t = renderer.render(frame, image).timings;
    if (lengths) *lengths = renderer.depths().lengths();
    return t;
}

// The scene's settings drawn with each particle's true optical depth (l = τ / σt) in place of the
// stand-ins' traced l: what the frame would be if approximation (a) were exact.
void render_with_true_depths(const SceneDescription& scene, const RenderOptions& options,
                             const SixwayTexture& texture, std::uint64_t frame, const std::vector<double>& tau,
                             ImageRgba& image, std::vector<float>& lengths) {
    FrameRenderer renderer(scene, options, texture);
    renderer.skip_to(frame);
    ImageRgba ignored;
    renderer.render(frame, ignored);  // brings particles, light and TLAS to the frame
    lengths.resize(tau.size());
    for (std::size_t i = 0; i < tau.size(); ++i) lengths[i] = float(tau[i] / double(scene.smoke.sigma_t));
    render_view(renderer.smoke(), renderer.particles().particles(), lengths, texture, renderer.camera(),
                renderer.view_settings(frame), image);
}

Truth compute_truth(const SceneDescription& scene, std::uint64_t frame, int size, bool quick,
                    const SixwayBakeSettings& puff);

int truth_size(const BenchOptions& options) {
    if (options.quick) return kQuickTruthSize;
    if (const char* s = std::getenv("SMOKETRACE_TRUTH_SIZE")) {
        const int n = std::atoi(s);
        if (n >= 16 && n <= 4096 && std::to_string(n) == s) return n;
        std::cerr << "smoketrace_bench: SMOKETRACE_TRUTH_SIZE='" << s << "' is not a whole number in 16..4096\n";
        std::exit(2);
    }
    return kTruthSize;
}

const SixwayBakeSettings& bake_settings(const BenchOptions& options) {
    static const SixwayBakeSettings puff = read_sixway_bake_settings(options.assets / "sixway.json");
    return puff;
}

// The scene alpha that gives the billboards the volume's mean opacity: over every texel column of every
// flipbook frame, the volume's opacity 1 − e^{−σt·r·∫ρ dz} (r the particles' mean radius) against the
// texture's, 1 − e^{−extinction·∫ρ dz} (the bake's alpha, before 8-bit rounding), ratio of the sums.
float matched_alpha(const SceneDescription& scene, const SixwayBakeSettings& bake) {
    const PuffVoxels g(bake);
    double radius = 0.0;
    for (const Particle& p : scene.smoke.particles) radius += double(p.radius);
    radius /= double(std::max<std::size_t>(1, scene.smoke.particles.size()));
    double volume = 0.0, texture = 0.0;
    std::vector<float> density;
    for (int f = 0; f < bake.frames; ++f) {
        sample_puff_density(bake, g, f, density);
        for (int j = 0; j < g.n; ++j)
            for (int i = 0; i < g.n; ++i) {
                double column = 0.0;
                for (int k = 0; k < g.nz; ++k) column += double(density[g.index(k, j, i)]) * double(g.dz);
                volume += -std::expm1(-double(scene.smoke.sigma_t) * radius * column);
                texture += -std::expm1(-double(bake.extinction) * column);
            }
    }
    return texture > 0.0 ? float(volume / texture) : scene.smoke.alpha;
}

void write_float_map(const std::filesystem::path& path, const std::vector<float>& map) {
    write_output(path, [&](std::ostream& out) {
        out.write(reinterpret_cast<const char*>(map.data()), std::streamsize(map.size() * sizeof(float)));
    });
}

void run_truth(const BenchOptions& options) {
    const int size = truth_size(options);
    const std::filesystem::path dir(options.results_dir), images = dir / "images";
    std::filesystem::create_directories(images);
    std::string header =
        "scene,frame,size,sweep,value,id,description,mode,shape,cutoff,groups,spp,compositing,threshold,repeats";
    for (const char* st : {"tlas_update", "od_pass", "resolve", "view", "total"})
        header += std::string(",") + st + "_median," + st + "_min," + st + "_max";
    header += ",image_rmse,image_psnr_db,image_max_abs,ssim,shadow_pixels,shadow_rmse,shadow_psnr_db,"
              "transmittance_err_mean,transmittance_err_max,transmittance_err_rms,truth_seconds,truth_bound,"
              "pareto,best_at_thesis_time";
    CsvFile csv(header);
    std::ostringstream grid;
    grid << "size " << size << "\n";

    for (const TruthScene& ts : kScenes) {
        // --quick: the sequence's frame alone (its particle depths take ~10 s whatever the image size).
        if (options.quick && ts.frame == 0) continue;
        SceneDescription scene = bench_scene_file(options, ts.file);
        scene.camera.width = scene.camera.height = std::uint32_t(size);
        const RenderOptions defaults = RenderOptions::from_scene(scene);
        const bool animated = ts.frame > 0;

        const Truth truth = compute_truth(scene, ts.frame, size, options.quick, bake_settings(options));
        std::cout << "  -- " << ts.name << " (" << ts.file << ", frame " << ts.frame << ", " << size << "x" << size
                  << ", " << scene.smoke.particles.size() << " particles): truth " << fmt(truth.seconds, 1)
                  << " s (render " << fmt(truth.render_seconds, 1) << " s), error bound " << truth.bound << ", unconverged pixels " << truth.unconverged << "\n"
                  << std::flush;

        std::vector<Run> runs;
        for (const Config& c : configurations(defaults, animated)) {
            Run r;
            r.config = c;
            runs.push_back(std::move(r));
        }
        for (int rep = 0; rep < options.repeats; ++rep)
            for (std::size_t k = 0; k < runs.size(); ++k) {
                Run& r = runs[(k + std::size_t(rep)) % runs.size()];
                if (!r.config.shippable()) continue;
                r.samples.push_back(
                    render_once(scene, r.config.options, bench_texture(options), ts.frame, r.image, &r.lengths));
            }
        const float alpha_matched = matched_alpha(scene, bake_settings(options));
        for (Run& r : runs) {
            if (r.config.depths == Depths::true_tau) {
                SceneDescription drawn = scene;
                if (r.config.alpha >= 0.0f) drawn.smoke.alpha = alpha_matched;
                render_with_true_depths(drawn, r.config.options, bench_texture(options), ts.frame, truth.tau, r.image,
                                        r.lengths);
            }
            if (r.config.ladder()) r.image = truth.rungs[std::size_t(r.config.rung)];
            for (std::size_t k = 0; k < 5; ++k) {
                std::vector<double> v;
                for (const FrameTimings& t : r.samples)
                    v.push_back(k == 0 ? t.tlas_update : k == 1 ? t.od_pass : k == 2 ? t.resolve : k == 3 ? t.view : t.total);
                r.stages[k] = stats_of(v);
            }
            r.picture = image_error(r.image, truth.image);
            r.ssim = ssim_srgb(r.image, truth.image);
            if (!truth.shadow.empty()) r.shadow = masked_image_error(r.image, truth.image, truth.shadow);
            r.has_depths = r.config.options.render.mode != RenderMode::basic && !truth.tau.empty() && !r.config.ladder();
            if (r.has_depths) r.transmittance = transmittance_error(r.lengths, scene.smoke.sigma_t, truth.tau);
        }

        // The front of total time against image RMSE over the configurations one can ship; the best
        // setting at the thesis's frame time: the most accurate whose median time is at most the thesis's.
        std::vector<double> total(runs.size()), rmse(runs.size());
        std::vector<bool> candidate(runs.size());
        auto index_of = [&](const std::string& id) {
            for (std::size_t i = 0; i < runs.size(); ++i)
                if (runs[i].config.id() == id) return i;
            throw std::logic_error("truth: no configuration " + id);
        };
        const std::size_t scene_row = 0, uniform_row = defaults.kernel.smooth() ? index_of("kernel_uniform") : scene_row,
                          thesis = index_of("named_thesis"), own_exact = index_of("named_own-exact"),
                          true_tau = index_of("exact_true-tau"), true_tau_exact = index_of("exact_true-tau-own-exact");
        for (std::size_t i = 0; i < runs.size(); ++i) {
            total[i] = runs[i].stages[4].median;
            rmse[i] = runs[i].picture.rmse;
            candidate[i] = runs[i].config.shippable();
        }
        std::vector<bool> front;
        mark_pareto(total, rmse, candidate, front);
        std::size_t best = thesis;
        for (std::size_t i = 0; i < runs.size(); ++i) {
            runs[i].pareto = front[i];
            if (candidate[i] && total[i] <= total[thesis] && rmse[i] < rmse[best]) best = i;
        }

        std::cout << "  " << std::left << std::setw(30) << "configuration" << std::right << std::setw(24)
                  << "total ms [min, max]" << std::setw(8) << "od" << std::setw(8) << "view" << " |" << std::setw(9)
                  << "rmse" << std::setw(7) << "psnr" << std::setw(7) << "ssim" << std::setw(8) << "shadow" << std::setw(9)
                  << "T err" << std::setw(8) << "T max" << "\n";
        for (std::size_t i = 0; i < runs.size(); ++i) {
            const Run& r = runs[i];
            const auto& s = r.stages;
            std::ostringstream line;
            line << "  " << std::left << std::setw(30)
                 << (r.config.sweep + " " + r.config.value + (r.pareto ? " *" : "") + (i == best ? " B" : "")) << std::right;
            if (r.config.shippable())
                line << std::setw(8) << fmt(s[4].median, 2) << " [" << std::setw(6) << fmt(s[4].min, 2) << ", "
                     << std::setw(6) << fmt(s[4].max, 2) << "]" << std::setw(8) << fmt(s[1].median + s[2].median)
                     << std::setw(8) << fmt(s[3].median, 2);
            else
                line << std::setw(24) << "(needs the truth)" << std::setw(16) << "";
            line << " |" << std::setw(9) << fmt(r.picture.rmse, 5) << std::setw(7) << fmt(r.picture.psnr_db, 1)
                 << std::setw(7) << fmt(r.ssim, 3) << std::setw(8)
                 << (truth.shadow.empty() ? std::string("-") : fmt(r.shadow.error.psnr_db, 1)) << std::setw(9)
                 << (r.has_depths ? fmt(r.transmittance.mean, 4) : std::string("-")) << std::setw(8)
                 << (r.has_depths ? fmt(r.transmittance.max, 3) : std::string("-")) << "\n";
            std::cout << line.str();
        }
        std::cout << "  (* = on the Pareto front of total time vs image RMSE, B = most accurate at most the thesis's "
                     "time; psnr in dB on linear RGB, peak 1; ssim on sRGB luma; shadow = PSNR inside the "
                     "truth's ground shadow ("
                  << runs[0].shadow.pixels << " of " << truth.shadow.size()
                  << " pixels); T err/max = |exp(-l sigma_t) - exp(-tau_true)| over particles)\n"
                  << "  best at the thesis's frame time (" << fmt(total[thesis], 2) << " ms): " << runs[best].config.sweep
                  << " " << runs[best].config.value << " (" << describe(runs[best].config.options) << "), "
                  << fmt(total[best], 2) << " ms, PSNR " << fmt(runs[best].picture.psnr_db, 1) << " dB against the thesis's "
                  << fmt(runs[thesis].picture.psnr_db, 1) << " dB\n"
                  << std::flush;

        // The ladder, truth to frame: each rung's error against the truth and what its one approximation adds to
        // the squared error (MSE, linear RGB) of the rung before.
        {
            const std::vector<std::pair<const char*, std::size_t>> chain = {
                {"(b) one transmittance per particle", index_of("ladder_one-transmittance")},
                {"    eq. 4.2's light map x e^-tau(centre)", index_of("ladder_light-map")},
                {"(d) six axis lights", index_of("ladder_six-axis")},
                {"    the bake's extinction", index_of("ladder_bake-extinction")},
                {"(c) billboards (the true tau)", true_tau},
                {"(a) the stand-ins' tau: the thesis's balls", uniform_row}};
            std::cout << "  ladder (truth " << fmt(truth.ladder.seconds, 1) << " s; view steps " << truth.ladder.view_error_estimate
                      << ", own light volumes' estimate " << truth.ladder.own_light_error_estimate << ", unconverged "
                      << truth.ladder.unconverged_pixels << "):\n";
            double previous = 0.0;
            for (const auto& [name, i] : chain) {
                const double mse = runs[i].picture.rmse * runs[i].picture.rmse;
                std::cout << "    " << std::left << std::setw(42) << name << std::right << " psnr " << std::setw(5)
                          << fmt(runs[i].picture.psnr_db, 1) << "  shadow " << std::setw(5)
                          << (truth.shadow.empty() ? std::string("-") : fmt(runs[i].shadow.error.psnr_db, 1)) << "  mse "
                          << fmt(mse, 5) << " (+" << fmt(mse - previous, 5) << ")\n";
                previous = mse;
            }
            // The soft stand-ins in place of (a): each kernel's frame, the rest of the scene's settings kept.
            for (const DensityKernelKind kind : {DensityKernelKind::gaussian, DensityKernelKind::poly1, DensityKernelKind::poly2}) {
                const std::string name = density_kernel(kind).name();
                const std::size_t i = defaults.kernel.kind == kind ? scene_row : index_of("kernel_" + name);
                const double mse = runs[i].picture.rmse * runs[i].picture.rmse;
                std::cout << "    " << std::left << std::setw(42) << ("    instead, the " + name + " kernel") << std::right
                          << " psnr " << std::setw(5) << fmt(runs[i].picture.psnr_db, 1) << "  shadow " << std::setw(5)
                          << (truth.shadow.empty() ? std::string("-") : fmt(runs[i].shadow.error.psnr_db, 1)) << "  mse "
                          << fmt(mse, 5) << "\n";
            }
            std::cout << "    matched alpha " << fmt(alpha_matched, 3) << " (scene " << fmt(scene.smoke.alpha, 3)
                      << "): billboards with the true tau at it, psnr "
                      << fmt(runs[index_of("exact_true-tau-matched-alpha")].picture.psnr_db, 1) << "\n"
                      << std::flush;
            // Issue 33's targets, each kernel against the thesis's balls with the rest of the scene's settings:
            // the ground shadow's RMSE and the particles' mean transmittance error, both as ratios, and the time.
            for (const DensityKernelKind kind : {DensityKernelKind::gaussian, DensityKernelKind::poly1, DensityKernelKind::poly2}) {
                const std::string name = density_kernel(kind).name();
                const std::size_t i = defaults.kernel.kind == kind ? scene_row : index_of("kernel_" + name);
                const Run &k = runs[i], &u = runs[uniform_row];
                const double shadow_ratio = truth.shadow.empty() ? 0.0 : k.shadow.error.rmse / u.shadow.error.rmse;
                const double t_ratio = k.has_depths && u.has_depths ? k.transmittance.mean / u.transmittance.mean : 0.0;
                const double time_ratio = k.stages[4].median / u.stages[4].median;
                std::cout << "    " << name << " / uniform: shadow rmse " << fmt(shadow_ratio, 3) << ", T err mean "
                          << fmt(t_ratio, 3) << ", frame time " << fmt(time_ratio, 3) << "\n";
                report("truth_kernel_" + name + "_shadow_rmse_over_uniform_" + std::string(ts.name), shadow_ratio);
                report("truth_kernel_" + name + "_transmittance_err_over_uniform_" + std::string(ts.name), t_ratio);
                report("truth_kernel_" + name + "_psnr_db_" + std::string(ts.name), k.picture.psnr_db);
            }
            for (const auto& [name, i] : chain)
                if (runs[i].config.ladder())
                    report("truth_ladder_psnr_db_" + runs[i].config.value + "_" + ts.name, runs[i].picture.psnr_db);
        }

        for (std::size_t i = 0; i < runs.size(); ++i) {
            const Run& r = runs[i];
            const RenderOptions& o = r.config.options;
            std::string description = describe(o);
            std::replace(description.begin(), description.end(), ',', ';');
            const auto& s = r.stages;
            csv.row(ts.name, ts.frame, size, r.config.sweep, r.config.value, r.config.id(), description,
                    to_string(o.render.mode), o.shape.name(), o.render.cutoff, o.render.groups, o.render.spp,
                    to_string(o.render.compositing), o.render.transmittance_threshold, r.samples.size(), s[0].median,
                    s[0].min, s[0].max, s[1].median, s[1].min, s[1].max, s[2].median, s[2].min, s[2].max, s[3].median,
                    s[3].min, s[3].max, s[4].median, s[4].min, s[4].max, r.picture.rmse, r.picture.psnr_db,
                    r.picture.max_abs, r.ssim, r.shadow.pixels, r.shadow.error.rmse, r.shadow.error.psnr_db,
                    r.has_depths ? r.transmittance.mean : 0.0, r.has_depths ? r.transmittance.max : 0.0,
                    r.has_depths ? r.transmittance.rms : 0.0, truth.seconds, truth.bound, int(r.pareto), int(i == best));
        }

        // Images: the truth, and the frames and error heat maps of the scene's settings, the thesis's and the best.
        const std::string prefix = std::string("truth_") + ts.name;
        write_png_srgb(images / (prefix + ".png"), truth.image);
        for (std::size_t i : {scene_row, thesis, best, true_tau}) {
            const std::string id = prefix + "_" + runs[i].config.id();
            write_png_srgb(images / (id + ".png"), runs[i].image);
            write_float_map(images / ("truth_heat_" + std::string(ts.name) + "_" + runs[i].config.id() + ".f32"),
                            pixel_error_map(runs[i].image, truth.image));
        }
        auto grid_line = [&](const char* role, std::size_t i) {
            grid << ts.name << " " << role << " " << runs[i].config.id() << " " << fmt(runs[i].picture.psnr_db, 1) << " "
                 << fmt(runs[i].stages[4].median, 2) << " " << describe(runs[i].config.options) << "\n";
        };
        grid << ts.name << " truth " << prefix << " " << fmt(truth.seconds, 1) << "\n";
        grid_line("scene", scene_row);
        grid_line("thesis", thesis);
        grid_line("best", best);
        grid_line("true_tau", true_tau);

        const std::string n = ts.name;
        report("truth_seconds_" + n, truth.seconds);
        report("truth_full_psnr_db_" + n, runs[scene_row].picture.psnr_db);
        report("truth_full_ssim_" + n, runs[scene_row].ssim);
        if (!truth.shadow.empty()) report("truth_full_shadow_psnr_db_" + n, runs[scene_row].shadow.error.psnr_db);
        report("truth_thesis_psnr_db_" + n, runs[thesis].picture.psnr_db);
        report("truth_own_exact_psnr_db_" + n, runs[own_exact].picture.psnr_db);
        report("truth_true_tau_psnr_db_" + n, runs[true_tau].picture.psnr_db);
        report("truth_true_tau_own_exact_psnr_db_" + n, runs[true_tau_exact].picture.psnr_db);
        report("truth_best_at_thesis_time_psnr_db_" + n, runs[best].picture.psnr_db);
    }
    csv.write(dir / "truth_sweeps.csv");
    const std::string g = grid.str();
    write_output(images / "truth_grid.txt", [&](std::ostream& out) { out << g; });
}

// ---- the truth ------------------------------------------------------------------------------------------

Truth compute_truth(const SceneDescription& scene, std::uint64_t frame, int size, bool quick,
                    const SixwayBakeSettings& puff) {
    TruthSettings settings;
    if (quick) {
        // CI size: the pipeline end to end, not a converged truth (its figures are not quoted). The light
        // volume's cost does not shrink with the image, so its spacing is 8x the default (64x fewer columns).
        settings.spp = 1;
        settings.tolerance = 1.0f / 64.0f;
        settings.light_spacing_voxels = 16.0f;
        settings.max_view_levels = 2;
    }
    Truth t;
    const auto t0 = std::chrono::steady_clock::now();
    const GroundTruth truth(scene, puff, frame, size, size, settings);
    const TruthReport report = truth.render(t.image);
    t.render_seconds = report.seconds;
    t.bound = report.max_error_estimate;
    t.unconverged = report.unconverged_pixels;
    t.tau = truth.particle_optical_depths();
    t.shadow = truth.ground_shadow_mask();
    t.ladder = truth.render_ladder(t.rungs);
    t.seconds = elapsed_ms(t0) / 1000.0;
    return t;
}

const RegisterSection kTruthSection{{"truth",
                                     "run time against error against the ground truth (volume render): every mode "
                                     "and knob on the shipped scenes, SSIM, ground-shadow error, transmittance",
                                     &run_truth, true}};

}  // namespace
}  // namespace smoketrace::bench
