#pragma once
// The textbook frame, shading: the colour of what a camera ray meets (thesis 4.3.5, ../shared/docs/method.md
// "View pass" and "Six-way lighting"). A billboard layer is lit by the six-way light map (4.2.2) and darkened
// by its particle's optical path length (eq. 4.2); the ground is lit by the light (eq. 4.4) and shadowed by
// the smoke toward the light (eq. 4.3). Read compositor.hpp next; frame.hpp puts the frame together.
#include <smoketrace/render/sixway_texture.hpp>
#include <smoketrace/smoke/density_kernel.hpp>
#include <smoketrace/smoke/scene_description.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <span>
#include <vector>

namespace smoketrace::textbook {

// What one frame's view is drawn with: the scene's colours and light, and the render settings.
struct ViewParameters {
    RenderMode mode = RenderMode::full;
    DensityKernel kernel{};         // full mode: uniform shadows from the nearest particle, smooth ones summed
    Compositing compositing = Compositing::over;
    double sigma_t = 1.0;           // extinction coefficient σt
    double alpha = 0.5;             // the billboards' opacity scale
    double softness = 0.3;          // soft-particle fade distance (Larsson 2010, 2.7); 0 = hard
    double transmittance_threshold = 1.0 / 255.0;  // "over" stops below this transmittance
    glm::dvec3 to_light{0.0, 1.0, 0.0};            // unit, toward the light
    glm::dvec3 light_color{1.0}, ambient{0.05}, background{0.53, 0.81, 0.92}, ground_color{0.8, 0.1, 0.1};
    int flipbook_frame = 0;         // the six-way flipbook's frame for particle 0 (particle i: + i)
    int spp = 1;                    // samples per pixel (render/pixel_samples.hpp)
};

// Transmittance along an optical path length l: T = exp(−l·σt) (eqs. 2.10, 2.12). σt = 0 is no extinction,
// also for a fully dark particle (l = ∞, where ∞·0 would be NaN).
double transmittance(double l, double sigma_t);

class Shading {
public:
    // `lengths`: each particle's optical path length l (unused in basic mode, which has no optical depth).
    Shading(const SmokeScene& scene, std::span<const Particle> particles, std::span<const float> lengths,
            const SixwayTexture& texture, const ViewParameters& view);

    // The opacity of particle p's billboard at texture coordinates uv (tangent space, v up), met at distance t
    // in front of the opaque surface at t_opaque (∞: none): the texture's alpha × the scene's alpha, faded to 0
    // where the surface behind is closer than `softness` (soft particles), so a quad never cuts a hard line
    // into the ground.
    [[nodiscard]] double opacity(std::uint32_t p, glm::dvec2 uv, double t, double t_opaque) const;
    // Its colour, eq. 4.2: c = lightMap · c_light · exp(−l·σt) + c_amb, lightMap = h·lx² + v·ly² + d·lz² with
    // the light in the billboard's tangent space (4.2.2).
    [[nodiscard]] glm::dvec3 layer_color(std::uint32_t p, glm::dvec2 uv) const;
    // exp(−l·σt) of particle p: what its billboard and the ground shadow it casts are darkened by.
    [[nodiscard]] double particle_transmittance(std::uint32_t p) const { return billboards_[p].transmittance; }

    // The ground's colour, eq. 4.4 with the shadow of eq. 4.3: c = c_base·(c_light·max(L·N, 0)·shadow + c_amb).
    [[nodiscard]] glm::dvec3 ground_color(double shadow) const;
    // Whether a ground point needs a shadow ray: the light must reach the ground's lit side, and basic mode has
    // no shadows.
    [[nodiscard]] bool ground_needs_shadow() const { return n_dot_l_ > 0.0 && view_.mode != RenderMode::basic; }

    [[nodiscard]] const ViewParameters& view() const { return view_; }
    [[nodiscard]] const SmokeScene& scene() const { return scene_; }
    [[nodiscard]] std::span<const Particle> particles() const { return particles_; }

private:
    struct Billboard {
        glm::dvec3 light_tangent;  // toward the light, in the billboard's tangent space (x right, y up, z to eye)
        int frame;                 // its flipbook frame
        double transmittance;      // exp(−l·σt), 1 in basic mode
    };
    const SmokeScene& scene_;
    std::span<const Particle> particles_;
    const SixwayTexture& texture_;
    ViewParameters view_;
    std::vector<Billboard> billboards_;
    double n_dot_l_ = 0.0;
};

}  // namespace smoketrace::textbook
