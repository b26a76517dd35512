// smoketrace render: frames and sequences of the smoke scene (thesis 4.3, 5.2.2).
#include "arguments.hpp"
#include "assets.hpp"
#include "command.hpp"
#include "output_arg.hpp"
#include "progress_bar.hpp"
#include "thread_limit.hpp"

#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/render/pixel_samples.hpp>
#include <smoketrace/io/output_path.hpp>
#include <smoketrace/io/png_io.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/io/sixway_files.hpp>

#include <charconv>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>
#include <sys/stat.h>
#include <tuple>

namespace smoketrace::cli {
namespace {

RenderMode parse_mode(const std::string& s) {
    if (s == "basic") return RenderMode::basic;
    if (s == "simple-shadow") return RenderMode::simple_shadow;
    if (s == "full") return RenderMode::full;
    throw CliError("--mode: '" + s + "' is not one of basic, simple-shadow, full");
}

// An existing file that is not a regular file or a folder (a FIFO, a device): a single frame streamed into it
// may have any name.
bool is_existing_stream(const std::filesystem::path& path) {
    struct stat st{};
    return ::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode);
}

// OUT.png for one frame; OUT_0000.png, OUT_0001.png, … for a sequence.
std::filesystem::path frame_path(const std::filesystem::path& out, std::uint32_t frame, std::uint32_t frames) {
    if (frames == 1) return out;
    char suffix[32];
    std::snprintf(suffix, sizeof suffix, "_%04u", frame);
    std::filesystem::path p = out;
    p.replace_filename(out.stem().string() + suffix + out.extension().string());
    return p;
}

// --frames: "N" (render N frames) or "A:B" (frames A … B − 1 of the scene's sequence).
struct FramesArg {
    std::optional<long long> count;
    std::optional<std::pair<std::uint32_t, std::uint32_t>> range;
};

FramesArg parse_frames(const std::optional<std::string>& text) {
    FramesArg f;
    if (!text) return f;
    const auto colon = text->find(':');
    if (colon == std::string::npos) {
        f.count = parse_integer(*text, "--frames", 1, 100000);
        return f;
    }
    const long long a = parse_integer(text->substr(0, colon), "--frames A:B: A", 0, kMaxSceneFrames - 1);
    const long long b = parse_integer(text->substr(colon + 1), "--frames A:B: B", 1, kMaxSceneFrames);
    if (a >= b) throw CliError("--frames " + *text + ": A must be less than B (frames A … B-1 are rendered)");
    f.range = std::pair{std::uint32_t(a), std::uint32_t(b)};
    return f;
}

int run_render(const Args& args) {
    ArgReader in(args);
    const auto out_arg = in.string("-o");
    const auto mode = in.string("--mode");
    const auto size = in.size("--size", int(kMaxImageSide));
    const FramesArg frames = parse_frames(in.string("--frames"));
    const auto groups = in.integer("--groups", 1, 1 << 20);
    const auto cutoff = in.integer("--cutoff", 0, 1'000'000'000);
    const auto shape_arg = in.string("--shape");
    const auto threads = in.integer("--threads", 1, 4096);
    const auto compositing = in.string("--compositing");
    const auto compositor = in.string("--compositor");
    const auto spp = in.integer("--spp", 1, kMaxSpp);
    const auto assets = in.string("--assets");
    const auto textures = in.string("--textures");
    const bool timings = in.flag("--timings");
    // After every flag has taken its value, so that "-o OUT" is never mistaken for the scene file.
    const std::string scene_path = in.positional("scene file (smoketrace render SCENE.json -o OUT.png)");
    in.finish();
    if (!out_arg) throw CliError("missing -o OUT.png");
    const std::filesystem::path out(*out_arg);
    const bool to_stdout = out == kStandardOutputPath;
    // One file that plays the whole sequence, where a browser can watch it; the name says which is wanted.
    const bool animated = out.extension() == ".apng";
    // Checks that need no file read, before the scene is loaded; every frame's path is checked below.
    if (!to_stdout) {
        if (out.extension() != ".png" && !animated && !is_existing_stream(out))
            throw CliError("-o: '" + out.string() + "' must end in .png (or .apng: the sequence as one animated PNG)");
        const std::filesystem::path out_dir = out.has_parent_path() ? out.parent_path() : ".";
        if (!std::filesystem::is_directory(out_dir))
            throw CliError("-o: folder '" + out_dir.string() + "' does not exist");
    }

    const ThreadLimit limit(threads ? int(*threads) : 0);
    const SceneDescription scene = load_scene_file(scene_path);
    RenderOptions options = RenderOptions::from_scene(scene);
    if (mode) options.render.mode = parse_mode(*mode);
    if (size) {
        options.width = size->first;
        options.height = size->second;
        if (std::uint64_t(options.width) * std::uint64_t(options.height) > kMaxImagePixels)
            throw CliError("--size: " + std::to_string(options.width) + "x" + std::to_string(options.height) +
                           " has more than " + std::to_string(kMaxImagePixels) + " pixels");
        // The file's camera was checked at the file's height; a taller image narrows the angle between rows.
        if (const std::string problem = pixel_angle_problem(scene.camera.fov_deg, options.height); !problem.empty()) {
            char fov[32];
            const auto shown = std::to_chars(fov, fov + sizeof fov, scene.camera.fov_deg).ptr;
            throw CliError("--size: " + std::to_string(options.width) + "x" + std::to_string(options.height) +
                           ": the scene's camera.fov_deg (" + std::string(fov, shown) + ") is too small for this size: " +
                           problem);
        }
    }
    if (frames.count) {
        options.render.frames = std::uint32_t(*frames.count);
        check_scene_motion(scene, options.render.frames);  // more frames than the file's: motion re-checked
    }
    if (groups) options.render.groups = std::uint32_t(*groups);
    if (cutoff) options.render.cutoff = std::uint32_t(*cutoff);
    if (shape_arg) {
        const auto s = parse_stand_in_shape(*shape_arg);
        if (!s) throw CliError("--shape: '" + *shape_arg + "' is not sphere, icosahedron or icosphere:L (L = 1…4)");
        options.shape = *s;
    }
    if (compositing) {
        if (*compositing == "over") options.render.compositing = Compositing::over;
        else if (*compositing == "thesis") options.render.compositing = Compositing::thesis;
        else throw CliError("--compositing: '" + *compositing + "' is not over or thesis");
    }
    if (compositor) {
        if (*compositor == "tiled") options.compositor = CompositorKind::tiled;
        else if (*compositor == "one-traversal") options.compositor = CompositorKind::one_traversal;
        else if (*compositor == "retrace") options.compositor = CompositorKind::retrace;
        else throw CliError("--compositor: '" + *compositor + "' is not one of tiled, one-traversal, retrace");
    }
    if (spp) options.render.spp = std::uint32_t(*spp);
    const std::uint32_t frame_count = options.render.frames;
    // The frames this run writes: all, or --frames A:B of the sequence (same names and bytes as a full run's).
    std::uint32_t first = 0, end = frame_count;
    if (frames.range) {
        std::tie(first, end) = *frames.range;
        if (end > frame_count)
            throw CliError("--frames " + std::to_string(first) + ":" + std::to_string(end) + ": B is beyond the " +
                           std::to_string(frame_count) + " frames of the sequence (the scene's render.frames)");
    }
    if (to_stdout && frame_count > 1)
        throw CliError("-o -: standard output takes one frame, not " + std::to_string(frame_count) +
                       " (--frames or the scene's render.frames); write a sequence with -o OUT.png or OUT.apng");
    if (frame_count > 1 && out.extension() != ".png" && !animated)
        throw CliError("-o: '" + out.string() +
                       "' must end in .png (it names the files of a sequence) or .apng (one animated PNG)");
    if (assets && textures) throw CliError("--assets and --textures name the same folder: give one");
    const std::filesystem::path texture_dir =
        textures ? find_assets(textures, "--textures") : find_assets(assets, "--assets");
    const SixwayLayout layout = read_sixway_layout(texture_dir / kSixwayLayoutFile);
    // Before any work: no frame may be written onto an input, a folder or into a missing folder.
    const std::vector<std::filesystem::path> inputs{scene_path, texture_dir / kSixwayLayoutFile, layout.positive,
                                                    layout.negative};
    bool timings_to_stderr = false;  // the PNG is on standard output: nothing else may go there
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
    const SixwayTexture texture = load_sixway_texture(layout.positive, layout.negative, layout.grid);

    FrameRenderer renderer(scene, options, texture);
    renderer.skip_to(first);  // particles, light, TLAS and the groups' optical depths as the full run has them
    ProgressBar progress(end - first);
    std::vector<FrameTimings> all;
    ImageRgba image;
    const auto render_frame = [&](std::uint32_t f) {
        const FrameReport r = renderer.render(f, image);
        all.push_back(r.timings);
        if (timings) {
            report << "frame=" << f << " tlas=" << to_string(r.tlas) << "\n" << format_timings(r.timings, true);
        }
    };
    if (animation) {
        // Each frame is compressed and written to the temporary file as it is rendered: one frame's memory.
        write_output(*animation, [&](std::ostream& file) {
            ApngWriter apng(file, out, options.width, options.height, end - first, options.render.fps);
            for (std::uint32_t f = first; f < end; ++f) {
                render_frame(f);
                apng.add_srgb(image);
                progress.step();
            }
            apng.finish();
        });
    } else {
        PngWriter png;  // one for the sequence: its memory is reused by every frame
        for (std::uint32_t f = first; f < end; ++f) {
            render_frame(f);
            png.write_srgb(frame_path(out, f, frame_count), image);
            progress.step();
        }
    }
    progress.finish();
    if (timings && end - first > 1) report << "median\n" << format_timings(median(all), true);
    if (animation)
        std::cerr << "wrote " << out.string() << " (" << end - first << " frames at " << options.render.fps
                  << " per second)\n";
    else if (to_stdout)
        std::cerr << "wrote the PNG to standard output\n";
    else if (end - first == 1)
        std::cerr << "wrote " << frame_path(out, first, frame_count).string() << "\n";
    else
        std::cerr << "wrote " << end - first << " frames " << frame_path(out, first, frame_count).string() << " … "
                  << frame_path(out, end - 1, frame_count).string() << "\n";
    return 0;
}

constexpr OptionHelp kOptions[] = {
    {"-o", "OUT.png|OUT.apng|-", "", "the PNG to write (8-bit sRGB; -: standard output, one frame); with N > 1 "
                                     "frames OUT_0000.png, OUT_0001.png, …; OUT.apng: every frame in one animated "
                                     "PNG, played at the scene's render.fps (24)"},
    {"--mode", "basic|simple-shadow|full", "the scene's render.mode (full)",
     "basic: no optical depths, no shadows; simple-shadow: ground shadows 0 or 1; full: eq. 4.3 shadows"},
    {"--size", "WxH", "the scene's camera.width x height (512x512)", "image size in pixels, each side 1…16384"},
    {"--frames", "N|A:B", "the scene's render.frames (1)",
     "N: frames to render, particles moving one step per frame; A:B: only frames A … B-1 of the scene's sequence, "
     "the same files a full run writes (for a batch scheduler's job array)"},
    {"--groups", "G", "the scene's render.groups (1)", "particle groups: 1/G of the optical depths updated per frame"},
    {"--cutoff", "K", "the scene's render.cutoff (0: none)",
     "a particle whose light ray meets more than K surfaces is fully dark"},
    {"--shape", "sphere|icosahedron|icosphere:L", "the scene's smoke.shape (sphere)",
     "particle stand-in for optical-depth and shadow rays; icosphere level L = 1…4"},
    {"--threads", "T", "all cores", "worker threads; the image is the same for any T"},
    {"--compositing", "over|thesis", "the scene's render.compositing (over)",
     "over: front-to-back over operator; thesis: eq. 4.1 as published"},
    {"--compositor", "tiled|one-traversal|retrace", "tiled",
     "tiled: 16x16 pixels' camera rays traced together; one-traversal: each pixel's rays alone (the reference); "
     "retrace: the thesis's closest-hit loop (all three give the same image)"},
    {"--spp", "N", "the scene's render.spp (1)",
     "samples per pixel, 1…64, on a fixed stratified pattern and averaged (anti-aliasing); 1: the pixel's centre"},
    {"--assets", "DIR", "SMOKETRACE_ASSETS, else <prefix>/share/smoketrace or assets/ beside the binary",
     "folder of the six-way textures (sixway.json, sixway_pos.png, sixway_neg.png)"},
    {"--textures", "DIR", "as --assets", "the same as --assets (its older name)"},
    {"--timings", "", "off",
     "print each frame's stage times in ms, and their medians over a sequence (on standard error with -o -)"},
};

const RegisterCommand registration{
    {"render",
     "render SCENE.json -o OUT.png|OUT.apng|- [--mode basic|simple-shadow|full] [--size WxH] [--frames N|A:B] [--groups G] "
     "[--cutoff K] [--shape S] [--threads T] [--timings] [--compositing over|thesis] "
     "[--compositor tiled|one-traversal|retrace] [--spp N] [--assets DIR]",
     "render a frame (-o -: on standard output), or N frames OUT_0000.png … or one animated OUT.apng, of the smoke "
     "scene", &run_render,
     kOptions}};

}  // namespace
}  // namespace smoketrace::cli
