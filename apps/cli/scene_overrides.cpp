#include "scene_overrides.hpp"

#include <smoketrace/core/image.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/render/frame_renderer.hpp>

#include <charconv>

namespace smoketrace::cli {
namespace {

RenderMode parse_mode(const std::string& s) {
    if (s == "basic") return RenderMode::basic;
    if (s == "simple-shadow") return RenderMode::simple_shadow;
    if (s == "full") return RenderMode::full;
    throw CliError("--mode: " + quoted_arg(s) + " is not one of basic, simple-shadow, full");
}

FramesArg parse_frames(const std::optional<std::string>& text) {
    FramesArg f;
    if (!text) return f;
    const auto colon = text->find(':');
    if (colon == std::string::npos) {
        f.count = parse_integer(*text, "--frames", 1, kMaxSceneFrames);
        return f;
    }
    const long long a = parse_integer(text->substr(0, colon), "--frames A:B: A", 0, kMaxSceneFrames - 1);
    const long long b = parse_integer(text->substr(colon + 1), "--frames A:B: B", 1, kMaxSceneFrames);
    if (a >= b)
        throw CliError("--frames " + shown_text(*text, kMaxShownPathBytes) +
                       ": A must be less than B (frames A … B-1 are rendered)");
    f.range = std::pair{std::uint32_t(a), std::uint32_t(b)};
    return f;
}

StandInShape parse_shape(const std::string& text) {
    const auto s = parse_stand_in_shape(text);
    if (!s)
        throw CliError("--shape: " + quoted_arg(text) + " is not sphere, icosahedron or icosphere:L (L = 1…4)");
    return *s;
}

DensityKernel parse_kernel(const std::string& text) {
    const auto k = parse_density_kernel(text);
    if (!k) throw CliError("--kernel: " + quoted_arg(text) + " is not one of " + std::string(kDensityKernelNames));
    return *k;
}

}  // namespace

SceneOverrides SceneOverrides::read(ArgReader& in, OverrideSet set) {
    SceneOverrides o;
    if (set == OverrideSet::frame) {
        o.mode = in.string("--mode");
        if (o.mode) parse_mode(*o.mode);  // checked now, before any file is read
        o.size = in.size("--size", int(kMaxImageSide));
        o.frames = parse_frames(in.string("--frames"));
        o.groups = in.integer("--groups", 1, 1 << 20);
    }
    o.cutoff = in.integer("--cutoff", 0, 1'000'000'000);
    o.shape = in.string("--shape");
    if (o.shape) parse_shape(*o.shape);
    o.kernel = in.string("--kernel");
    if (o.kernel) parse_kernel(*o.kernel);
    if (set == OverrideSet::frame) {
        o.compositing = in.string("--compositing");
        if (o.compositing && *o.compositing != "over" && *o.compositing != "thesis")
            throw CliError("--compositing: " + quoted_arg(*o.compositing) + " is not over or thesis");
        o.spp = in.integer("--spp", 1, kMaxSpp);
    }
    return o;
}

const char* SceneOverrides::frame_only_flag() const {
    if (mode) return "--mode";
    if (size) return "--size";
    if (frames.count || frames.range) return "--frames";
    if (groups) return "--groups";
    if (compositing) return "--compositing";
    if (spp) return "--spp";
    return nullptr;
}

RenderOptions SceneOverrides::render_options(const SceneDescription& scene) const {
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
    if (shape) options.shape = parse_shape(*shape);
    if (kernel) options.kernel = parse_kernel(*kernel);
    if (compositing) options.render.compositing = *compositing == "over" ? Compositing::over : Compositing::thesis;
    if (spp) options.render.spp = std::uint32_t(*spp);
    return options;
}

DepthOptions SceneOverrides::depth_options(const SceneDescription& scene) const {
    DepthOptions options{scene.smoke.shape, scene.smoke.kernel, scene.render.cutoff};
    if (cutoff) options.cutoff = std::uint32_t(*cutoff);
    if (shape) options.shape = parse_shape(*shape);
    if (kernel) options.kernel = parse_kernel(*kernel);
    return options;
}

std::pair<std::uint32_t, std::uint32_t> SceneOverrides::frame_range(const RenderOptions& options) const {
    const std::uint32_t count = options.render.frames;
    if (!frames.range) return {0, count};
    const auto [first, end] = *frames.range;
    if (end > count)
        throw CliError("--frames " + std::to_string(first) + ":" + std::to_string(end) + ": B is beyond the " +
                       std::to_string(count) + " frames of the sequence (the scene's render.frames)");
    return *frames.range;
}

}  // namespace smoketrace::cli
