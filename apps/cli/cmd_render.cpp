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
#include <smoketrace/io/output_path.hpp>
#include <smoketrace/io/png_io.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/io/sixway_files.hpp>

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sys/stat.h>

namespace smoketrace::cli {
namespace {

// An existing file that is not a regular file or a folder (a FIFO, a device): a single frame streamed into it
// may have any name.
bool is_existing_stream(const std::filesystem::path& path) {
    struct stat st{};
    return ::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode);
}

// OUT.png for one frame; OUT_0000.png, OUT_0001.png, … for a sequence. Every name has as many digits as the
// last frame's number (at least 4), so that the names sort in frame order for any length of sequence.
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
    // After every flag has taken its value, so that "-o OUT" is never mistaken for the scene file.
    const std::string scene_path = in.positional("scene file (smoketrace render SCENE.json -o OUT.png)");
    in.finish();
    if (!out_arg) throw CliError("missing -o OUT.png");
    const std::filesystem::path out(*out_arg);
    const bool to_stdout = out == kStandardOutputPath;
    // Checks that need no file read, before the scene is loaded; every frame's path is checked below.
    if (!to_stdout) {
        if (!has_extension(out, ".png") && !is_existing_stream(out))
            throw CliError("-o: '" + out.string() + "' must end in .png");
        const std::filesystem::path out_dir = out.has_parent_path() ? out.parent_path() : ".";
        if (!std::filesystem::is_directory(out_dir))
            throw CliError("-o: folder '" + out_dir.string() + "' does not exist");
    }

    const ThreadLimit limit(threads ? int(*threads) : 0);
    const SceneDescription scene = load_scene_file(scene_path);
    RenderOptions options = overrides.render_options(scene);
    if (compositor) {
        if (*compositor == "tiled") options.compositor = CompositorKind::tiled;
        else if (*compositor == "one-traversal") options.compositor = CompositorKind::one_traversal;
        else if (*compositor == "retrace") options.compositor = CompositorKind::retrace;
        else throw CliError("--compositor: '" + *compositor + "' is not one of tiled, one-traversal, retrace");
    }
    const std::uint32_t frame_count = options.render.frames;
    const auto [first, end] = overrides.frame_range(options);
    if (to_stdout && frame_count > 1)
        throw CliError("-o -: standard output takes one frame, not " + std::to_string(frame_count) +
                       " (--frames or the scene's render.frames); write a sequence with -o OUT.png");
    if (frame_count > 1 && !has_extension(out, ".png"))
        throw CliError("-o: '" + out.string() + "' must end in .png (it names the files of a sequence)");
    if (assets && textures) throw CliError("--assets and --textures name the same folder: give one");
    const std::filesystem::path texture_dir =
        textures ? find_assets(textures, "--textures") : find_assets(assets, "--assets");
    const SixwayLayout layout = read_sixway_layout(texture_dir / kSixwayLayoutFile);
    // Before any work: no frame may be written onto an input, a folder or into a missing folder.
    std::vector<std::filesystem::path> inputs = scene_inputs(scene_path, scene);
    inputs.insert(inputs.end(), {texture_dir / kSixwayLayoutFile, layout.positive, layout.negative});
    bool timings_to_stderr = false;  // the PNG is on standard output: nothing else may go there
    for (std::uint32_t f = first; f < end; ++f)
        if (checked_output(frame_path(out, f, frame_count), inputs).kind == OutputKind::standard_output)
            timings_to_stderr = true;
    std::ostream& report = timings_to_stderr ? std::cerr : std::cout;
    const SixwayTexture texture = load_sixway_texture(layout.positive, layout.negative, layout.grid);

    FrameRenderer renderer(scene, options, texture);
    renderer.skip_to(first);  // particles, light, TLAS and the groups' optical depths as the full run has them
    ProgressBar progress(end - first);
    std::vector<FrameTimings> all;
    ImageRgba image;
    PngWriter png;  // one for the sequence: its memory is reused by every frame
    for (std::uint32_t f = first; f < end; ++f) {
        const FrameReport r = renderer.render(f, image);
        png.write_srgb(frame_path(out, f, frame_count), image);
        all.push_back(r.timings);
        if (timings) {
            report << "frame=" << f << " tlas=" << to_string(r.tlas) << "\n" << format_timings(r.timings, true);
        }
        progress.step();
    }
    progress.finish();
    if (timings && end - first > 1) report << "median\n" << format_timings(median(all), true);
    if (to_stdout)
        std::cerr << "wrote the PNG to standard output\n";
    else if (end - first == 1)
        std::cerr << "wrote " << frame_path(out, first, frame_count).string() << "\n";
    else
        std::cerr << "wrote " << end - first << " frames " << frame_path(out, first, frame_count).string() << " … "
                  << frame_path(out, end - 1, frame_count).string() << "\n";
    return 0;
}

constexpr OptionHelp kOptions[] = {
    {"-o", "OUT.png|-", "", "the PNG to write (8-bit sRGB; -: standard output, one frame); with N > 1 frames "
                            "OUT_0000.png, OUT_0001.png, … (the digits of the last frame's number, at least 4)"},
    kModeHelp,
    kSizeHelp,
    {"--frames", "N|A:B", "the scene's render.frames (1)",
     "N: frames to render (1…1000000), particles moving one step per frame; A:B: only frames A … B-1 of the "
     "scene's sequence, the same files a full run writes (for a batch scheduler's job array)"},
    kGroupsHelp,
    kCutoffHelp,
    kShapeHelp,
    {"--threads", "T", "all cores", "worker threads; the image is the same for any T"},
    kCompositingHelp,
    {"--compositor", "tiled|one-traversal|retrace", "tiled",
     "tiled: 16x16 pixels' camera rays traced together; one-traversal: each pixel's rays alone (the reference); "
     "retrace: the thesis's closest-hit loop (all three give the same image)"},
    kSppHelp,
    {"--assets", "DIR", "SMOKETRACE_ASSETS, else <prefix>/share/smoketrace or assets/ beside the binary",
     "folder of the six-way textures (sixway.json, sixway_pos.png, sixway_neg.png)"},
    {"--textures", "DIR", "as --assets", "the same as --assets (its older name)"},
    {"--timings", "", "off",
     "print each frame's stage times in ms, and their medians over a sequence (on standard error with -o -)"},
};

const RegisterCommand registration{
    {"render",
     "render SCENE.json -o OUT.png|- [--mode basic|simple-shadow|full] [--size WxH] [--frames N|A:B] [--groups G] "
     "[--cutoff K] [--shape S] [--threads T] [--timings] [--compositing over|thesis] "
     "[--compositor tiled|one-traversal|retrace] [--spp N] [--assets DIR]",
     "render a frame (-o -: on standard output), or N frames OUT_0000.png …, of the smoke scene", &run_render,
     kOptions}};

}  // namespace
}  // namespace smoketrace::cli
