#pragma once
// The textbook frame, the loop (thesis 4.3, figure 4.1; method.md "Render loop"): per frame, the particles
// move, the scene's instances follow them and the billboards turn to the camera, this frame's particle group
// gets its optical depths (4.3.2–4.3.3, 4.4.2; none in basic mode), and every pixel is the mean of its
// samples' camera rays (compositor.hpp). Render modes (3.2): basic, simple-shadow, full.
#include <smoketrace/core/image.hpp>
#include <smoketrace/render/camera.hpp>
#include <smoketrace/render/sixway_texture.hpp>
#include <smoketrace/smoke/density_kernel.hpp>
#include <smoketrace/smoke/particle_system.hpp>
#include <smoketrace/smoke/scene_description.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>
#include <smoketrace/textbook/shading.hpp>

#include <cstdint>
#include <vector>

namespace smoketrace::textbook {

// What a render takes besides the scene file.
struct FrameOptions {
    RenderSettings render;  // mode, cutoff, groups, softness, threshold, compositing, spp
    StandInShape shape{};
    DensityKernel kernel = kPoly1Kernel;  // the stand-ins' density: optical depths and ground shadows
    int width = 512, height = 512;

    static FrameOptions from_scene(const SceneDescription& scene);  // the scene file's own settings and size
};

class FrameLoop {
public:
    // Throws std::invalid_argument when groups < 1 or spp is outside 1…kMaxSpp.
    FrameLoop(const SceneDescription& scene, const FrameOptions& options, const SixwayTexture& texture);

    // Renders frame `frame` (0, 1, 2, …; particles advance one step per frame) into `image`. Frames must come in
    // increasing order; frames passed over are advanced (particles, scene, optical depths), not drawn. The image
    // is the same for any number of threads.
    void render(std::uint64_t frame, ImageRgba& image);

    // Each particle's optical path length l as of the last frame (0 before its first update, ∞ fully dark).
    [[nodiscard]] const std::vector<float>& lengths() const { return lengths_; }
    // What frame `frame` is drawn with: the scene's colours and light, the options' settings.
    [[nodiscard]] ViewParameters view_parameters(std::uint64_t frame) const;

private:
    void advance_to(std::uint64_t frame);

    const SceneDescription& desc_;
    FrameOptions options_;
    const SixwayTexture& texture_;
    ParticleSystem particles_;
    SmokeScene scene_;
    Camera camera_;
    std::vector<float> lengths_;
    std::int64_t frame_ = -1;  // the frame the scene stands at
};

}  // namespace smoketrace::textbook
