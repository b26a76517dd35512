// The per-ray compositors, see per_ray_view.hpp and view_compositor.hpp.
#include "per_ray_view.hpp"

#include <smoketrace/trace/trace.hpp>

#include <cmath>
#include <limits>

namespace smoketrace::view {
namespace {

// The ground at distance t along `ray`, with its own shadow ray (eqs. 4.3, 4.4).
glm::vec3 ground(const PixelShader& shader, const Ray& ray, float t) {
    if (!shader.ground_needs_shadow_ray()) return shader.ground_color(1.0f);
    const Ray shadow_ray{ray.origin + t * ray.direction, kShadowRayTmin, shader.settings().to_light,
                         std::numeric_limits<float>::infinity()};
    return shader.ground_color(
        shader.shadow(trace(shader.scene().scene(), shadow_ray, shader.shadow_ray_flags(), kStandInMask)));
}

}  // namespace

// First the opaque surface (the ground): a ray whose mask leaves out stand-ins and billboards, so the
// mask-grouped TLAS prunes both groups at its top. Then one traversal over the billboards strictly in front
// of it, each layer's opacity found as the any-hit callback meets it (thesis 4.3.5, in the spirit of
// Multi-Layer Alpha Tracing, Brüll & Grosch 2020), then sorted and composited front to back.
glm::vec3 one_traversal_sample(const PixelShader& shader, const Ray& ray, std::vector<Layer>& layers) {
    const AccelScene& scene = shader.scene().scene();
    const TraceResult opaque = trace(scene, ray, ray_flag_force_opaque, kOpaqueViewMask);
    const float t_opaque = opaque.hit ? opaque.committed.t : std::numeric_limits<float>::infinity();
    Ray billboard_ray = ray;
    if (opaque.hit) billboard_ray.tmax = std::nextafter(t_opaque, 0.0f);
    LayerCollector collect(shader, layers, t_opaque);
    trace(scene, billboard_ray, ray_flag_force_non_opaque, kBillboardMask, collect);
    PixelCompositor comp(shader.settings());
    if (!composite_layers(shader, layers, comp)) return comp.finish(glm::vec3(0.0f));
    return comp.finish(opaque.hit ? ground(shader, ray, t_opaque) : shader.settings().background);
}

glm::vec3 retrace_sample(const PixelShader& shader, const Ray& ray) {
    const SmokeScene& smoke = shader.scene();
    // The opaque surface first, for the soft-particle fade (the thesis had the depth buffer for that).
    const TraceResult opaque = trace(smoke.scene(), ray, ray_flag_cull_non_opaque, kViewRayMask);
    const float t_opaque = opaque.hit ? opaque.committed.t : std::numeric_limits<float>::infinity();
    PixelCompositor comp(shader.settings());
    Ray r = ray;
    for (;;) {
        const TraceResult h = trace(smoke.scene(), r, ray_flag_force_opaque, kViewRayMask);
        if (!h.hit || !smoke.is_billboard(h.committed.instance_index))
            return comp.finish(h.hit ? ground(shader, ray, h.committed.t) : shader.settings().background);
        const TraceHit& c = h.committed;
        Layer l{c.t, c.instance_id, billboard_uv(c.primitive_index, c.barycentrics), 0.0f};
        l.alpha = shader.layer_alpha(l.particle, l.t, l.uv, t_opaque);
        if (!comp.add(shader.layer_color(l), l.alpha)) return comp.finish(glm::vec3(0.0f));
        // Go on behind this quad: the next representable t (a quad at exactly the same depth is the one
        // place where the compositors may differ).
        r.tmin = std::nextafter(c.t, std::numeric_limits<float>::infinity());
    }
}

}  // namespace smoketrace::view
