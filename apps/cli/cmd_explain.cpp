// smoketrace explain: one ray's story, for people learning the method (docs/explain.md). The stories are the
// library's (smoke/optical_depth_story.hpp, render/pixel_story.hpp); this file reads the arguments and the
// scene, and prints or draws what the library recorded.
#include "arguments.hpp"
#include "assets.hpp"
#include "command.hpp"
#include "explain_report.hpp"
#include "output_arg.hpp"
#include "scene_overrides.hpp"
#include "thread_limit.hpp"

#include <smoketrace/io/output_path.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/io/sixway_files.hpp>
#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/render/pixel_story.hpp>
#include <smoketrace/smoke/optical_depth_story.hpp>
#include <smoketrace/truth/ground_truth.hpp>

#include <filesystem>
#include <iostream>
#include <sstream>
#include <sys/stat.h>

namespace smoketrace::cli {
namespace {

// "X,Y": two whole numbers >= 0; the image's size is checked once the scene is read.
std::pair<int, int> parse_pixel(const std::string& text) {
    const auto comma = text.find(',');
    if (comma == std::string::npos)
        throw CliError("--pixel: " + quoted_arg(text) + " is not of the form X,Y (e.g. 256,300)");
    const long long x = parse_integer(text.substr(0, comma), "--pixel: X", 0, 1 << 30);
    const long long y = parse_integer(text.substr(comma + 1), "--pixel: Y", 0, 1 << 30);
    return {int(x), int(y)};
}

int run_explain(const Args& args) {
    ArgReader in(args);
    const auto out_arg = in.string("-o");
    const auto particle_arg = in.integer("--particle", 0, 0xFFFFFFFFLL);
    const auto pixel_arg = in.string("--pixel");
    const auto assets = in.string("--assets");
    const auto threads = in.integer("--threads", 1, 4096);
    const auto frame_arg = in.integer("--frame", 0, kMaxSceneFrames - 1);
    const bool truth = in.flag("--truth");
    // render's and depths' own options, read alike, so that the story is of the pixel the user looked at.
    const SceneOverrides overrides = SceneOverrides::read(in, OverrideSet::frame);
    const std::string scene_path =
        in.positional("scene file (smoketrace explain SCENE.json --particle N | --pixel X,Y)");
    in.finish();
    if (particle_arg && pixel_arg) throw CliError("--particle and --pixel: give one of them, not both");
    if (!particle_arg && !pixel_arg)
        throw CliError("give --particle N (a particle's optical-depth ray) or --pixel X,Y");
    if (particle_arg) {
        // What `depths` traces: frame 0, with only its --shape, --kernel and --cutoff.
        if (frame_arg) throw CliError("--frame: --particle explains frame 0, as depths computes it");
        if (truth) throw CliError("--truth: the truth of a pixel (--pixel); depths --truth gives a particle's");
        if (const char* flag = overrides.frame_only_flag())
            throw CliError(std::string(flag) + ": --particle takes only depths' --shape, --kernel and --cutoff (" +
                           flag + " changes the frame, not the optical-depth ray)");
    }
    std::optional<std::pair<int, int>> pixel;
    if (pixel_arg) pixel = parse_pixel(*pixel_arg);
    std::optional<std::filesystem::path> out;
    if (out_arg) {
        out = std::filesystem::path(*out_arg);
        struct stat st {};
        const bool stream = ::stat(out->c_str(), &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode);
        if (*out != kStandardOutputPath && !has_extension(*out, ".svg") && !stream)
            throw CliError("-o: " + quoted_arg(out->string()) + " must end in .svg");
    }
    const ThreadLimit limit(threads ? int(*threads) : 0);
    std::vector<std::filesystem::path> inputs{scene_path};
    std::optional<std::filesystem::path> texture_dir;
    if (pixel) {
        texture_dir = find_assets(assets, "--assets");
        inputs.push_back(*texture_dir / kSixwayLayoutFile);
    }
    // Before any work: -o must not be an input, a folder, or in a missing folder.
    std::optional<OutputTarget> target;
    if (out) target = checked_output(*out, inputs);
    // With the SVG on standard output, the text goes to standard error.
    std::ostream& text = target && target->kind == OutputKind::standard_output ? std::cerr : std::cout;

    const SceneDescription desc = load_scene_file(scene_path);
    const RenderOptions options = overrides.render_options(desc);
    if (target) check_output_not_input(*target, scene_inputs(scene_path, desc));  // the PLY it names
    const std::string scene_name =
        shown_text(std::filesystem::path(scene_path).filename().string(), kMaxShownPathBytes);
    std::ostringstream svg;
    if (particle_arg) {
        const auto& particles = desc.smoke.particles;
        if (particles.empty()) throw CliError("--particle: " + quoted_arg(scene_path) + " has no particles");
        if (std::uint64_t(*particle_arg) >= particles.size())
            throw CliError("--particle: " + std::to_string(*particle_arg) +
                           " is out of range: " + quoted_arg(scene_path) + " has " + std::to_string(particles.size()) +
                           " particles, 0…" + std::to_string(particles.size() - 1));
        // What `smoketrace depths` traces with the same --shape, --kernel and --cutoff: frame 0's particles and
        // light.
        std::optional<GroundQuad> ground;
        if (desc.ground) ground = GroundQuad{desc.ground->corners};
        SmokeScene smoke(particles, options.shape, ground, /*billboards=*/false);
        smoke.update(particles, desc.camera.position);
        OpticalDepthSettings settings;
        settings.cutoff = options.render.cutoff;
        settings.kernel = options.kernel;
        const OpticalDepthStory story =
            explain_optical_depth(smoke, particles, std::uint32_t(*particle_arg), desc.light.direction_at_frame(0),
                                  settings, HitSort::adaptive, desc.smoke.sigma_t);
        write_particle_text(text, story, particles, scene_name, options.shape.name().c_str(), desc.origin);
        if (target) write_particle_svg(svg, story, scene_name);
    } else {
        // The frame render writes first (0, or A of --frames A:B), unless --frame names another of them.
        const auto [first, end] = overrides.frame_range(options);
        const std::uint32_t frame = frame_arg ? std::uint32_t(*frame_arg) : first;
        if (frame < first || frame >= end)
            throw CliError("--frame: " + std::to_string(frame) + " is not one of the frames rendered, " +
                           std::to_string(first) + "…" + std::to_string(end - 1) +
                           " (--frames, else the scene's render.frames)");
        if (pixel->first >= options.width || pixel->second >= options.height)
            throw CliError("--pixel: " + shown_text(*pixel_arg, kMaxShownPathBytes) + " is outside the " +
                           std::to_string(options.width) + "x" + std::to_string(options.height) + " image (x 0…" +
                           std::to_string(options.width - 1) + ", y 0…" + std::to_string(options.height - 1) +
                           "; --size, else the scene's camera.width and height)");
        const SixwayLayout layout = read_sixway_layout(*texture_dir / kSixwayLayoutFile);
        if (target) check_output_not_input(*target, {layout.positive, layout.negative});
        const SixwayTexture texture = load_sixway_texture(layout.positive, layout.negative, layout.grid);
        // The frame as `render` draws it with the same options (mode, compositing, spp, size, groups, cutoff,
        // shape), brought there as render --frames A:B brings it, then that frame's pixel.
        FrameRenderer renderer(desc, options, texture);
        renderer.skip_to(frame);
        ImageRgba image;
        renderer.render(frame, image);
        const PixelStory story = explain_pixel(renderer, frame, pixel->first, pixel->second);
        const glm::vec3 frame_pixel(image.at(pixel->first, pixel->second));
        write_pixel_text(text, story, frame_pixel, scene_name, frame, desc.origin);
        if (truth) {
            // The same frame's smoke as a volume (truth/ground_truth.hpp), its puff the one the textures were
            // baked from; one pixel, its light rays traced exactly.
            const TruthSettings settings;
            const GroundTruth volume(desc, read_sixway_bake_settings(*texture_dir / kSixwayLayoutFile), frame,
                                     options.width, options.height, settings);
            write_pixel_truth_text(text, frame_pixel, volume.pixel(pixel->first, pixel->second), settings.spp,
                                   settings.tolerance);
        }
        if (target) write_pixel_svg(svg, story, scene_name, frame);
    }
    if (target) {
        write_output(*target, [&](std::ostream& o) { o << svg.str(); });
        std::cerr << (target->kind == OutputKind::standard_output
                          ? std::string("wrote the SVG to standard output")
                          : "wrote " + shown_text(out->string(), kMaxShownPathBytes))
                  << "\n";
    }
    return 0;
}

constexpr OptionHelp kOptions[] = {
    {"--particle", "N", "none: give --particle or --pixel",
     "explain particle N's optical-depth ray (0-based, as in depths' CSV)"},
    {"--pixel", "X,Y", "none: give --particle or --pixel",
     "explain pixel (X, Y) of a frame (0,0 the top left), each of its samples, as render draws it with the same "
     "options"},
    {"--truth", "", "off",
     "also the pixel's ground truth (the smoke as a volume, as smoketrace truth renders it) beside the frame's, "
     "and their difference (--pixel only; seconds to a minute)"},
    {"--frame", "F", "the first frame render writes (0, or A of --frames A:B)",
     "the frame of the sequence whose pixel is explained (--pixel only), one of those render writes"},
    {"-o", "OUT.svg|-", "none (text only)",
     "also draw the story as an SVG (-: standard output, the text then on standard error)"},
    {"--assets", "DIR", "SMOKETRACE_ASSETS, else <prefix>/share/smoketrace or assets/ beside the binary",
     "folder of the six-way textures (--pixel only)"},
    {"--threads", "T", "all cores", "worker threads for the frame (--pixel); the story is the same for any T"},
    kModeHelp,
    kSizeHelp,
    {"--frames", "N|A:B", "the scene's render.frames (1)",
     "as render's (--pixel only): the sequence --frame is one of; N up to 1000000, or A:B of the scene's"},
    kGroupsHelp,
    kCutoffHelp,
    kShapeHelp,
    kKernelHelp,
    kCompositingHelp,
    kSppHelp,
};

const RegisterCommand registration{
    {"explain",
     "explain SCENE.json --particle N | --pixel X,Y [--truth] [--frame F] [-o OUT.svg|-] [--assets DIR] [--threads T] "
     "[render's --mode --size --frames --groups --cutoff --shape --kernel --compositing --spp]",
     "one ray's story, step by step, for learning the method: a particle's optical-depth ray (the any-hit "
     "candidates, the sort, eq. 3.1's counter, l, tau, T; under a smooth --kernel each exit's share and their "
     "sum) or a pixel's camera ray (its layers, eq. 4.2, the ground and its shadow ray); see docs/explain.md",
     &run_explain, kOptions}};

}  // namespace
}  // namespace smoketrace::cli
