// smoketrace depths: the optical-depth pipeline alone (thesis 4.3.2–4.3.3), one CSV row per particle.
#include "arguments.hpp"
#include "command.hpp"
#include "output_arg.hpp"
#include "scene_overrides.hpp"
#include "thread_limit.hpp"

#include <smoketrace/io/depths_csv.hpp>
#include <smoketrace/io/output_path.hpp>
#include <smoketrace/smoke/optical_path_lengths.hpp>
#include <smoketrace/smoke/particle_groups.hpp>
#include <smoketrace/io/scene_file.hpp>

#include <iostream>
#include <memory>

namespace smoketrace::cli {
namespace {

HitSort parse_sort(const std::string& s) {
    if (s == "adaptive") return HitSort::adaptive;
    if (s == "std") return HitSort::std_sort;
    if (s == "bubble") return HitSort::bubble;
    throw CliError("--sort: '" + s + "' is not one of adaptive, std, bubble");
}

int run_depths(const Args& args) {
    ArgReader in(args);
    const auto out_path = in.string("-o");
    const SceneOverrides overrides = SceneOverrides::read(in, OverrideSet::optical_depth);
    const auto threads = in.integer("--threads", 1, 4096);
    const auto repeat = in.integer("--repeat", 1, 1'000'000);
    const auto sort_arg = in.string("--sort");
    const bool timings = in.flag("--timings");
    // After every flag has taken its value, so that "-o OUT" is never mistaken for the scene file.
    const std::string scene_path = in.positional("scene file (smoketrace depths SCENE.json -o OUT.csv)");
    in.finish();
    if (!out_path) throw CliError("missing -o OUT.csv");

    const HitSort sort = sort_arg ? parse_sort(*sort_arg) : HitSort::adaptive;
    const ThreadLimit limit(threads ? int(*threads) : 0);
    // Before any work: -o must not be the scene file, a folder, or in a missing folder.
    const OutputTarget output = checked_output(*out_path, {scene_path});
    // With the CSV on standard output, the timings go to standard error.
    std::ostream& report = output.kind == OutputKind::standard_output ? std::cerr : std::cout;

    StageClock read_clock;
    const SceneDescription desc = load_scene_file(scene_path);
    const double read_ms = read_clock.lap_ms();
    check_output_not_input(output, scene_inputs(scene_path, desc));  // the PLY it names, now known
    const auto& particles = desc.smoke.particles;
    std::optional<GroundQuad> ground;
    if (desc.ground) ground = GroundQuad{desc.ground->corners};
    const RenderOptions options = overrides.render_options(desc);
    OpticalDepthSettings settings;
    settings.cutoff = options.render.cutoff;
    const std::vector<std::uint32_t> all = particle_group(particles.size(), 1, 0);

    std::vector<FrameTimings> runs;
    std::unique_ptr<OpticalPathLengths> depths;
    for (long long r = 0; r < (repeat ? *repeat : 1); ++r) {
        FrameTimings t;
        StageClock clock;
        SmokeScene smoke(particles, options.shape, ground, /*billboards=*/false);
        smoke.update(particles, desc.camera.position);
        t.tlas_update = clock.lap_ms();
        depths = std::make_unique<OpticalPathLengths>(particles.size());
        depths->update(smoke, particles, all, desc.light.direction, settings, sort, t);
        t.total = t.tlas_update + t.od_pass + t.resolve;
        runs.push_back(t);
    }

    StageClock write_clock;
    write_output(output, [&](std::ostream& out) {
        for (const std::string& piece : format_depths_csv(depths->lengths(), depths->hit_counts(), depths->status()))
            out.write(piece.data(), std::streamsize(piece.size()));
    });
    const double write_ms = write_clock.lap_ms();
    // The stages, then reading the scene and writing the CSV (once each, whatever --repeat says).
    if (timings) report << format_timings(median(runs), false) << "read_scene=" << read_ms << "\nwrite_csv=" << write_ms
                        << '\n';
    return 0;
}

constexpr OptionHelp kOptions[] = {
    {"-o", "OUT.csv|-", "", "the CSV to write (-: standard output): particle,optical_path_length,hits,status, one row "
                            "per particle"},
    kCutoffHelp,
    kShapeHelp,
    {"--threads", "T", "all cores", "worker threads; the output is the same for any T"},
    {"--repeat", "R", "1", "run the pass R times (for --timings)"},
    {"--timings", "", "off", "print the median stage times in ms (tlas_update, od_pass, resolve), then the times to "
                            "read the scene and write the CSV (read_scene, write_csv); on standard error with -o -"},
    {"--sort", "adaptive|std|bubble", "adaptive",
     "how each particle's hits are sorted (adaptive: a sorting network, rank or radix sort by list length)"},
};

const RegisterCommand registration{
    {"depths",
     "depths SCENE.json -o OUT.csv|- [--shape sphere|icosahedron|icosphere:L] [--cutoff K] [--threads T] "
     "[--repeat R] [--timings] [--sort adaptive|std|bubble]",
     "optical path length of every particle toward the light, as CSV (-o -: on standard output)", &run_depths,
     kOptions}};

}  // namespace
}  // namespace smoketrace::cli
