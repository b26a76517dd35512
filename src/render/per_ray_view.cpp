// The per-ray compositors, see per_ray_view.hpp and view_compositor.hpp.
#include "per_ray_view.hpp"

#include <smoketrace/trace/trace.hpp>

#include <cmath>
#include <limits>

namespace smoketrace::view {

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
            return comp.finish(h.hit ? ground_sample(shader, ray, h.committed.t) : shader.settings().background);
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
