#pragma once
// Contract: one_traversal_sample() is within kFastVsTextbookTolerance of textbook::camera_ray_color() for the same
// ray (float against double, world against object space: view_compositor.hpp); so is retrace_sample(), except
// on a ray that meets two billboards at the same float t, where it shows only one (tests/test_textbook_frame.cpp);
// both, like every compositor, may order two billboards a few ulps apart in depth otherwise (view_compositor.hpp).
//
// The per-ray compositors (view_compositor.hpp): every pixel sample's camera ray traced on its own with
// trace(). The reference the tiled compositor is held to, and the thesis's re-trace loop. Internal to the
// render layer.
#include "pixel_shading.hpp"

#include <smoketrace/geometry/ray.hpp>
#include <smoketrace/trace/trace.hpp>

#include <cmath>
#include <limits>
#include <vector>

namespace smoketrace::view {

// The ground at distance t along `ray`, with its own shadow ray (eqs. 4.3, 4.4).
template <class Observer = NoPixelObserver>
glm::vec3 ground_sample(const PixelShader& shader, const Ray& ray, float t, Observer&& observe = {}) {
    if (!shader.ground_needs_shadow_ray()) {
        const glm::vec3 c = shader.ground_color(1.0f);
        observe.ground(nullptr, nullptr, 1.0f, c);
        return c;
    }
    const Ray shadow_ray{ray.origin + t * ray.direction, kShadowRayTmin, shader.settings().to_light,
                         std::numeric_limits<float>::infinity()};
    const AccelScene& scene = shader.scene().scene();
    TraceResult r;
    float shadow;
    if (shader.shadow_sums_kernel()) {
        // Every stand-in toward the light (pixel_shading.hpp): the all-hits walk, which meets them in the
        // order trace_bundle() meets them for the tiled compositor's shadow rays, so the sum has its bits.
        double sum = 0.0;
        r = trace<TlasWalk::all_hits>(scene, shadow_ray, shader.shadow_ray_flags(), kStandInMask,
                                      [&](const TraceHit& h) {
                                          double share = 0.0;
                                          if (!h.front_face()) {
                                              share = shader.shadow_share(shadow_ray.origin, h.instance_id);
                                              sum += share;
                                          }
                                          observe.shadow_hit(h, share);
                                          return AnyHitDecision::ignore;
                                      });
        const float l = float(sum);
        observe.shadow_length(l);
        shadow = shader.kernel_shadow(l);
    } else {
        r = trace(scene, shadow_ray, shader.shadow_ray_flags(), kStandInMask);
        shadow = shader.shadow(r);
    }
    const glm::vec3 c = shader.ground_color(shadow);
    observe.ground(&shadow_ray, &r, shadow, c);
    return c;
}

// One traversal for the opaque surface, one over the billboards in front of it (LayerCollector).
//
// First the opaque surface (the ground): a ray whose mask leaves out stand-ins and billboards, so the
// mask-grouped TLAS prunes both groups at its top. Then one traversal over the billboards strictly in front
// of it, each layer's opacity found as the any-hit callback meets it (thesis 4.3.5, in the spirit of
// Multi-Layer Alpha Tracing, Brüll & Grosch 2020), then sorted and composited front to back. `observe` is
// told each step (pixel_shading.hpp); the default observer compiles away.
template <class Observer = NoPixelObserver>
glm::vec3 one_traversal_sample(const PixelShader& shader, const Ray& ray, std::vector<Layer>& layers,
                               Observer&& observe = {}) {
    const AccelScene& scene = shader.scene().scene();
    const TraceResult opaque = trace(scene, ray, ray_flag_force_opaque, kOpaqueViewMask);
    observe.opaque_surface(opaque);
    const float t_opaque = opaque.hit ? opaque.committed.t : std::numeric_limits<float>::infinity();
    Ray billboard_ray = ray;
    if (opaque.hit) billboard_ray.tmax = std::nextafter(t_opaque, 0.0f);
    LayerCollector collect(shader, layers, t_opaque);
    const TraceResult billboards = trace(scene, billboard_ray, ray_flag_force_non_opaque, kBillboardMask, collect);
    observe.layers_collected(layers, billboards);
    PixelCompositor comp(shader.settings());
    if (!composite_layers(shader, layers, comp, observe)) return comp.finish(glm::vec3(0.0f));
    const glm::vec3 background =
        opaque.hit ? ground_sample(shader, ray, t_opaque, observe) : shader.settings().background;
    observe.background(background, comp);
    return comp.finish(background);
}

// The thesis's loop: the closest billboard or the ground, shade, and trace again from just behind it.
glm::vec3 retrace_sample(const PixelShader& shader, const Ray& ray);

}  // namespace smoketrace::view
