#pragma once
// Contract: frame by frame the particles, light and particle groups of textbook::FrameLoop (textbook/frame.hpp),
// each image within kFastVsTextbookTolerance of its image per pixel (tests/test_textbook_frame.cpp): float
// shading and world-space hits against the textbook's double and object space (view_compositor.hpp), and the
// fast optical-depth pass's lengths against the textbook's (smoke/optical_depth_pass.hpp states that contract).
//
// One frame of the thesis's render loop (4.3, figure 4.1), and the sequence of frames (5.2.2):
//   advance particles → TLAS update (none / refit / rebuild) → optical-depth pass and resolve for this
//   frame's particle group (skipped in basic mode) → view pass → image.
// Work a frame does not need is skipped: basic mode never runs the optical-depth pass; a frame in which
// no particle moved and the light did not turn does no TLAS work and no optical-depth work, and redraws
// only the view (the billboards' flipbook advances every frame). The previous image is kept as it is only
// when the flipbook frame is also the same (a one-frame flipbook).
#include <smoketrace/render/camera.hpp>
#include <smoketrace/core/frame_timings.hpp>
#include <smoketrace/core/image.hpp>
#include <smoketrace/core/work_progress.hpp>
#include <smoketrace/smoke/optical_path_lengths.hpp>
#include <smoketrace/smoke/particle_system.hpp>
#include <smoketrace/smoke/scene_description.hpp>
#include <smoketrace/render/sixway_texture.hpp>
#include <smoketrace/render/view_compositor.hpp>

#include <memory>

namespace smoketrace {

// Everything a render takes besides the scene file (the command line overrides the file's values).
struct RenderOptions {
    RenderSettings render;            // mode, cutoff, groups, frames, softness, threshold, compositing, spp
    StandInShape shape{};
    DensityKernel kernel = kPoly1Kernel;  // the stand-ins' density: optical depths and shadows (as SmokeDescription's)
    int width = 512, height = 512;
    CompositorKind compositor = CompositorKind::tiled;
    HitSort sort = HitSort::adaptive;

    // The scene file's own settings and camera size.
    static RenderOptions from_scene(const SceneDescription& scene);
};

struct FrameReport {
    FrameTimings timings;
    TlasUpdate tlas = TlasUpdate::none;
    std::size_t depths_updated = 0;  // particles traced this frame
    bool reused_previous = false;    // nothing changed, the flipbook frame neither: the previous image was kept
};

class FrameRenderer {
public:
    FrameRenderer(const SceneDescription& scene, const RenderOptions& options, const SixwayTexture& texture);

    // Renders frame `frame` (0, 1, 2, … in order: particles advance one step per frame) into `image`.
    FrameReport render(std::uint64_t frame, ImageRgba& image);
    // Brings the scene to where a full run stands after frames 0 … frame − 1 without drawing them, so that
    // render(frame) gives the full run's image bit for bit (render --frames A:B): particles, light and TLAS
    // advance frame by frame as render() advances them; the optical depths are traced only in the frames
    // whose values are still in use at `frame` (each group's last update). From a fresh renderer or after
    // the last frame rendered; frame >= the next frame.
    void skip_to(std::uint64_t frame);
    // Where render() and skip_to() count their stages' work (TLAS update, optical depths, view) for a progress
    // display; null (the default): nowhere. The images are the same either way.
    void count_progress(WorkProgress* progress) { progress_ = progress; }

    [[nodiscard]] const OpticalPathLengths& depths() const { return depths_; }
    [[nodiscard]] const ParticleSystem& particles() const { return particles_; }
    [[nodiscard]] const SmokeScene& smoke() const { return smoke_; }
    [[nodiscard]] const Camera& camera() const { return camera_; }
    [[nodiscard]] const SixwayTexture& texture() const { return texture_; }
    // What the view pass of frame `frame` is drawn with: the options, the scene's colours and the light.
    [[nodiscard]] ViewSettings view_settings(std::uint64_t frame) const;

private:
    // What render() does before it draws: advances to `frame` (the next one), updates the TLAS and, when
    // trace_depths, this frame's optical depths. True when nothing changed since the previous frame.
    bool advance_to(std::uint64_t frame, bool trace_depths, FrameReport& report);
    // Whether frame `frame` changes nothing (no particle moves and the light does not turn).
    [[nodiscard]] bool still_at(std::uint64_t frame) const;

    const SceneDescription& desc_;
    RenderOptions options_;
    const SixwayTexture& texture_;
    ParticleSystem particles_;
    SmokeScene smoke_;
    Camera camera_;
    OpticalPathLengths depths_;
    std::int64_t last_frame_ = -1;
    glm::vec3 last_light_{0.0f};
    int last_flipbook_frame_ = -1;  // the flipbook frame of the image last drawn
    WorkProgress* progress_ = nullptr;
};

}  // namespace smoketrace
