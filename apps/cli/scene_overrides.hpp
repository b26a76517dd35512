#pragma once
// The options that override a scene file's settings (--mode, --size, --frames, --groups, --cutoff, --shape,
// --kernel, --compositing, --spp), read and applied in one place for every command that takes them: `explain --pixel`
// then draws the very frame `render` drew with the same options, and `explain --particle` traces what
// `depths` traced.
#include "arguments.hpp"
#include "command.hpp"

#include <smoketrace/smoke/scene_description.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <utility>

namespace smoketrace {
struct RenderOptions;  // render/frame_renderer.hpp: only the frame commands, which include it, build one
}

namespace smoketrace::cli {

// What the optical-depth pass alone takes from a scene (depths, explain --particle): the stand-ins, their
// density kernel and the cutoff. Plain scene data: `depths` needs nothing of render/ to build it.
struct DepthOptions {
    StandInShape shape{};
    DensityKernel kernel{};
    std::uint32_t cutoff = 0;  // 0 = none
};

// Which overrides a command reads: the optical-depth pass alone (depths, explain --particle) depends only on
// the stand-ins, their density kernel and the cutoff; a frame (render, explain --pixel) on all of them.
enum class OverrideSet { optical_depth, frame };

// --frames: "N" (render N frames) or "A:B" (frames A … B − 1 of the scene's sequence).
struct FramesArg {
    std::optional<long long> count;
    std::optional<std::pair<std::uint32_t, std::uint32_t>> range;
};

struct SceneOverrides {
    std::optional<std::string> mode, shape, kernel, compositing;
    std::optional<std::pair<int, int>> size;
    FramesArg frames;
    std::optional<long long> groups, cutoff, spp;

    // Reads the set's flags from `in` (each value checked; CliError names the flag).
    static SceneOverrides read(ArgReader& in, OverrideSet set);
    // The first override given that only a frame uses (--mode, --size, --frames, --groups, --compositing,
    // --spp), or null: what `explain --particle` refuses.
    [[nodiscard]] const char* frame_only_flag() const;
    // The scene file's settings with these overrides applied, checked against the scene: a size its camera's
    // field of view cannot resolve, more frames than its motion stays in range for. Throws CliError.
    [[nodiscard]] RenderOptions render_options(const SceneDescription& scene) const;
    // The scene file's shape, kernel and cutoff with --shape, --kernel and --cutoff applied: render_options()'s.
    [[nodiscard]] DepthOptions depth_options(const SceneDescription& scene) const;
    // The frames a run writes, [first, end): all `options.render.frames` of them, or --frames A:B of the
    // sequence (CliError when B is beyond it).
    [[nodiscard]] std::pair<std::uint32_t, std::uint32_t> frame_range(const RenderOptions& options) const;
};

// The help entries of the overrides, one definition for every command that lists them.
inline constexpr OptionHelp kModeHelp{
    "--mode", "basic|simple-shadow|full", "the scene's render.mode (full)",
    "basic: no optical depths, no shadows; simple-shadow: ground shadows 0 or 1; full: eq. 4.3 shadows"};
inline constexpr OptionHelp kSizeHelp{"--size", "WxH", "the scene's camera.width x height (512x512)",
                                      "image size in pixels, each side 1…16384"};
inline constexpr OptionHelp kGroupsHelp{"--groups", "G", "the scene's render.groups (1)",
                                        "particle groups: 1/G of the optical depths updated per frame"};
inline constexpr OptionHelp kCutoffHelp{"--cutoff", "K", "the scene's render.cutoff (0: none)",
                                        "a particle whose light ray meets more than K surfaces is fully dark"};
inline constexpr OptionHelp kShapeHelp{"--shape", "sphere|icosahedron|icosphere:L", "the scene's smoke.shape (sphere)",
                                       "particle stand-in for optical-depth and shadow rays; icosphere level L = 1…4"};
inline constexpr OptionHelp kKernelHelp{"--kernel", "uniform|gaussian|poly1|poly2", "the scene's smoke.kernel (uniform)",
                                        "the stand-ins' density for optical depth: uniform balls (eq. 3.1), or a "
                                        "smooth profile fitted to the baked puff, integrated in closed form"};
inline constexpr OptionHelp kCompositingHelp{"--compositing", "over|thesis", "the scene's render.compositing (over)",
                                             "over: front-to-back over operator; thesis: eq. 4.1 as published"};
inline constexpr OptionHelp kSppHelp{
    "--spp", "N", "the scene's render.spp (1)",
    "samples per pixel, 1…64, on a fixed stratified pattern and averaged (anti-aliasing); 1: the pixel's centre"};

}  // namespace smoketrace::cli
