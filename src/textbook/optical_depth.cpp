#include <smoketrace/textbook/optical_depth.hpp>

#include <smoketrace/textbook/trace.hpp>

#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstdint>

namespace smoketrace::textbook {

double length_in_smoke(std::span<const Crossing> sorted) {
    // Eq. 3.1: the counter starts at the number of particles around the origin, −Σ steps (the ray leaves each
    // of them once and enters none), steps by each crossing, and the ray is in smoke while it is > 0.
    int counter = 0;
    for (const Crossing& c : sorted) counter -= c.step;
    double length = 0.0, t_last = 0.0;
    for (const Crossing& c : sorted) {
        if (counter > 0) length += double(c.t) - t_last;
        counter += c.step;
        t_last = c.t;
    }
    return length;  // after the last crossing the counter is 0: nothing is left open
}

LightRayDepth light_ray_depth(const AccelScene& scene, std::span<const Particle> particles, const Ray& ray,
                              std::uint32_t cutoff, const DensityKernel& kernel) {
    // Thesis 4.3.2's any-hit shader: note each stand-in surface, entering or leaving, and IgnoreHit() so that the
    // search goes on. The ground, opaque, calls no any-hit: it is committed and shortens the ray.
    std::vector<Crossing> crossings;
    const TraceResult r = trace(scene, ray, ray_flag_none, kLightRayMask, [&](const TraceHit& h) {
        crossings.push_back({h.t, h.front_face() ? +1 : -1, h.instance_id});
        return AnyHitDecision::ignore;
    });
    // The statuses depend on the whole ray, so it is traced whole and the cutoff applied here. Crossings met
    // before the ground was found may lie behind it: only those in front count.
    if (r.hit) {
        const auto in_front = std::count_if(crossings.begin(), crossings.end(),
                                            [&](const Crossing& c) { return c.t < r.committed.t; });
        return {DepthStatus::occluded, std::uint32_t(in_front), kFullyDarkPathLength};
    }
    if (cutoff > 0 && crossings.size() > cutoff) return {DepthStatus::cutoff, cutoff + 1, kFullyDarkPathLength};
    const std::uint32_t hits = std::uint32_t(crossings.size());
    if (kernel.smooth()) {
        // A smooth kernel's l is the sum of each met particle's own integral (density_kernel.hpp): the ray
        // leaves every particle it meets exactly once, so each exit names one. A sum needs no sort.
        const glm::dvec3 unit_direction = glm::normalize(glm::dvec3(ray.direction));
        double l = 0.0;
        for (const Crossing& c : crossings)
            if (c.step < 0)
                l += particle_stretch_integral(kernel, ray.origin, unit_direction, particles[c.particle].center,
                                               particles[c.particle].radius);
        return {DepthStatus::ok, hits, float(l)};
    }
    // The hit resolver (thesis 4.3.3): the crossings came in the order the walk met them; sorted by t, eq. 3.1.
    std::sort(crossings.begin(), crossings.end(), [](const Crossing& a, const Crossing& b) { return a.t < b.t; });
    return {DepthStatus::ok, hits, float(length_in_smoke(crossings))};
}

OpticalDepths optical_depths(const SmokeScene& scene, std::span<const Particle> particles,
                             std::span<const std::uint32_t> which, const glm::vec3& to_light, std::uint32_t cutoff,
                             const DensityKernel& kernel) {
    validate(kernel);
    const glm::vec3 direction = glm::normalize(to_light);
    OpticalDepths out;
    out.lengths.resize(which.size());
    out.status.resize(which.size());
    out.hit_counts.resize(which.size());
    // Each particle's ray on its own, so any thread may take any of them and the output is the same.
    tbb::parallel_for(std::size_t(0), which.size(), [&](std::size_t k) {
        // From the centre, inside the particle's own stand-in, toward the light (optical_depth_pass.hpp):
        // tmin a fraction of the radius, so that a surface through the centre is not crossed at t = 0.
        const Particle& p = particles[which[k]];
        const Ray ray{p.center, optical_depth_tmin(p.radius), direction, kOpticalDepthTmax};
        const LightRayDepth d = light_ray_depth(scene.scene(), particles, ray, cutoff, kernel);
        out.lengths[k] = d.length;
        out.status[k] = d.status;
        out.hit_counts[k] = d.hits;
    });
    return out;
}

}  // namespace smoketrace::textbook
