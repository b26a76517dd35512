#pragma once
// What a pixel of the view pass computes once its rays have found their surfaces (thesis 4.3.5), shared by
// the tiled compositor (tiled_view.cpp) and the per-ray ones (per_ray_view.cpp), so that the two differ in
// how they find the layers and nothing else:
//   * a billboard layer's opacity (texture alpha × the scene's alpha × the soft-particle fade), known when
//     the layer is met, and its colour (six-way light map, eq. 4.2), looked up only for layers the
//     compositor reaches;
//   * the ground's colour (eq. 4.4) given its shadow (eq. 4.3), and the shadow ray that finds it: the
//     nearest particle's transmittance, or under a smooth density kernel every particle's share summed;
//   * front-to-back compositing of the layers sorted by depth, stopping below the transmittance threshold.
// Internal to the render layer (src/render/), not installed.
#include <smoketrace/core/radix_sort.hpp>
#include <smoketrace/render/sixway_texture.hpp>
#include <smoketrace/render/view_compositor.hpp>
#include <smoketrace/smoke/density_kernel.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>
#include <smoketrace/accel/trace_types.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

namespace smoketrace::view {

// TMin of shadow rays from the ground: the shadow ray sees stand-ins only (the ground cannot shadow
// itself, billboards are excluded by the thesis's mask ~2), so no self-intersection offset is needed.
inline constexpr float kShadowRayTmin = 0.0f;

// View rays see stand-ins never and billboards only through the any-hit pass: the rest is opaque.
inline constexpr std::uint8_t kOpaqueViewMask = kViewRayMask & static_cast<std::uint8_t>(~kBillboardMask);

// Transmittance along an optical path length l: T = exp(−τ) with τ = l·σt (thesis eqs. 2.10, 2.12).
// σt = 0 means no extinction at all, also for the "fully dark" l = ∞ (where ∞·0 would be NaN).
inline float beer_lambert(float l, float sigma_t) { return sigma_t == 0.0f ? 1.0f : std::exp(-l * sigma_t); }

// Texture coordinates of a billboard hit: the quad is [−1, 1]² in object xy (smoke_scene.cpp), split
// into triangles (0, 1, 2) and (0, 2, 3); uv is the tangent space of sixway_texture.hpp (v up).
inline glm::vec2 billboard_uv(std::uint32_t primitive, glm::vec2 b) {
    static constexpr glm::vec2 quad[4] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    const glm::vec2 v0 = quad[0], v1 = quad[primitive == 0 ? 1 : 2], v2 = quad[primitive == 0 ? 2 : 3];
    const glm::vec2 p = (1.0f - b.x - b.y) * v0 + b.x * v1 + b.y * v2;
    return {0.5f * (p.x + 1.0f), 0.5f * (p.y + 1.0f)};
}

// A billboard layer of a pixel, met but not yet coloured: its depth, particle, texture coordinates and
// opacity.
struct Layer {
    float t;
    std::uint32_t particle;
    glm::vec2 uv;
    float alpha;
};

// Sorts a pixel's layers front to back: by t, and layers at exactly the same t by particle, so that the order
// does not depend on the order the layers were met in (a tile meets them in another order than a lone ray).
inline void sort_layers(std::span<Layer> layers) {
    auto key = [](const Layer& l) {
        // t ≥ tmin > 0, so its bits order as the numbers do.
        return std::uint64_t(std::bit_cast<std::uint32_t>(l.t)) << 32 | l.particle;
    };
    if (layers.size() <= 16) return insertion_sort(layers, key);  // most pixels
    std::sort(layers.begin(), layers.end(), [&](const Layer& a, const Layer& b) { return key(a) < key(b); });
}

class PixelShader {
public:
    PixelShader(const SmokeScene& scene, std::span<const Particle> particles, std::span<const float> lengths,
                const SixwayTexture& texture, const ViewSettings& s)
        : scene_(scene), particles_(particles), texture_(texture), s_(s),
          kernel_shadow_(s.mode == RenderMode::full && s.kernel.smooth()),
          light_unit_(glm::normalize(glm::dvec3(s.to_light))) {
        validate(s.kernel);
        // Per particle, once per frame: the light in its billboard's tangent space (x right, y up, z toward
        // the eye), its flipbook frame and its Beer–Lambert factor exp(−l·σt) (eqs. 2.10, 2.12; basic mode
        // has no optical depth: l = 0).
        const bool optical_depth = s.mode != RenderMode::basic;
        billboards_.resize(particles.size());
        for (std::size_t i = 0; i < particles.size(); ++i) {
            const glm::dmat3 m = scene.scene().transform(std::uint32_t(particles.size() + i)).linear;
            const glm::dvec3 L(s.to_light);
            Billboard& b = billboards_[i];
            b.light_tangent = glm::vec3(glm::dot(L, glm::normalize(m[0])), glm::dot(L, glm::normalize(m[1])),
                                        glm::dot(L, glm::normalize(m[2])));
            b.frame = (s.flipbook_frame + int(i)) % texture.frame_count();
            b.transmittance = optical_depth ? beer_lambert(lengths[i], s.sigma_t) : 1.0f;
        }
        if (scene.has_ground()) ground_normal_ = glm::normalize(scene.ground_normal());
        n_dot_l_ = std::max(glm::dot(ground_normal_, s.to_light), 0.0f);
    }

    // The opacity of particle p's billboard met at distance t, texture coordinates uv, in front of the opaque
    // surface at t_opaque: texture alpha × the scene's alpha, faded where the surface behind is closer than
    // `softness` (soft particles, Larsson 2010, 2.7), so the quad does not cut a hard line into the ground.
    [[nodiscard]] float layer_alpha(std::uint32_t p, float t, glm::vec2 uv, float t_opaque) const {
        float alpha = texture_alpha(p, uv) * s_.alpha;
        if (s_.softness > 0.0f && t_opaque < std::numeric_limits<float>::infinity())
            alpha *= std::clamp((t_opaque - t) / s_.softness, 0.0f, 1.0f);
        return alpha;
    }

    // The flipbook's alpha at uv of particle p's billboard, before the scene's alpha and the fade.
    [[nodiscard]] float texture_alpha(std::uint32_t p, glm::vec2 uv) const {
        return texture_.alpha(texture_.footprint(uv, billboards_[p].frame));
    }

    // Its colour. Thesis 4.3.5: light map × light colour, attenuated by the particle's optical depth
    // (eq. 4.2): c_new = c_p·exp(−l·σt) + c_amb.
    [[nodiscard]] glm::vec3 layer_color(const Layer& l) const {
        return light_map(l) * s_.light_color * billboards_[l.particle].transmittance + s_.ambient;
    }
    // The six-way light map of a layer (thesis 4.2.2): h·lx² + v·ly² + d·lz² in its billboard's tangent space.
    [[nodiscard]] float light_map(const Layer& l) const {
        const Billboard& b = billboards_[l.particle];
        return texture_.light_map(texture_.footprint(l.uv, b.frame), b.light_tangent);
    }
    // exp(−l·σt) of particle p, as its layers and the shadows it casts use it (1 in basic mode).
    [[nodiscard]] float particle_transmittance(std::uint32_t p) const { return billboards_[p].transmittance; }

    // Whether the ground at a pixel needs a shadow ray, and the ray's flags and mask (thesis 4.3.5): toward
    // the light, stand-ins only; simple-shadow asks whether anything is in the way, full the nearest
    // particle (its optical depth is the shadow's), and full with a smooth kernel every particle on the way:
    // each candidate goes to any-hit (shadow_sums_kernel()).
    [[nodiscard]] bool ground_needs_shadow_ray() const { return n_dot_l_ > 0.0f && s_.mode != RenderMode::basic; }
    [[nodiscard]] std::uint32_t shadow_ray_flags() const {
        if (kernel_shadow_) return ray_flag_force_non_opaque;
        return s_.mode == RenderMode::simple_shadow
                   ? ray_flag_force_opaque | ray_flag_accept_first_hit_and_end_search | ray_flag_skip_closest_hit_shader
                   : ray_flag_force_opaque;
    }
    // The shadow a shadow ray's result casts (eq. 4.3): exp(−l·σt) of the nearest particle toward the light
    // (full), 0 if any is in the way (simple-shadow). Not for a smooth kernel's ray (kernel_shadow()).
    [[nodiscard]] float shadow(const TraceResult& r) const {
        if (!r.hit) return 1.0f;
        return s_.mode == RenderMode::simple_shadow ? 0.0f : billboards_[r.committed.instance_id].transmittance;
    }

    // Eq. 4.3 under a smooth density kernel (full mode): the ground point's shadow is exp(−σt·l_g), l_g the
    // density-weighted length of its shadow ray through every particle toward the light, the sum of their
    // closed-form shares as the optical-depth pass sums a particle's (kernel_bundle_sums.hpp): an any-hit
    // walk over all the stand-ins the ray meets, each exit adding shadow_share(), entries nothing, in double
    // in the order the walk meets them, l_g that sum rounded to float. The kernel's density is smooth, so
    // the shadow fades out toward the puffs' rims instead of ending at a disc's edge. No cutoff: the cutoff
    // is the optical-depth pass's (thesis 4.4.3), and a shadow ray is never "fully dark".
    [[nodiscard]] bool shadow_sums_kernel() const { return kernel_shadow_; }
    // The share of particle p, whose stand-in the shadow ray from `origin` leaves (particle_stretch_integral()).
    [[nodiscard]] double shadow_share(const glm::vec3& origin, std::uint32_t p) const {
        return particle_stretch_integral(s_.kernel, origin, light_unit_, particles_[p].center, particles_[p].radius);
    }
    // The shadow of a summed l_g: exp(−l_g·σt).
    [[nodiscard]] float kernel_shadow(float l) const { return beer_lambert(l, s_.sigma_t); }
    // The shadow rays' direction in double, unit length: what the shares are integrated along.
    [[nodiscard]] const glm::dvec3& light_unit() const { return light_unit_; }
    [[nodiscard]] std::span<const Particle> particles() const { return particles_; }

    // The ground's colour (thesis eq. 4.4 with the shadow of eq. 4.3): c = c_base·(c_light·max(L·N, 0)·shadow
    // + c_amb); the ambient term keeps shadowed ground from going black, as the particles' c_amb does (eq. 4.2).
    [[nodiscard]] glm::vec3 ground_color(float shadow) const {
        return s_.ground_color * (s_.light_color * (n_dot_l_ * shadow) + s_.ambient);
    }

    [[nodiscard]] const ViewSettings& settings() const { return s_; }
    [[nodiscard]] const SmokeScene& scene() const { return scene_; }

private:
    struct Billboard {
        glm::vec3 light_tangent;
        int frame;
        float transmittance;
    };
    const SmokeScene& scene_;
    std::span<const Particle> particles_;
    const SixwayTexture& texture_;
    const ViewSettings& s_;
    bool kernel_shadow_;
    glm::dvec3 light_unit_;
    std::vector<Billboard> billboards_;
    glm::vec3 ground_normal_{0.0f, 1.0f, 0.0f};
    float n_dot_l_ = 0.0f;
};

// Front-to-back compositing of one pixel's layers, then the background (ground or sky) behind them.
class PixelCompositor {
public:
    PixelCompositor() = default;
    explicit PixelCompositor(const ViewSettings& s) : s_(&s) {}

    // Returns false once nothing behind can contribute (transmittance below the threshold).
    bool add(const glm::vec3& c, float a) {
        color_ += contribution(c, a);
        if (s_->compositing == Compositing::over) {
            transmittance_ *= 1.0f - a;
            return transmittance_ >= s_->transmittance_threshold;
        }
        previous_alpha_ = a;
        return true;
    }
    // What add(c, a) would add to the colour now: the bits add() adds.
    [[nodiscard]] glm::vec3 contribution(const glm::vec3& c, float a) const {
        if (s_->compositing == Compositing::over) return transmittance_ * a * c;  // "over": C += T·a·c, T *= 1 − a
        return (1.0f - previous_alpha_) * c * a;  // thesis eq. 4.1: only the previous layer's alpha
    }
    // The weight the next layer gets before its own alpha: the transmittance in front of it ("over"), or
    // 1 − the previous layer's alpha (eq. 4.1).
    [[nodiscard]] float front_weight() const {
        return s_->compositing == Compositing::over ? transmittance_ : 1.0f - previous_alpha_;
    }
    [[nodiscard]] float transmittance() const { return transmittance_; }
    [[nodiscard]] const glm::vec3& color() const { return color_; }
    glm::vec3 finish(const glm::vec3& background) {
        add(background, 1.0f);
        return color_;
    }

private:
    const ViewSettings* s_ = nullptr;
    glm::vec3 color_{0.0f};
    float transmittance_ = 1.0f;
    float previous_alpha_ = 0.0f;
};

// A pixel's layers, met in any order, as the one-traversal compositors collect them: the any-hit callback of
// its billboard ray. A layer of zero opacity is dropped; once the layers met make the pixel opaque (the
// product of their (1 − a) below the threshold, which is the transmittance in front of the farthest of
// them), the callback accepts a hit at or behind the farthest, which (DXR rule 6) lowers the ray's tmax to
// it and prunes everything behind: the compositor would have stopped before reaching it, so the image is
// the same as with every layer collected (up to the order of the rounded products, far below an 8-bit
// step). The thesis's eq. 4.1 has no transmittance, so there every layer is collected.
class LayerCollector {
public:
    LayerCollector() = default;
    LayerCollector(const PixelShader& shader, std::vector<Layer>& layers, float t_opaque)
        : shader_(&shader), layers_(&layers), t_opaque_(t_opaque),
          may_stop_(shader.settings().compositing == Compositing::over) {
        layers.clear();
    }

    [[gnu::always_inline]] AnyHitDecision operator()(const TraceHit& h) {
        const glm::vec2 uv = billboard_uv(h.primitive_index, h.barycentrics);
        const float alpha = shader_->layer_alpha(h.instance_id, h.t, uv, t_opaque_);
        if (!(alpha > 0.0f)) return AnyHitDecision::ignore;
        layers_->push_back(Layer{h.t, h.instance_id, uv, alpha});
        transmittance_ *= 1.0f - alpha;
        t_farthest_ = std::max(t_farthest_, h.t);
        if (may_stop_ && transmittance_ < shader_->settings().transmittance_threshold && h.t >= t_farthest_)
            return AnyHitDecision::accept;
        return AnyHitDecision::ignore;
    }

private:
    const PixelShader* shader_ = nullptr;
    std::vector<Layer>* layers_ = nullptr;
    float t_opaque_ = 0.0f;
    bool may_stop_ = false;
    float transmittance_ = 1.0f, t_farthest_ = 0.0f;
};

// What a compositor tells an observer as it works (render/pixel_story.hpp records it for smoketrace explain).
// The compositors take the observer as a template argument: this one, the default, does nothing and
// compiles away, so the image's hot path is the same code with or without the hook.
struct NoPixelObserver {
    void opaque_surface(const TraceResult&) {}                      // the closest opaque hit, or none
    void layers_collected(std::span<const Layer>, const TraceResult&) {}  // met, before the sort; the billboard search
    void layer(const Layer&, const glm::vec3&, const PixelCompositor&) {}  // its colour, before it is added
    void shadow_hit(const TraceHit&, double) {}  // a smooth kernel's shadow ray: each candidate, its share (entry: 0)
    void shadow_length(float) {}                   // and their sum l_g
    void ground(const Ray*, const TraceResult*, float, const glm::vec3&) {}  // shadow ray (or none), shadow, colour
    void background(const glm::vec3&, const PixelCompositor&) {}    // behind the layers, before it is added
};

// A pixel's layers sorted front to back and composited, each coloured as the compositor reaches it. Returns
// false when they made the pixel opaque: the background is not seen (finish with black).
template <class Observer = NoPixelObserver>
inline bool composite_layers(const PixelShader& shader, std::span<Layer> layers, PixelCompositor& comp,
                             Observer&& observe = {}) {
    sort_layers(layers);
    for (const Layer& l : layers) {
        const glm::vec3 c = shader.layer_color(l);
        observe.layer(l, c, comp);
        if (!comp.add(c, l.alpha)) return false;
    }
    return true;
}

}  // namespace smoketrace::view
