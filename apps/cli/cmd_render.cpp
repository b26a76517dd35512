// smoketrace render: frames and sequences of the smoke scene (thesis 4.3, 5.2.2).
#include "arguments.hpp"
#include "assets.hpp"
#include "command.hpp"
#include "output_arg.hpp"
#include "progress_bar.hpp"
#include "scene_overrides.hpp"
#include "thread_limit.hpp"

#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/render/pixel_samples.hpp>
#include <smoketrace/io/image_files.hpp>
#include <smoketrace/io/output_path.hpp>
#include <smoketrace/io/png_io.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/io/sixway_files.hpp>
#include <smoketrace/textbook/frame.hpp>

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>

namespace smoketrace::cli {
namespace {

// OUT.png for one frame; OUT_0000.png, OUT_0001.png, … for a sequence (OUT.exr, OUT_0000.exr, … alike). Every
// name has as many digits as the last frame's number (at least 4), so that the names sort in frame order for any
// length of sequence.
std::filesystem::path frame_path(const std::filesystem::path& out, std::uint32_t frame, std::uint32_t frames) {
    if (frames == 1) return out;
    const int digits = std::max(4, int(std::to_string(frames - 1).size()));
    char suffix[32];
    std::snprintf(suffix, sizeof suffix, "_%0*u", digits, frame);
    std::filesystem::path p = out;
    p.replace_filename(out.stem().string() + suffix + out.extension().string());
    return p;
}

int run_render(const Args& args) {
    ArgReader in(args);
    const auto out_arg = in.string("-o");
    const SceneOverrides overrides = SceneOverrides::read(in, OverrideSet::frame);
    const auto threads = in.integer("--threads", 1, 4096);
    const auto compositor = in.string("--compositor");
    const auto assets = in.string("--assets");
    const auto textures = in.string("--textures");
    const bool timings = in.flag("--timings");
    const auto path = in.string("--path");
    // After every flag has taken its value, so that "-o OUT" is never mistaken for the scene file.
    const std::string scene_path = in.positional("scene file (smoketrace render SCENE.json -o OUT.png)");
    in.finish();
    if (!out_arg) throw CliError("missing -o OUT.png");
    // The textbook path (src/textbook/) is the method in plain code; the fast path's own knobs do not apply.
    const bool textbook = path && *path == "textbook";
    if (path && !textbook && *path != "fast")
        throw CliError("--path: " + quoted_arg(*path) + " is not one of textbook, fast");
    if (textbook && compositor) throw CliError("--compositor: the textbook path has one compositor; give --path fast");
    if (textbook && timings) throw CliError("--timings: the textbook path is not timed; give --path fast");
    const std::filesystem::path out(*out_arg);
    const bool to_stdout = out == kStandardOutputPath;
    // One file that plays the whole sequence, where a browser can watch it; the name says which is wanted.
    const bool animated = has_extension(out, ".apng");
    // Checks that need no file read, before the scene is loaded; every frame's path is checked below. The
    // kind of image is output_image_kind()'s choice, the one the writer makes.
    if (!to_stdout) {
        if (!animated) {
            try {
                (void)output_image_kind(out);
            } catch (const OutputPathError&) {
                throw CliError("-o: " + quoted_arg(out.string()) + " must end in " + std::string(kImageFileKindsText) +
                               " (or .apng: the sequence as one animated PNG)");
            }
        }
        const std::filesystem::path out_dir = out.has_parent_path() ? out.parent_path() : ".";
        if (!std::filesystem::is_directory(out_dir))
            throw CliError("-o: folder " + quoted_arg(out_dir.string()) + " does not exist");
    }

    const ThreadLimit limit(threads ? int(*threads) : 0);
    const SceneDescription scene = load_scene_file(scene_path);
    RenderOptions options = overrides.render_options(scene);
    if (compositor) {
        if (*compositor == "tiled") options.compositor = CompositorKind::tiled;
        else if (*compositor == "one-traversal") options.compositor = CompositorKind::one_traversal;
        else if (*compositor == "retrace") options.compositor = CompositorKind::retrace;
        else throw CliError("--compositor: " + quoted_arg(*compositor) + " is not one of tiled, one-traversal, "
                            "retrace");
    }
    const std::uint32_t frame_count = options.render.frames;
    // Plain names, not a structured binding: the lambdas below capture them, which Clang 14 cannot.
    const std::pair<std::uint32_t, std::uint32_t> range = overrides.frame_range(options);
    const std::uint32_t first = range.first, end = range.second;
    if (to_stdout && frame_count > 1)
        throw CliError("-o -: standard output takes one frame, not " + std::to_string(frame_count) +
                       " (--frames or the scene's render.frames); write a sequence with -o OUT.png or OUT.apng");
    if (frame_count > 1 && !image_file_kind(out) && !animated)
        throw CliError("-o: " + quoted_arg(out.string()) + " must end in " + std::string(kImageFileKindsText) +
                       " (it names the files of a sequence) or .apng (one animated PNG)");
    if (assets && textures) throw CliError("--assets and --textures name the same folder: give one");
    const std::filesystem::path texture_dir =
        textures ? find_assets(textures, "--textures") : find_assets(assets, "--assets");
    const SixwayLayout layout = read_sixway_layout(texture_dir / kSixwayLayoutFile);
    // Before any work: no frame may be written onto an input, a folder or into a missing folder.
    std::vector<std::filesystem::path> inputs = scene_inputs(scene_path, scene);
    inputs.insert(inputs.end(), {texture_dir / kSixwayLayoutFile, layout.positive, layout.negative});
    bool timings_to_stderr = false;  // the image is on standard output: nothing else may go there
    std::optional<OutputTarget> animation;
    if (animated) {
        animation = checked_output(out, inputs);
        timings_to_stderr = animation->kind == OutputKind::standard_output;
    } else {
        for (std::uint32_t f = first; f < end; ++f)
            if (checked_output(frame_path(out, f, frame_count), inputs).kind == OutputKind::standard_output)
                timings_to_stderr = true;
    }
    std::ostream& report = timings_to_stderr ? std::cerr : std::cout;
    ProgressBar progress(end - first, "frame");
    WorkProgress* const work = progress.work();
    if (work) work->begin("reading the textures", 0);
    const SixwayTexture texture = load_sixway_texture(layout.positive, layout.negative, layout.grid);

    if (work) work->begin("building the scene", 0);
    std::optional<FrameRenderer> renderer;
    std::optional<textbook::FrameLoop> textbook_loop;  // advances over the frames before `first` itself
    if (textbook) {
        textbook_loop.emplace(scene, textbook::FrameOptions{options.render, options.shape, options.kernel,
                                                            options.width, options.height},
                              texture);
    } else {
        renderer.emplace(scene, options, texture);
        renderer->count_progress(work);
        renderer->skip_to(first);  // particles, light, TLAS and the groups' optical depths as the full run has them
    }
    std::vector<FrameTimings> all;
    ImageRgba image;
    const std::string image_stage =
        "writing the " + std::string(to_string(animated ? ImageFileKind::png : output_image_kind(out)));
    const auto render_frame = [&](std::uint32_t f) {
        if (textbook_loop) {
            if (work) work->begin("the textbook frame", 0);
            textbook_loop->render(f, image);
            if (work) work->begin(animation ? "compressing the frame" : image_stage.c_str(), 0);
            return;
        }
        const FrameReport r = renderer->render(f, image);
        all.push_back(r.timings);
        if (timings) {
            progress.clear_line();
            report << "frame=" << f << " tlas=" << to_string(r.tlas) << "\n" << format_timings(r.timings, true)
                   << format_usage(r.timings, true);
            report.flush();
        }
        if (work) work->begin(animation ? "compressing the frame" : image_stage.c_str(), 0);
    };
    if (animation) {
        // Each frame is compressed and written to the temporary file as it is rendered: one frame's memory.
        write_output(*animation, [&](std::ostream& file) {
            ApngWriter apng(file, out, options.width, options.height, end - first, options.render.fps);
            for (std::uint32_t f = first; f < end; ++f) {
                render_frame(f);
                apng.add_srgb(image);
                progress.step();
                // The next frame's first stage, until render() names the next.
                if (work && f + 1 < end) work->begin("moving the particles", 0);
            }
            apng.finish();
        });
    } else {
        ImageFileWriter writer;  // one for the sequence: the PNG encoder's memory is reused by every frame
        for (std::uint32_t f = first; f < end; ++f) {
            render_frame(f);
            writer.write(frame_path(out, f, frame_count), image);
            progress.step();
            if (work && f + 1 < end) work->begin("moving the particles", 0);
        }
    }
    progress.finish();
    if (timings && end - first > 1) {
        const FrameTimings m = median(all);
        report << "median\n" << format_timings(m, true) << format_usage(m, true);
    }
    if (animation)
        std::cerr << "wrote " << shown_text(out.string(), kMaxShownPathBytes) << " (" << end - first
                  << " frames at " << options.render.fps << " per second)\n";
    else if (to_stdout)
        std::cerr << "wrote the PNG to standard output\n";
    else if (end - first == 1)
        std::cerr << "wrote " << shown_text(frame_path(out, first, frame_count).string(), kMaxShownPathBytes) << "\n";
    else
        std::cerr << "wrote " << end - first << " frames "
                  << shown_text(frame_path(out, first, frame_count).string(), kMaxShownPathBytes) << " … "
                  << shown_text(frame_path(out, end - 1, frame_count).string(), kMaxShownPathBytes) << "\n";
    return 0;
}

constexpr OptionHelp kOptions[] = {
    {"-o", "OUT.png|OUT.exr|OUT.pfm|OUT.apng|-", "",
     "the image to write: .png 8-bit sRGB; .exr (OpenEXR) or .pfm (Portable Float Map) the linear radiance before "
     "sRGB, 32-bit float RGB; -: a PNG on standard output, one frame. With N > 1 frames OUT_0000.png, "
     "OUT_0001.png, … (.exr, .pfm alike; the digits of the last frame's number, at least 4); OUT.apng: every "
     "frame in one animated PNG, played at the scene's render.fps (24)"},
    kModeHelp,
    kSizeHelp,
    {"--frames", "N|A:B", "the scene's render.frames (1)",
     "N: frames to render (1…1000000), particles moving one step per frame; A:B: only frames A … B-1 of the "
     "scene's sequence, the same files a full run writes (for a batch scheduler's job array)"},
    kGroupsHelp,
    kCutoffHelp,
    kShapeHelp,
    kKernelHelp,
    {"--threads", "T", "all cores", "worker threads; the image is the same for any T"},
    kCompositingHelp,
    {"--compositor", "tiled|one-traversal|retrace", "tiled",
     "tiled: 16x16 pixels' camera rays traced together; one-traversal: each pixel's rays alone (the reference); "
     "retrace: the thesis's closest-hit loop (all three give the same image); fast path only"},
    {"--path", "textbook|fast", "fast",
     "fast: the optimised renderer; textbook: the method in plain scalar code (src/textbook/, the reference the "
     "fast path is tested against; slower, no --compositor or --timings)"},
    kSppHelp,
    {"--assets", "DIR", "SMOKETRACE_ASSETS, else <prefix>/share/smoketrace or assets/ beside the binary",
     "folder of the six-way textures (sixway.json, sixway_pos.png, sixway_neg.png)"},
    {"--textures", "DIR", "as --assets", "the same as --assets (its older name)"},
    {"--timings", "", "off",
     "print each frame's stage times in ms, then each stage's CPU time and page faults (STAGE.user_ms, "
     ".system_ms, .minor_faults, .major_faults), and their medians over a sequence (on standard error with -o -)"},
};

const RegisterCommand registration{
    {"render",
     "render SCENE.json -o OUT.png|OUT.exr|OUT.pfm|OUT.apng|- [--mode basic|simple-shadow|full] [--size WxH] "
     "[--frames N|A:B] [--groups G] "
     "[--cutoff K] [--shape S] [--kernel NAME] [--threads T] [--timings] [--compositing over|thesis] "
     "[--compositor tiled|one-traversal|retrace] [--spp N] [--path textbook|fast] [--assets DIR]",
     "render a frame (PNG, or linear float EXR or PFM; -o -: on standard output), or N frames OUT_0000.png … or "
     "one animated OUT.apng, of the smoke scene", &run_render,
     kOptions}};

}  // namespace
}  // namespace smoketrace::cli
