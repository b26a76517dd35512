// One pixel of the view pass told step by step, see pixel_story.hpp.
#include <smoketrace/render/pixel_story.hpp>
#include <smoketrace/render/pixel_samples.hpp>

#include "per_ray_view.hpp"
#include "pixel_shading.hpp"

#include <stdexcept>
#include <string>
#include <utility>

namespace smoketrace {
namespace {

// The observer one_traversal_sample() reports to (pixel_shading.hpp): copies what it is told into a story.
struct SampleRecorder {
    const view::PixelShader& shader;
    std::span<const float> lengths;
    SampleStory& s;
    std::vector<ShadowHitStory> shadow_hits = {};  // a smooth kernel's shadow ray, until ground() is told
    float kernel_length = 0.0f;

    void opaque_surface(const TraceResult& r) {
        if (r.hit) s.opaque_t = r.committed.t;
    }
    void layers_collected(std::span<const view::Layer> layers, const TraceResult& r) {
        s.layers_met = layers.size();
        if (r.hit) s.search_cut_at = r.committed.t;  // LayerCollector accepted a hit: the pixel was opaque
    }
    void layer(const view::Layer& l, const glm::vec3& c, const view::PixelCompositor& comp) {
        LayerStory ls;
        ls.particle = l.particle;
        ls.t = l.t;
        ls.texture_alpha = shader.texture_alpha(l.particle, l.uv);
        ls.alpha = l.alpha;
        ls.light_map = shader.light_map(l);
        ls.length = l.particle < lengths.size() ? lengths[l.particle] : 0.0f;
        ls.particle_transmittance = shader.particle_transmittance(l.particle);
        ls.color = c;
        ls.weight_before = comp.front_weight();
        ls.contribution = comp.contribution(c, l.alpha);
        view::PixelCompositor behind = comp;  // a copy: what the compositor's own add() leaves behind this layer
        behind.add(c, l.alpha);
        ls.weight_after = behind.front_weight();
        s.layers.push_back(ls);
    }
    void shadow_hit(const TraceHit& h, double share) {
        shadow_hits.push_back(ShadowHitStory{h.instance_id, h.t, !h.front_face(), share});
    }
    void shadow_length(float l) { kernel_length = l; }
    void ground(const Ray* shadow_ray, const TraceResult* r, float shadow, const glm::vec3& c) {
        GroundStory g;
        g.t = s.opaque_t.value_or(0.0f);
        g.point = s.ray.origin + g.t * s.ray.direction;
        if (shadow_ray) {
            g.shadow_ray = true;
            g.shadow = *shadow_ray;
            g.point = shadow_ray->origin;  // the compositor's own ground point
            g.shadow_hit = r->hit;
            if (shader.shadow_sums_kernel()) {
                g.kernel_shadow = true;
                g.shadow_hit = !shadow_hits.empty();
                g.shadow_hits = std::move(shadow_hits);
                g.shadow_length = kernel_length;
            } else if (r->hit && shader.settings().mode == RenderMode::full) {
                g.shadow_particle = r->committed.instance_id;
                g.shadow_t = r->committed.t;
            }
        }
        g.shadow_factor = shadow;
        g.color = c;
        s.ground = g;
    }
    void background(const glm::vec3& bg, const view::PixelCompositor& comp) {
        s.end = s.ground ? SampleEnd::ground : SampleEnd::sky;
        s.background = bg;
        s.background_contribution = comp.contribution(bg, 1.0f);
    }
};

}  // namespace

PixelStory explain_pixel(const SmokeScene& scene, std::span<const Particle> particles, std::span<const float> lengths,
                         const SixwayTexture& texture, const Camera& camera, const ViewSettings& settings, int x,
                         int y) {
    if (x < 0 || y < 0 || x >= camera.width() || y >= camera.height()) {
        throw std::out_of_range("pixel " + std::to_string(x) + "," + std::to_string(y) + " is outside the " +
                                std::to_string(camera.width()) + "x" + std::to_string(camera.height()) +
                                " image (x 0…" + std::to_string(camera.width() - 1) + ", y 0…" +
                                std::to_string(camera.height() - 1) + ")");
    }
    const PixelSamples samples(settings.spp);
    const view::PixelShader shader(scene, particles, lengths, texture, settings);
    PixelStory story;
    story.x = x;
    story.y = y;
    story.mode = settings.mode;
    story.kernel = settings.kernel;
    story.sigma_t = settings.sigma_t;
    story.compositing = settings.compositing;
    story.transmittance_threshold = settings.transmittance_threshold;
    std::vector<view::Layer> layers;
    // render_view()'s per-ray loop (view_compositor.cpp): the same rays, summed in sample order, divided once.
    glm::vec3 sum(0.0f);
    for (int i = 0; i < samples.count(); ++i) {
        SampleStory& s = story.samples.emplace_back();
        s.offset = samples[i];
        s.ray = camera.ray_through(float(x) + s.offset.x, float(y) + s.offset.y, kViewRayTmin);
        s.end = SampleEnd::transmittance_threshold;  // unless the recorder is told of a background
        s.color = view::one_traversal_sample(shader, s.ray, layers, SampleRecorder{shader, lengths, s});
        sum += s.color;
    }
    story.color = sum / float(samples.count());
    return story;
}

PixelStory explain_pixel(const FrameRenderer& renderer, std::uint64_t frame, int x, int y) {
    const ViewSettings settings = renderer.view_settings(frame);
    return explain_pixel(renderer.smoke(), renderer.particles().particles(), renderer.depths().lengths(),
                         renderer.texture(), renderer.camera(), settings, x, y);
}

}  // namespace smoketrace
