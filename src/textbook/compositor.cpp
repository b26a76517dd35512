// The textbook frame, compositor (thesis 4.3.5, eqs. 4.1, 4.3): see compositor.hpp.
#include <smoketrace/textbook/compositor.hpp>
#include <smoketrace/textbook/trace.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace smoketrace::textbook {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// A billboard the camera ray passes through.
struct Layer {
    float t;
    std::uint32_t particle;
    glm::dvec2 uv;
    double alpha;
};

// Texture coordinates of a hit on a billboard: the quad is [−1, 1]² in its object xy (smoke_scene.cpp), as the
// triangles (0, 1, 2) and (0, 2, 3); uv is the texture's tangent space [0, 1]², v up.
glm::dvec2 billboard_uv(std::uint32_t triangle, glm::vec2 barycentrics) {
    const glm::dvec2 corner[4] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    const glm::dvec2 v1 = corner[triangle == 0 ? 1 : 2], v2 = corner[triangle == 0 ? 2 : 3];
    const double b1 = barycentrics.x, b2 = barycentrics.y;
    const glm::dvec2 p = (1.0 - b1 - b2) * corner[0] + b1 * v1 + b2 * v2;
    return 0.5 * (p + 1.0);
}

}  // namespace

double ground_shadow(const Shading& shading, const glm::vec3& point) {
    const ViewParameters& v = shading.view();
    // Toward the light, the stand-ins only (mask 1): the ground cannot shadow itself and billboards are for
    // camera rays. TMin 0: nothing at the ground point itself can be met.
    const Ray ray{point, 0.0f, glm::vec3(v.to_light), std::numeric_limits<float>::infinity()};
    const AccelScene& scene = shading.scene().scene();
    if (v.mode == RenderMode::simple_shadow) {
        const TraceResult r = trace(scene, ray, ray_flag_force_opaque | ray_flag_accept_first_hit_and_end_search,
                                    kStandInMask);
        return r.hit ? 0.0 : 1.0;
    }
    if (!v.kernel.smooth()) {
        // The thesis: the nearest particle's optical depth is the shadow's.
        const TraceResult r = trace(scene, ray, ray_flag_force_opaque, kStandInMask);
        return r.hit ? shading.particle_transmittance(r.committed.instance_id) : 1.0;
    }
    // A smooth kernel: every particle whose stand-in the ray leaves adds its share of the density-weighted
    // length (each is left exactly once; entries add nothing), summed in double; no cutoff.
    double l = 0.0;
    const glm::dvec3 direction = glm::normalize(v.to_light);
    trace(scene, ray, ray_flag_force_non_opaque, kStandInMask, [&](const TraceHit& h) {
        if (!h.front_face()) {
            const Particle& p = shading.particles()[h.instance_id];
            l += particle_stretch_integral(v.kernel, point, direction, p.center, p.radius);
        }
        return AnyHitDecision::ignore;
    });
    return transmittance(l, v.sigma_t);
}

glm::dvec3 camera_ray_color(const Shading& shading, const Ray& ray) {
    const ViewParameters& v = shading.view();
    const AccelScene& scene = shading.scene().scene();
    // 1. The opaque surface: the closest hit of anything but billboards and stand-ins (the ground).
    const TraceResult opaque = trace(scene, ray, ray_flag_force_opaque, kGroundMask);
    const double t_opaque = opaque.hit ? double(opaque.committed.t) : kInf;

    // 2. Every billboard strictly in front of it: an any-hit callback that notes each one and ignores it, so
    //    the search goes on and meets them all (in no particular order).
    std::vector<Layer> layers;
    Ray to_surface = ray;
    if (opaque.hit) to_surface.tmax = std::nextafter(opaque.committed.t, 0.0f);
    trace(scene, to_surface, ray_flag_force_non_opaque, kBillboardMask, [&](const TraceHit& h) {
        const glm::dvec2 uv = billboard_uv(h.primitive_index, h.barycentrics);
        const double alpha = shading.opacity(h.instance_id, uv, h.t, t_opaque);
        if (alpha > 0.0) layers.push_back({h.t, h.instance_id, uv, alpha});
        return AnyHitDecision::ignore;
    });

    // 3. Front to back: by distance, and layers at the same distance by particle, so that the order is the
    //    scene's and not the order the search met them in.
    std::sort(layers.begin(), layers.end(), [](const Layer& a, const Layer& b) {
        return a.t != b.t ? a.t < b.t : a.particle < b.particle;
    });
    glm::dvec3 color(0.0);
    double t_front = 1.0;  // "over": the transmittance of the layers in front
    double a_prev = 0.0;   // eq. 4.1: the previous layer's alpha
    for (const Layer& l : layers) {
        const glm::dvec3 c = shading.layer_color(l.particle, l.uv);
        if (v.compositing == Compositing::thesis) {
            color += (1.0 - a_prev) * c * l.alpha;  // eq. 4.1: c_tot += (1 − a_prev)·c_new·a_p
            a_prev = l.alpha;
            continue;
        }
        color += t_front * l.alpha * c;  // "over": C += T·a·c, T *= 1 − a
        t_front *= 1.0 - l.alpha;
        if (t_front < v.transmittance_threshold) return color;  // nothing behind shows any more
    }

    // 4. Behind the layers: the sky, or the ground with its shadow.
    glm::dvec3 background = v.background;
    if (opaque.hit) {
        const glm::vec3 point = ray.origin + opaque.committed.t * ray.direction;
        background = shading.ground_color(shading.ground_needs_shadow() ? ground_shadow(shading, point) : 1.0);
    }
    return color + (v.compositing == Compositing::thesis ? 1.0 - a_prev : t_front) * background;
}

}  // namespace smoketrace::textbook
