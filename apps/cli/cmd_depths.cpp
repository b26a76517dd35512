// smoketrace depths: the optical-depth pipeline alone (thesis 4.3.2–4.3.3), one CSV row per particle.
#include "arguments.hpp"
#include "assets.hpp"
#include "command.hpp"
#include "output_arg.hpp"
#include "progress_bar.hpp"
#include "scene_overrides.hpp"
#include "thread_limit.hpp"

#include <smoketrace/io/depths_csv.hpp>
#include <smoketrace/io/output_path.hpp>
#include <smoketrace/smoke/optical_path_lengths.hpp>
#include <smoketrace/smoke/particle_groups.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/io/sixway_files.hpp>
#include <smoketrace/textbook/optical_depth.hpp>
#include <smoketrace/truth/ground_truth.hpp>

#include <iostream>
#include <memory>

namespace smoketrace::cli {
namespace {

HitSort parse_sort(const std::string& s) {
    if (s == "adaptive") return HitSort::adaptive;
    if (s == "std") return HitSort::std_sort;
    if (s == "bubble") return HitSort::bubble;
    throw CliError("--sort: " + quoted_arg(s) + " is not one of adaptive, std, bubble");
}

int run_depths(const Args& args) {
    ArgReader in(args);
    const auto out_path = in.string("-o");
    const SceneOverrides overrides = SceneOverrides::read(in, OverrideSet::optical_depth);
    const auto threads = in.integer("--threads", 1, 4096);
    const auto repeat = in.integer("--repeat", 1, 1'000'000);
    const auto sort_arg = in.string("--sort");
    const bool timings = in.flag("--timings");
    const bool truth = in.flag("--truth");
    const auto assets = in.string("--assets");
    const auto path = in.string("--path");
    // After every flag has taken its value, so that "-o OUT" is never mistaken for the scene file.
    const std::string scene_path = in.positional("scene file (smoketrace depths SCENE.json -o OUT.csv)");
    in.finish();
    if (!out_path) throw CliError("missing -o OUT.csv");
    if (assets && !truth) throw CliError("--assets: only --truth reads the six-way textures' puff");
    // The textbook path (src/textbook/) is the method in plain code; the fast path's own knobs do not apply.
    const bool textbook = path && *path == "textbook";
    if (path && !textbook && *path != "fast")
        throw CliError("--path: " + quoted_arg(*path) + " is not one of textbook, fast");
    if (textbook && sort_arg) throw CliError("--sort: the textbook path sorts with std::sort; give --path fast");
    if (textbook && timings) throw CliError("--timings: the textbook path is not timed; give --path fast");

    const HitSort sort = sort_arg ? parse_sort(*sort_arg) : HitSort::adaptive;
    const ThreadLimit limit(threads ? int(*threads) : 0);
    // Before any work: -o must not be the scene file, a folder, or in a missing folder.
    const OutputTarget output = checked_output(*out_path, {scene_path});
    // With the CSV on standard output, the timings go to standard error.
    std::ostream& report = output.kind == OutputKind::standard_output ? std::cerr : std::cout;

    ProgressBar progress(std::uint64_t(repeat ? *repeat : 1), "repeat");
    WorkProgress* const work = progress.work();
    if (work) work->begin("reading the scene", 0);
    StageClock read_clock;
    const SceneDescription desc = load_scene_file(scene_path);
    ProcessUsage read_usage;
    const double read_ms = read_clock.lap_ms(read_usage);
    check_output_not_input(output, scene_inputs(scene_path, desc));  // the PLY it names, now known
    const auto& particles = desc.smoke.particles;
    std::optional<GroundQuad> ground;
    if (desc.ground) ground = GroundQuad{desc.ground->corners};
    const DepthOptions options = overrides.depth_options(desc);
    OpticalDepthSettings settings;
    settings.cutoff = options.cutoff;
    settings.progress = work;
    settings.kernel = options.kernel;
    const std::vector<std::uint32_t> all = particle_group(particles.size(), 1, 0);

    std::vector<FrameTimings> runs;
    std::unique_ptr<OpticalPathLengths> depths;
    textbook::OpticalDepths textbook_depths;
    for (long long r = 0; r < (repeat ? *repeat : 1); ++r) {
        FrameTimings t;
        StageClock clock;
        if (work) work->begin("TLAS build", 0);
        SmokeScene smoke(particles, options.shape, ground, /*billboards=*/false);
        smoke.update(particles, desc.camera.position);
        t.tlas_update = clock.lap_ms(t.usage.tlas_update);
        if (textbook) {
            if (work) work->begin("optical depths (textbook)", 0);
            textbook_depths = textbook::optical_depths(smoke, particles, all, desc.light.direction, settings.cutoff,
                                                       settings.kernel);
        } else {
            depths = std::make_unique<OpticalPathLengths>(particles.size());
            depths->update(smoke, particles, all, desc.light.direction, settings, sort, t);
        }
        t.total = t.tlas_update + t.od_pass + t.resolve;
        runs.push_back(t);
        progress.step();
    }

    std::vector<double> true_depths;
    if (truth) {
        // The ground truth's τ from each centre, exact light rays through the same particles (frame 0).
        if (work) work->begin("true optical depths", 0);
        const SixwayBakeSettings puff = read_sixway_bake_settings(find_assets(assets, "--assets") / kSixwayLayoutFile);
        const GroundTruth ground_truth(desc, puff, 0, 1, 1);
        true_depths = ground_truth.particle_optical_depths();
    }

    if (work) work->begin("writing the CSV", 0);
    StageClock write_clock;
    write_output(output, [&](std::ostream& out) {
        const auto pieces = textbook ? format_depths_csv(textbook_depths.lengths, textbook_depths.hit_counts,
                                                         textbook_depths.status, true_depths)
                                     : format_depths_csv(depths->lengths(), depths->hit_counts(), depths->status(),
                                                         true_depths);
        for (const std::string& piece : pieces) out.write(piece.data(), std::streamsize(piece.size()));
    });
    ProcessUsage write_usage;
    const double write_ms = write_clock.lap_ms(write_usage);
    progress.finish();
    std::cerr << (output.kind == OutputKind::standard_output ? std::string("wrote the CSV to standard output")
                                                             : "wrote " + shown_text(*out_path, kMaxShownPathBytes))
              << " (" << particles.size() << (particles.size() == 1 ? " particle)\n" : " particles)\n");
    // The stages, then reading the scene and writing the CSV (once each, whatever --repeat says); then the
    // same stages' CPU time and page faults.
    if (timings) {
        const FrameTimings m = median(runs);
        report << format_timings(m, false) << "read_scene=" << read_ms << "\nwrite_csv=" << write_ms << '\n'
               << format_usage(m, false) << format_stage_usage("read_scene", read_usage)
               << format_stage_usage("write_csv", write_usage);
    }
    return 0;
}

constexpr OptionHelp kOptions[] = {
    {"-o", "OUT.csv|-", "", "the CSV to write (-: standard output): particle,optical_path_length,hits,status, one row "
                            "per particle"},
    kCutoffHelp,
    kShapeHelp,
    kKernelHelp,
    {"--threads", "T", "all cores", "worker threads; the output is the same for any T"},
    {"--repeat", "R", "1", "run the pass R times (for --timings)"},
    {"--timings", "", "off", "print the median stage times in ms (tlas_update, od_pass, resolve), then the times to "
                            "read the scene and write the CSV (read_scene, write_csv), then each stage's CPU time "
                            "and page faults (STAGE.user_ms, .system_ms, .minor_faults, .major_faults); on standard "
                            "error with -o -"},
    {"--truth", "", "off", "add a column true_optical_depth: the ground truth's τ from each centre to the light "
                          "(docs/ground-truth.md; compare with optical_path_length × sigma_t)"},
    {"--assets", "DIR", "as render's", "with --truth: folder of the six-way textures whose sixway.json \"bake\" gives "
                                       "the puff"},
    {"--sort", "adaptive|std|bubble", "adaptive",
     "how each particle's hits are sorted (adaptive: a sorting network, rank or radix sort by list length); fast "
     "path only"},
    {"--path", "textbook|fast", "fast",
     "fast: the optimised pass; textbook: the method in plain scalar code (src/textbook/, the reference the fast "
     "path is tested against; the same statuses and counts, lengths within float rounding; no --sort or --timings)"},
};

const RegisterCommand registration{
    {"depths",
     "depths SCENE.json -o OUT.csv|- [--shape sphere|icosahedron|icosphere:L] [--kernel NAME] [--cutoff K] "
     "[--threads T] "
     "[--repeat R] [--timings] [--sort adaptive|std|bubble] [--path textbook|fast] [--truth [--assets DIR]]",
     "optical path length of every particle toward the light, as CSV (-o -: on standard output)", &run_depths,
     kOptions}};

}  // namespace
}  // namespace smoketrace::cli
