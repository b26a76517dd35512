#pragma once
// Contract: within kFastVsTextbookTolerance per pixel and channel (tests/test_textbook_frame.cpp) of the textbook
// view (textbook/frame.hpp, compositor.hpp), not bit for bit: it shades in float where the textbook shades in
// double, and its rays meet billboards and stand-ins in world space where textbook::trace works in object space.
// Exception: two billboards within a few ulps of the same depth on a ray may be composited in either order
// (t rounds differently in the two spaces): that sample moves by T·a1·a2·|c1 − c2|, its pixel by that over spp
// (measured: 3.9e-4 at one pixel of two_tubes_above.json at 512², spp 4).
//
// The view pass (thesis 4.3.5): per pixel, the billboards along the camera ray are shaded with six-way
// lighting and attenuated by their particle's optical depth, composited front to back over the ground
// (lit, with a shadow ray) or the sky.
//
// Three compositors give the same image (tests/test_view_compositor.cpp states the tolerance):
//  * tiled (default): the camera rays of a 16×16 block of pixels traced together (trace_tile(), one walk of
//    the top level per block, each billboard tested for sixteen rays in one SIMD step), then per pixel what
//    one_traversal does, the ground's shadow rays traced thirty-two at a time (trace_bundle()). Every
//    sample is bit for bit one_traversal's: the two trace calls give each ray exactly what trace() does.
//  * one_traversal (the per-ray reference): one ray finds the opaque surface, then a single billboard
//    traversal whose any-hit callback collects every layer in front of it (Multi-Layer Alpha Tracing, Brüll
//    & Grosch 2020, with an unbounded layer list); the layers are sorted by t and composited until the
//    remaining transmittance drops below a threshold, a layer's colour looked up only when it is reached.
//    Once the layers already met make the pixel opaque, the callback accepts a hit to cut the traversal
//    short (exact: see src/render/pixel_shading.hpp);
//  * retrace (the thesis's loop): trace the closest billboard, shade it, composite, and trace again from
//    just behind it, until the ground, the sky or the threshold.
#include <smoketrace/render/camera.hpp>
#include <smoketrace/core/image.hpp>
#include <smoketrace/core/simd/level.hpp>
#include <smoketrace/core/work_progress.hpp>
#include <smoketrace/smoke/scene_description.hpp>
#include <smoketrace/render/sixway_texture.hpp>
#include <smoketrace/smoke/density_kernel.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>

#include <span>

namespace smoketrace {

enum class CompositorKind : std::uint8_t { tiled, one_traversal, retrace };

// TMin of view rays (thesis 4.3.5): 1e-3 in scene units, clear of the camera's own position.
inline constexpr float kViewRayTmin = 1e-3f;

struct ViewSettings {
    RenderMode mode = RenderMode::full;
    // The stand-ins' density (density_kernel.hpp). In full mode a smooth kernel's ground shadow sums every
    // particle toward the light (pixel_shading.hpp); uniform keeps the thesis's nearest particle (eq. 4.3).
    DensityKernel kernel{};
    Compositing compositing = Compositing::over;
    CompositorKind compositor = CompositorKind::tiled;
    float sigma_t = 1.0f;
    float alpha = 0.5f;
    float softness = 0.3f;                        // soft-particle fade distance (Larsson 2.7); 0 = hard
    float transmittance_threshold = 1.0f / 255.0f;  // stop compositing below this transmittance
    glm::vec3 to_light{0.0f, 1.0f, 0.0f};         // unit
    glm::vec3 light_color{1.0f};
    glm::vec3 ambient{0.05f};
    glm::vec3 background{0.53f, 0.81f, 0.92f};
    glm::vec3 ground_color{0.8f, 0.1f, 0.1f};
    int flipbook_frame = 0;                       // animation frame of the six-way flipbook
    int spp = 1;                                  // samples per pixel, 1…kMaxSpp (pixel_samples.hpp)
    WorkProgress* progress = nullptr;             // where the pixels drawn are counted (a display); null: nowhere
};

// Renders one image. `lengths` holds each particle's optical path length (ignored in basic mode).
// Each pixel is the plain mean (a box filter) of its settings.spp samples at the points of pixel_samples.hpp,
// in linear colour; spp 1 traces camera.ray(x, y) and gives exactly that ray's colour. Parallel over 16×16
// tiles (TBB); each pixel depends on nothing but its own rays, summed in sample order, so the image is the
// same whatever the thread count. Throws std::invalid_argument when spp is outside 1…kMaxSpp or the kernel
// is not valid (density_kernel.hpp's validate()).
void render_view(const SmokeScene& scene, std::span<const Particle> particles, std::span<const float> lengths,
                 const SixwayTexture& texture, const Camera& camera, const ViewSettings& settings, ImageRgba& image);

namespace detail {
// render_view()'s blocks at one kernel level (core/simd/dispatch.hpp), `image` already of the camera's size:
// view_compositor.cpp, compiled once per level, instantiates it for the level it is compiled for.
template <simd::Level L>
void render_view_at_level(const SmokeScene& scene, std::span<const Particle> particles,
                          std::span<const float> lengths, const SixwayTexture& texture, const Camera& camera,
                          const ViewSettings& settings, ImageRgba& image);
}  // namespace detail

}  // namespace smoketrace
