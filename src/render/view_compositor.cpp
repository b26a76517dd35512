// The view pass (thesis 4.3.5), see view_compositor.hpp.
#include <smoketrace/core/radix_sort.hpp>
#include <smoketrace/trace/trace.hpp>
#include <smoketrace/render/pixel_samples.hpp>
#include <smoketrace/render/view_compositor.hpp>

#include <glm/geometric.hpp>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace smoketrace {
namespace {

constexpr int kTileSize = 16;  // 16×16 pixels: enough work per task, small enough to balance
// TMin of shadow rays from the ground: the shadow ray sees stand-ins only (the ground cannot shadow
// itself, billboards are excluded by the thesis's mask ~2), so no self-intersection offset is needed.
constexpr float kShadowRayTmin = 0.0f;

// Transmittance along an optical path length l: T = exp(−τ) with τ = l·σt (thesis eqs. 2.10, 2.12).
// σt = 0 means no extinction at all, also for the "fully dark" l = ∞ (where ∞·0 would be NaN).
float beer_lambert(float l, float sigma_t) { return sigma_t == 0.0f ? 1.0f : std::exp(-l * sigma_t); }

// One billboard layer of a pixel, already shaded.
struct Layer {
    float t;
    glm::vec3 color;
    float alpha;
};

// View rays see stand-ins never and billboards only through the any-hit pass: the rest is opaque.
constexpr std::uint8_t kOpaqueViewMask = kViewRayMask & static_cast<std::uint8_t>(~kBillboardMask);

struct Scratch {
    std::vector<Layer> layers, sort_buffer;
};

// Texture coordinates of a billboard hit: the quad is [−1, 1]² in object xy (smoke_scene.cpp), split
// into triangles (0, 1, 2) and (0, 2, 3); uv is the tangent space of sixway_texture.hpp (v up).
glm::vec2 billboard_uv(std::uint32_t primitive, glm::vec2 b) {
    static constexpr glm::vec2 quad[4] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    const glm::vec2 v0 = quad[0], v1 = quad[primitive == 0 ? 1 : 2], v2 = quad[primitive == 0 ? 2 : 3];
    const glm::vec2 p = (1.0f - b.x - b.y) * v0 + b.x * v1 + b.y * v2;
    return {0.5f * (p.x + 1.0f), 0.5f * (p.y + 1.0f)};
}

class PixelShader {
public:
    PixelShader(const SmokeScene& scene, std::span<const Particle> particles, std::span<const float> lengths,
                const SixwayTexture& texture, const ViewSettings& s)
        : scene_(scene), texture_(texture), s_(s),
          optical_depth_(s.mode != RenderMode::basic) {
        // The light in each billboard's tangent space (x right, y up, z toward the eye), once per frame.
        light_tangent_.resize(particles.size());
        for (std::size_t i = 0; i < particles.size(); ++i) {
            const glm::dmat3& m = scene.scene().instance(std::uint32_t(particles.size() + i)).object_to_world.linear;
            const glm::dvec3 L(s.to_light);
            light_tangent_[i] = glm::vec3(glm::dot(L, glm::normalize(m[0])), glm::dot(L, glm::normalize(m[1])),
                                          glm::dot(L, glm::normalize(m[2])));
        }
        if (scene.has_ground()) ground_normal_ = glm::normalize(scene.ground_normal());
        // Each particle's Beer–Lambert factor exp(−l·σt) (eqs. 2.10, 2.12), once per frame rather than
        // once per layer; basic mode has no optical depth (l = 0).
        transmittance_.resize(particles.size());
        for (std::size_t i = 0; i < particles.size(); ++i)
            transmittance_[i] = optical_depth_ ? beer_lambert(lengths[i], s.sigma_t) : 1.0f;
    }

    // Colour and opacity of the billboard of particle p, hit at distance t at texture coordinates uv;
    // t_opaque is the distance to the opaque surface behind it.
    void shade_layer(std::uint32_t p, float t, glm::vec2 uv, float t_opaque, glm::vec3& color, float& alpha) const {
        const int frame = (s_.flipbook_frame + int(p)) % texture_.frame_count();
        const SixwaySample tex = texture_.sample(uv, frame);
        alpha = tex.alpha * s_.alpha;
        // Soft particles (Larsson 2010, 2.7): fade where the opaque surface behind is closer than
        // `softness`, so the quad does not cut a hard line into the ground.
        if (s_.softness > 0.0f && t_opaque < std::numeric_limits<float>::infinity())
            alpha *= std::clamp((t_opaque - t) / s_.softness, 0.0f, 1.0f);
        // Thesis 4.3.5: light map × light colour, attenuated by the particle's optical depth (eq. 4.2):
        // c_new = c_p·exp(−l·σt) + c_amb. Basic mode has no optical depth: l = 0.
        const glm::vec3 c_p = sixway_light_map(tex, light_tangent_[p]) * s_.light_color;
        color = c_p * transmittance_[p] + s_.ambient;
    }

    // The ground at distance t along `ray` (thesis eq. 4.4 with the shadow of eq. 4.3):
    // c = c_base·(c_light·max(L·N, 0)·shadow + c_amb); shadow = exp(−l·σt) with l of the nearest particle
    // toward the light (full), 0 if any particle is in the way (simple-shadow), 1 in basic mode. The
    // ambient term keeps shadowed ground from going black, as the particles' c_amb does (eq. 4.2).
    glm::vec3 shade_ground(const Ray& ray, float t) const {
        const float n_dot_l = std::max(glm::dot(ground_normal_, s_.to_light), 0.0f);
        float shadow = 1.0f;
        if (n_dot_l > 0.0f && s_.mode != RenderMode::basic) {
            const Ray shadow_ray{ray.origin + t * ray.direction, kShadowRayTmin, s_.to_light,
                                 std::numeric_limits<float>::infinity()};
            if (s_.mode == RenderMode::simple_shadow) {
                const auto r = trace(scene_.scene(), shadow_ray,
                                     ray_flag_force_opaque | ray_flag_accept_first_hit_and_end_search |
                                         ray_flag_skip_closest_hit_shader,
                                     kStandInMask);
                if (r.hit) shadow = 0.0f;
            } else {
                const auto r = trace(scene_.scene(), shadow_ray, ray_flag_force_opaque, kStandInMask);
                if (r.hit) shadow = transmittance_[r.committed.instance_id];
            }
        }
        return s_.ground_color * (s_.light_color * (n_dot_l * shadow) + s_.ambient);
    }

    [[nodiscard]] const ViewSettings& settings() const { return s_; }
    [[nodiscard]] const SmokeScene& scene() const { return scene_; }

private:
    const SmokeScene& scene_;
    const SixwayTexture& texture_;
    const ViewSettings& s_;
    bool optical_depth_;
    std::vector<glm::vec3> light_tangent_;
    std::vector<float> transmittance_;
    glm::vec3 ground_normal_{0.0f, 1.0f, 0.0f};
};

// Front-to-back compositing of one pixel's layers, then the background (ground or sky) behind them.
class PixelCompositor {
public:
    explicit PixelCompositor(const ViewSettings& s) : s_(s) {}

    // Returns false once nothing behind can contribute (transmittance below the threshold).
    bool add(const glm::vec3& c, float a) {
        if (s_.compositing == Compositing::over) {
            color_ += transmittance_ * a * c;  // the "over" operator: C += T·a·c, T *= 1 − a
            transmittance_ *= 1.0f - a;
            return transmittance_ >= s_.transmittance_threshold;
        }
        color_ += (1.0f - previous_alpha_) * c * a;  // thesis eq. 4.1: only the previous layer's alpha
        previous_alpha_ = a;
        return true;
    }
    glm::vec3 finish(const glm::vec3& background) {
        add(background, 1.0f);
        return color_;
    }

private:
    const ViewSettings& s_;
    glm::vec3 color_{0.0f};
    float transmittance_ = 1.0f;
    float previous_alpha_ = 0.0f;
};

// One pixel in two rays. First the opaque surface (the ground): a ray whose mask leaves out stand-ins and
// billboards, so the mask-grouped TLAS prunes both groups at its top. Then one traversal over the
// billboards in front of it, shading each layer as the any-hit callback meets it (thesis 4.3.5, in the
// spirit of Multi-Layer Alpha Tracing, Brüll & Grosch 2020): fully transparent texels are dropped, the
// rest are sorted by t with the resolver's radix sort and composited front to back.
//
// Early termination, exact: the product of (1 − a) over the layers collected so far is the transmittance
// in front of the farthest of them. Once it is below the threshold, nothing behind that layer can reach
// the pixel, so the callback accepts the hit, which (DXR rule 6) shrinks the ray's tmax to its t and
// prunes every box behind it. The compositor would have stopped there anyway: the image is the same as
// with every layer collected (up to the order of the rounded products, far below an 8-bit step). The
// thesis's eq. 4.1 has no transmittance, so it collects every layer.
glm::vec3 one_traversal_pixel(const PixelShader& shader, const Ray& ray, Scratch& scratch) {
    const AccelScene& scene = shader.scene().scene();
    const ViewSettings& s = shader.settings();
    const TraceResult opaque = trace(scene, ray, ray_flag_force_opaque, kOpaqueViewMask);
    const float t_opaque = opaque.hit ? opaque.committed.t : std::numeric_limits<float>::infinity();

    std::vector<Layer>& layers = scratch.layers;
    layers.clear();
    Ray billboard_ray = ray;
    if (opaque.hit) billboard_ray.tmax = std::nextafter(t_opaque, 0.0f);  // layers strictly in front
    const bool may_stop = s.compositing == Compositing::over;
    float transmittance = 1.0f, t_farthest = 0.0f;
    auto collect = [&](const TraceHit& h) {
        Layer l{h.t, glm::vec3(0.0f), 0.0f};
        shader.shade_layer(h.instance_id, h.t, billboard_uv(h.primitive_index, h.barycentrics), t_opaque, l.color,
                           l.alpha);
        if (!(l.alpha > 0.0f)) return AnyHitDecision::ignore;
        layers.push_back(l);
        transmittance *= 1.0f - l.alpha;
        t_farthest = std::max(t_farthest, h.t);
        if (may_stop && transmittance < s.transmittance_threshold && h.t >= t_farthest)
            return AnyHitDecision::accept;
        return AnyHitDecision::ignore;
    };
    trace(scene, billboard_ray, ray_flag_force_non_opaque, kBillboardMask, collect);
    scratch.sort_buffer.resize(layers.size());
    sort_by_float_key(std::span<Layer>(layers), std::span<Layer>(scratch.sort_buffer),
                      [](const Layer& l) { return l.t; });

    PixelCompositor comp(s);
    for (const Layer& l : layers)
        if (!comp.add(l.color, l.alpha)) return comp.finish(glm::vec3(0.0f));
    return comp.finish(opaque.hit ? shader.shade_ground(ray, t_opaque) : s.background);
}

// The thesis's loop: closest billboard or ground, shade, and trace again from just behind the billboard.
glm::vec3 retrace_pixel(const PixelShader& shader, const Ray& ray) {
    const SmokeScene& smoke = shader.scene();
    // The opaque surface first, for the soft-particle fade (the thesis had the depth buffer for that).
    const TraceResult opaque = trace(smoke.scene(), ray, ray_flag_cull_non_opaque, kViewRayMask);
    const float t_opaque = opaque.hit ? opaque.committed.t : std::numeric_limits<float>::infinity();
    PixelCompositor comp(shader.settings());
    Ray r = ray;
    for (;;) {
        const TraceResult h = trace(smoke.scene(), r, ray_flag_force_opaque, kViewRayMask);
        if (!h.hit || !smoke.is_billboard(h.committed.instance_index))
            return comp.finish(h.hit ? shader.shade_ground(ray, h.committed.t) : shader.settings().background);
        glm::vec3 c;
        float a;
        shader.shade_layer(h.committed.instance_id, h.committed.t,
                           billboard_uv(h.committed.primitive_index, h.committed.barycentrics), t_opaque, c, a);
        if (!comp.add(c, a)) return comp.finish(glm::vec3(0.0f));
        // Go on behind this quad: the next representable t (a quad at exactly the same depth is the one
        // place where the two compositors may differ).
        r.tmin = std::nextafter(h.committed.t, std::numeric_limits<float>::infinity());
    }
}

}  // namespace

void render_view(const SmokeScene& scene, std::span<const Particle> particles, std::span<const float> lengths,
                 const SixwayTexture& texture, const Camera& camera, const ViewSettings& settings, ImageRgba& image) {
    if (!scene.has_billboards() && !particles.empty())
        throw std::invalid_argument("render_view: the scene was built without billboards");
    // Every pixel is written below: a frame of the same size reuses the buffer (no page faults).
    if (image.width != camera.width() || image.height != camera.height())
        image = ImageRgba(camera.width(), camera.height(), ImageRgba::Uninitialized{});
    const PixelSamples samples(settings.spp);
    const PixelShader shader(scene, particles, lengths, texture, settings);
    tbb::enumerable_thread_specific<Scratch> scratch;
    const int tiles_x = (camera.width() + kTileSize - 1) / kTileSize;
    const int tiles_y = (camera.height() + kTileSize - 1) / kTileSize;
    tbb::parallel_for(0, tiles_x * tiles_y, [&](int tile) {
        Scratch& local = scratch.local();
        const int x0 = (tile % tiles_x) * kTileSize, y0 = (tile / tiles_x) * kTileSize;
        const int x1 = std::min(x0 + kTileSize, camera.width()), y1 = std::min(y0 + kTileSize, camera.height());
        for (int y = y0; y < y1; ++y)
            for (int x = x0; x < x1; ++x) {
                // Summed in sample order and divided once: the same bits on any thread. With one sample the
                // offset is (0.5, 0.5), the ray is camera.ray(x, y) and 0 + c, c / 1 leave its colour as it is.
                // x + offset rounds by at most 2^-11 (x < 2^14) and the offsets keep 1/(2·spp) >= 2^-7 from
                // the pixel's sides, so a sample never leaves its pixel.
                glm::vec3 sum(0.0f);
                for (int i = 0; i < samples.count(); ++i) {
                    const glm::vec2 o = samples[i];
                    const Ray ray = camera.ray_through(float(x) + o.x, float(y) + o.y, kViewRayTmin);
                    sum += settings.compositor == CompositorKind::one_traversal
                               ? one_traversal_pixel(shader, ray, local)
                               : retrace_pixel(shader, ray);
                }
                image.at(x, y) = glm::vec4(sum / float(samples.count()), 1.0f);
            }
    });
}

}  // namespace smoketrace
