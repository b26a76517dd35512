#include <smoketrace/textbook/optical_depth.hpp>

#include <smoketrace/textbook/trace.hpp>

#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>

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

OpticalDepths optical_depths(const SmokeScene& scene, std::span<const Particle> particles,
                             std::span<const std::uint32_t> which, const glm::vec3& to_light, std::uint32_t cutoff,
                             const DensityKernel& kernel) {
    validate(kernel);
    const glm::vec3 direction = glm::normalize(to_light);
    const glm::dvec3 unit_direction = glm::normalize(glm::dvec3(direction));  // a smooth kernel's, in double
    const std::size_t n = which.size();
    OpticalDepths out{std::vector<float>(n, kFullyDarkPathLength), std::vector<DepthStatus>(n),
                      std::vector<std::uint32_t>(n)};
    // Each particle's ray on its own, so any thread may take any of them and the output is the same.
    tbb::parallel_for(std::size_t(0), n, [&](std::size_t k) {
        // From the centre toward the light; tmin a fraction of the radius (optical_depth_pass.hpp).
        const Particle& p = particles[which[k]];
        const Ray ray{p.center, optical_depth_tmin(p.radius), direction, kOpticalDepthTmax};
        // Thesis 4.3.2's any-hit shader: note each stand-in surface, entering or leaving, and IgnoreHit() so that
        // the search goes on. The ground, opaque, calls no any-hit: it is committed and shortens the ray.
        std::vector<Crossing> crossings;
        const TraceResult r = trace(scene.scene(), ray, ray_flag_none, kLightRayMask, [&](const TraceHit& h) {
            crossings.push_back({h.t, h.front_face() ? +1 : -1, h.instance_id});
            return AnyHitDecision::ignore;
        });
        // The statuses depend on the whole ray, traced whole, the cutoff applied here; fully dark (thesis 4.3.3)
        // unless ok. Crossings met before the ground was found may lie behind it.
        const auto in_front = [&](const Crossing& c) { return !r.hit || c.t < r.committed.t; };
        const auto hits = std::uint32_t(std::count_if(crossings.begin(), crossings.end(), in_front));
        out.status[k] = r.hit                          ? DepthStatus::occluded
                        : cutoff > 0 && hits > cutoff ? DepthStatus::cutoff
                                                      : DepthStatus::ok;
        out.hit_counts[k] = out.status[k] == DepthStatus::cutoff ? cutoff + 1 : hits;
        if (out.status[k] != DepthStatus::ok) return;
        if (kernel.smooth()) {  // l: each met particle's integral (density_kernel.hpp), one per exit; no sort
            double l = 0.0;
            for (const Crossing& c : crossings)
                if (c.step < 0)
                    l += particle_stretch_integral(kernel, ray.origin, unit_direction, particles[c.particle].center,
                                                   particles[c.particle].radius);
            out.lengths[k] = float(l);
            return;
        }
        // The hit resolver (thesis 4.3.3): the crossings in the order of t, then eq. 3.1.
        std::sort(crossings.begin(), crossings.end(), [](const Crossing& a, const Crossing& b) { return a.t < b.t; });
        out.lengths[k] = float(length_in_smoke(crossings));
    });
    return out;
}

}  // namespace smoketrace::textbook
