#pragma once
// textbook::optical_depths(): the optical-depth pass (thesis 4.3.2) and the hit resolver (4.3.3) as one loop
// over particles. Each particle's ray toward the light collects the particle surfaces it crosses through
// textbook::trace() and its any-hit shader; the crossings are sorted by t and walked (eq. 3.1) into the optical
// path length l, or, for a smooth density kernel, the particles met are integrated in closed form and summed.
// ../shared/docs/method.md, 3.1 and 4.3.
#include <smoketrace/accel/accel_scene.hpp>
#include <smoketrace/geometry/ray.hpp>
#include <smoketrace/smoke/density_kernel.hpp>
// DepthStatus, kFullyDarkPathLength and the ray's optical_depth_tmin(), kOpticalDepthTmax, which this header
// brings (from hit_resolver.hpp and optical_depth_pass.hpp).
#include <smoketrace/smoke/optical_path_lengths.hpp>
#include <smoketrace/smoke/particle_system.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>

#include <glm/vec3.hpp>

#include <cstdint>
#include <span>
#include <vector>

namespace smoketrace::textbook {

// One particle surface a light ray crosses: entering the particle (step +1, a front face) or leaving it
// (step −1, a back face); `particle` is the stand-in's user id, its particle index.
struct Crossing {
    float t = 0.0f;
    int step = 0;
    std::uint32_t particle = 0;
};

// Eq. 3.1: the length of the stretches of the ray, from its origin (t = 0), that lie inside at least one
// particle, given every crossing of the ray sorted by t. In double.
[[nodiscard]] double length_in_smoke(std::span<const Crossing> sorted);

// What one light ray found, with the statuses of optical_depth_pass.hpp: ok; occluded (the opaque ground lies
// on the ray; `hits` counts the crossings in front of it); cutoff (more than K crossings, `hits` = K + 1).
// `length`: l (kFullyDarkPathLength unless ok).
struct LightRayDepth {
    DepthStatus status = DepthStatus::ok;
    std::uint32_t hits = 0;
    float length = 0.0f;
};

// The light ray `ray` through `scene` (a SmokeScene's, the stand-ins of `particles`), under the density
// `kernel` and the cutoff K = `cutoff` (0: none).
[[nodiscard]] LightRayDepth light_ray_depth(const AccelScene& scene, std::span<const Particle> particles,
                                            const Ray& ray, std::uint32_t cutoff, const DensityKernel& kernel);

// Each particle of `which`, from its centre toward `to_light` (need not be unit length), as the fast pass
// traces it: [k] for which[k]. The same arrays OpticalPathLengths gives, for the same CSV.
struct OpticalDepths {
    std::vector<float> lengths;
    std::vector<DepthStatus> status;
    std::vector<std::uint32_t> hit_counts;
};
[[nodiscard]] OpticalDepths optical_depths(const SmokeScene& scene, std::span<const Particle> particles,
                                           std::span<const std::uint32_t> which, const glm::vec3& to_light,
                                           std::uint32_t cutoff, const DensityKernel& kernel);

}  // namespace smoketrace::textbook
