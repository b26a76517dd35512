#pragma once
// One pixel of the view pass told step by step, for people learning the method (smoketrace explain --pixel,
// docs/explain.md): each sample's camera ray run through the per-ray compositor (one_traversal, the
// reference the tiled compositor matches bit for bit) with an observer that records what it does: the
// opaque surface, the billboard layers front to back with their colours (eq. 4.2) and weights, where the
// compositing stopped and why, and the ground with its shadow ray (eqs. 4.3, 4.4; under a smooth density
// kernel every particle the shadow ray leaves, with its share). The compositor's own
// code runs; the observer only listens, so the pixel is the one render_view() writes (tests/test_explain.cpp).
#include <smoketrace/geometry/ray.hpp>
#include <smoketrace/render/camera.hpp>
#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/render/sixway_texture.hpp>
#include <smoketrace/render/view_compositor.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace smoketrace {

// One billboard layer as the compositor reached it, front to back.
struct LayerStory {
    std::uint32_t particle = 0;
    float t = 0.0f;                   // along the camera ray
    float texture_alpha = 0.0f;       // the flipbook's alpha at the hit
    float alpha = 0.0f;               // texture alpha × the scene's alpha × the soft-particle fade
    float light_map = 0.0f;           // six-way light (thesis 4.2.2)
    float length = 0.0f;              // the particle's optical path length l (the optical-depth pass's)
    float particle_transmittance = 1.0f;  // exp(−l·σt) (1 in basic mode)
    glm::vec3 color{0.0f};            // c_new = c_p·exp(−l·σt) + c_amb (eq. 4.2)
    float weight_before = 1.0f;       // "over": the transmittance in front of it; thesis: 1 − a_prev
    float weight_after = 1.0f;        // the same behind it
    glm::vec3 contribution{0.0f};     // what it adds to the pixel: weight·a·c_new
};

// Why a sample's compositing ended.
enum class SampleEnd : std::uint8_t {
    transmittance_threshold,  // the layers left less than the threshold for what lies behind ("over" only)
    ground,                   // it reached the ground
    sky,                      // nothing left: no ground behind the layers, the background colour
};

// A surface a smooth kernel's shadow ray crossed, in the order its walk met them (pixel_shading.hpp).
struct ShadowHitStory {
    std::uint32_t particle = 0;
    float t = 0.0f;
    bool exit = false;   // it leaves the particle's stand-in (an entry adds nothing)
    double share = 0.0;  // an exit's: the particle's integral of the density along the ray (density_kernel.hpp)
};

struct GroundStory {
    float t = 0.0f;                   // along the camera ray
    glm::vec3 point{0.0f};
    bool shadow_ray = false;          // traced (not in basic mode, nor where the light is below the ground)
    Ray shadow;                       // the shadow ray, when traced
    bool shadow_hit = false;          // it met a stand-in
    std::uint32_t shadow_particle = 0;  // full mode: the nearest one, whose l casts the shadow
    float shadow_t = 0.0f;
    float shadow_factor = 1.0f;       // exp(−l·σt) of that particle (full), 0 (simple-shadow), 1 (lit)
    // Full mode with a smooth kernel: the shadow ray's every candidate instead of the nearest particle, the
    // sum l_g of the shares, and shadow_factor = exp(−σt·l_g).
    bool kernel_shadow = false;
    std::vector<ShadowHitStory> shadow_hits;
    float shadow_length = 0.0f;       // l_g
    glm::vec3 color{0.0f};            // c_base·(c_light·max(L·N, 0)·shadow + c_amb) (eqs. 4.3, 4.4)
};

struct SampleStory {
    glm::vec2 offset{0.5f};           // in the pixel, from its top-left corner (pixel_samples.hpp)
    Ray ray;
    std::optional<float> opaque_t;    // the opaque surface (the ground) behind the billboards
    std::size_t layers_met = 0;       // billboard layers with alpha > 0 collected in front of it
    std::optional<float> search_cut_at;  // the layers met made the pixel opaque: the billboard search stopped here
    std::vector<LayerStory> layers;   // the ones the compositor reached, front to back
    SampleEnd end = SampleEnd::sky;
    std::optional<GroundStory> ground;
    glm::vec3 background{0.0f};       // behind the layers: the ground's colour or the sky (unset at a threshold end)
    glm::vec3 background_contribution{0.0f};
    glm::vec3 color{0.0f};            // the sample's colour
};

struct PixelStory {
    int x = 0, y = 0;
    RenderMode mode = RenderMode::full;
    DensityKernel kernel{};
    float sigma_t = 0.0f;
    Compositing compositing = Compositing::over;
    float transmittance_threshold = 0.0f;
    std::vector<SampleStory> samples;  // settings.spp of them, in the order the view pass sums them
    glm::vec3 color{0.0f};             // their mean, the pixel render_view() writes (linear)
};

// Pixel (x, y) of the view pass with these inputs (render_view()'s). Throws std::out_of_range naming the
// pixel and the image size when it lies outside the camera's image.
[[nodiscard]] PixelStory explain_pixel(const SmokeScene& scene, std::span<const Particle> particles,
                                       std::span<const float> lengths, const SixwayTexture& texture,
                                       const Camera& camera, const ViewSettings& settings, int x, int y);

// The same for the frame `renderer` rendered last, `frame`.
[[nodiscard]] PixelStory explain_pixel(const FrameRenderer& renderer, std::uint64_t frame, int x, int y);

}  // namespace smoketrace
