#pragma once
// textbook::optical_depths(): the optical-depth pass (thesis 4.3.2) and the hit resolver (4.3.3) as one loop
// over particles. Each particle's ray toward the light collects the particle surfaces it crosses through
// textbook::trace() and its any-hit shader; the crossings are sorted by t and walked (eq. 3.1) into the optical
// path length l, or, for a smooth density kernel, the particles met are integrated in closed form and summed.
// ../shared/docs/method.md, 3.1 and 4.3.
#include <smoketrace/smoke/density_kernel.hpp>
#include <smoketrace/smoke/light_ray.hpp>
#include <smoketrace/smoke/particle_system.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>

#include <cstdint>
#include <span>
#include <vector>

namespace smoketrace::textbook {

// A particle surface crossed by a light ray: entering the particle (step +1, a front face) or leaving it (step
// −1, a back face). `particle`: the stand-in's user id, its particle index.
struct Crossing { float t = 0.0f; int step = 0; std::uint32_t particle = 0; };

// Eq. 3.1: the length of the stretches of the ray, from its origin (t = 0), that lie inside at least one
// particle, given every crossing of the ray sorted by t. In double.
[[nodiscard]] double length_in_smoke(std::span<const Crossing> sorted);

// For particle which[k], [k]: its status (light_ray.hpp: ok; occluded, the opaque ground on the ray,
// with the crossings in front of it counted; cutoff, more than K crossings, counted K + 1), its crossings and l
// (kFullyDarkPathLength unless ok): the arrays OpticalPathLengths gives, for the same CSV.
struct OpticalDepths {
    std::vector<float> lengths;
    std::vector<DepthStatus> status;
    std::vector<std::uint32_t> hit_counts;
};

// Each particle of `which` traced from its centre toward `to_light` (need not be unit length) through `scene`,
// under the density `kernel` and the cutoff K = `cutoff` (0: none).
[[nodiscard]] OpticalDepths optical_depths(const SmokeScene& scene, std::span<const Particle> particles,
                                           std::span<const std::uint32_t> which, const glm::vec3& to_light,
                                           std::uint32_t cutoff, const DensityKernel& kernel);

}  // namespace smoketrace::textbook
