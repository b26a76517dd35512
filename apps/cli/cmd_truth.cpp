// smoketrace truth: the ground truth of a frame, the smoke it depicts rendered as a volume and converged
// (docs/ground-truth.md), to measure the frame's approximations against.
#include "arguments.hpp"
#include "assets.hpp"
#include "command.hpp"
#include "output_arg.hpp"
#include "progress_bar.hpp"
#include "scene_overrides.hpp"
#include "thread_limit.hpp"

#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/io/image_files.hpp>
#include <smoketrace/io/output_path.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/io/sixway_files.hpp>
#include <smoketrace/truth/ground_truth.hpp>

#include <array>
#include <filesystem>
#include <optional>
#include <iostream>

namespace smoketrace::cli {
namespace {

// The image as render writes a frame, with the progress display's last stage.
void write_truth_image(const std::filesystem::path& out, const ImageRgba& image, ImageFileKind kind,
                       WorkProgress* work, ProgressBar& progress) {
    const std::string writing = "writing the " + std::string(to_string(kind));
    if (work) work->begin(writing.c_str(), 0);
    write_image(out, image);
    progress.step();
    progress.finish();
}

int run_truth(const Args& args) {
    ArgReader in(args);
    const auto out_arg = in.string("-o");
    SceneOverrides overrides;
    overrides.size = in.size("--size", int(kMaxImageSide));
    const auto frame = in.integer("--frame", 0, kMaxSceneFrames - 1);
    const auto tolerance = in.number("--tolerance", 1e-6, 1.0);
    const auto spp = in.integer("--spp", 1, kMaxSpp);
    const auto light_spacing = in.number("--light-spacing", 0.25, 1024.0);
    const auto threads = in.integer("--threads", 1, 4096);
    const auto assets = in.string("--assets");
    const auto rung_name = in.string("--rung");
    const auto check_stride = in.integer("--check", 1, kMaxImageSide);
    // After every flag has taken its value, so that "-o OUT" is never mistaken for the scene file.
    const std::string scene_path = in.positional("scene file (smoketrace truth SCENE.json -o OUT.png)");
    in.finish();
    if (!out_arg) throw CliError("missing -o OUT.png");
    const std::filesystem::path out(*out_arg);
    ImageFileKind kind;
    try {
        kind = output_image_kind(out);  // render's choice: .png, .exr, .pfm
    } catch (const OutputPathError& e) {
        throw CliError(std::string("-o: ") + e.what());
    }

    std::optional<TruthRung> rung;
    if (rung_name) {
        for (int k = 0; k < kTruthRungs; ++k)
            if (*rung_name == to_string(TruthRung(k))) rung = TruthRung(k);
        if (!rung) {
            std::string names;
            for (int k = 0; k < kTruthRungs; ++k) names += std::string(k ? ", " : "") + to_string(TruthRung(k));
            throw CliError("--rung: unknown rung '" + shown_text(*rung_name) + "' (use " + names + ")");
        }
        if (check_stride) throw CliError("--check checks the truth's bound, and a rung has none: give one of the two");
    }

    const ThreadLimit limit(threads ? int(*threads) : 0);
    const SceneDescription scene = load_scene_file(scene_path);
    const std::uint64_t f = frame ? std::uint64_t(*frame) : 0;
    overrides.frames.count = (long long)(f + 1);  // the scene's motion must stay in range up to this frame
    const RenderOptions options = overrides.render_options(scene);
    const std::filesystem::path texture_dir = find_assets(assets, "--assets");
    const std::filesystem::path sidecar = texture_dir / kSixwayLayoutFile;
    const SixwayBakeSettings puff = read_sixway_bake_settings(sidecar);
    std::vector<std::filesystem::path> inputs = scene_inputs(scene_path, scene);
    inputs.push_back(sidecar);
    const OutputTarget output = checked_output(out, inputs);
    TruthSettings settings;
    if (tolerance) settings.tolerance = float(*tolerance);
    if (spp) settings.spp = int(*spp);
    if (light_spacing) settings.light_spacing_voxels = float(*light_spacing);
    ProgressBar progress(1, "frame");
    WorkProgress* const work = progress.work();
    if (work) work->begin("sampling the puffs", 0);
    const GroundTruth truth(scene, puff, f, options.width, options.height, settings);
    ImageRgba image;
    std::ostream& report = output.kind == OutputKind::standard_output ? std::cerr : std::cout;
    if (rung) {
        std::array<ImageRgba, kTruthRungs> rungs;
        const LadderReport r = truth.render_ladder(rungs, work);
        image = std::move(rungs[std::size_t(*rung)]);
        write_truth_image(out, image, kind, work, progress);
        report << "rung " << to_string(*rung) << " of the truth's ladder, frame " << f << " at " << options.width << "x"
               << options.height << ", " << settings.spp << " samples per pixel: " << r.seconds << " s\n"
               << "view steps: largest change at the last level " << r.view_error_estimate << " (half the tolerance "
               << 0.5f * settings.tolerance << "), levels " << r.view_levels_used << ", unconverged pixels "
               << r.unconverged_pixels << ", " << r.camera_samples << " density samples\n";
    } else {
        const TruthReport r = truth.render(image, work);
        TruthCheck c;
        if (check_stride) c = truth.check(image, r, int(*check_stride), work);
        write_truth_image(out, image, kind, work, progress);
        report << "truth of frame " << f << " at " << options.width << "x" << options.height << ", " << settings.spp
               << " samples per pixel: " << r.seconds << " s (light volume " << r.light_seconds << " s)\n"
               << "error bound (per pixel and channel, linear): " << r.max_error_estimate << " (tolerance "
               << settings.tolerance << "; view steps " << r.view_error_estimate << ", light "
               << r.light_error_estimate << "; the light volume alone " << r.light_volume_error_estimate << ")\n"
               << "unconverged pixels: " << r.unconverged_pixels << "\n"
               << "view step levels: " << r.view_levels_used << ", light volume " << r.light_columns_u << "x"
               << r.light_columns_v << "x" << r.light_nodes_w << " nodes at " << r.light_spacing << ", "
               << r.camera_samples << " density samples\n"
               << "exact light rays: " << r.exact_light_samples << " of " << r.light_samples << " lit samples, in "
               << r.exact_light_pixels << " pixels\n";
        if (check_stride)
            report << "checked " << c.pixels << " pixels (every " << *check_stride << "th) against exact light rays in "
                   << c.seconds << " s: largest difference " << c.largest_difference << " at (" << c.x << ", " << c.y
                   << "), its estimate " << c.estimate_there << "; " << c.above_tolerance
                   << " above the tolerance, " << c.above_estimate << " above their estimate + half the tolerance\n";
    }
    std::cerr << (output.kind == OutputKind::standard_output ? std::string("wrote the PNG to standard output")
                                                             : "wrote " + shown_text(out.string(), kMaxShownPathBytes))
              << "\n";
    return 0;
}

constexpr OptionHelp kOptions[] = {
    {"-o", "OUT.png|OUT.exr|OUT.pfm|-", "",
     "the image to write, as render writes a frame: .png 8-bit sRGB; .exr or .pfm the linear radiance, 32-bit float "
     "RGB; -: a PNG on standard output"},
    kSizeHelp,
    {"--frame", "N", "0", "the frame of the scene's sequence (particles and light as render draws frame N)"},
    {"--tolerance", "X", "1/512", "per pixel and channel, linear radiance: steps are halved and exact light rays "
                                  "replace the light volume until the pixel's error estimate is below X"},
    {"--light-spacing", "V", "2", "the light volume's node spacing in voxels of the smallest puff; exact light rays "
                                  "make up for it where the estimate asks, which a coarser volume makes less reliable "
                                  "(docs/ground-truth.md, the spacing)"},
    {"--spp", "N", "16", "samples per pixel (the pixel_samples pattern render uses), averaged: an anti-aliased truth"},
    {"--threads", "T", "all cores", "worker threads; the image is the same for any T"},
    {"--assets", "DIR", "as render's", "folder of the six-way textures: the puff is read from sixway.json's \"bake\""},
    {"--check", "K", "", "after the image, every Kth pixel (the centre of each KxK block) again with every light ray "
                         "exact (pixel()), and the largest difference against the bound; slow: a pixel takes seconds"},
    {"--rung", "NAME", "", "a rung of the ladder instead of the truth: the volume with the frame's approximations of "
                           "the light put in up to NAME (one-transmittance, light-map, six-axis, bake-extinction; "
                           "docs/ground-truth.md)"},
};

const RegisterCommand registration{
    {"truth",
     "truth SCENE.json -o OUT.png|OUT.exr|OUT.pfm|- [--size WxH] [--frame N] [--tolerance X] [--spp N] "
     "[--threads T] [--assets DIR] [--check K] [--rung NAME]",
     "the ground truth of a frame: the smoke it depicts rendered as a volume, converged to a stated bound",
     &run_truth, kOptions}};

}  // namespace
}  // namespace smoketrace::cli
