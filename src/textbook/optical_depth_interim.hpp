#pragma once
// INTERIM until the textbook optical-depth pass lands (helper T1): the fast pass behind the textbook's call.
#include <smoketrace/smoke/optical_path_lengths.hpp>
#include <vector>
namespace smoketrace::textbook {
struct OpticalDepths {
    std::vector<float> lengths;
};
inline OpticalDepths optical_depths(const SmokeScene& scene, std::span<const Particle> particles,
                                               std::span<const std::uint32_t> which, const glm::vec3& to_light,
                                               std::uint32_t cutoff, const DensityKernel& kernel) {
    OpticalPathLengths all(particles.size());
    OpticalDepthSettings s;
    s.cutoff = cutoff;
    s.kernel = kernel;
    FrameTimings t;
    all.update(scene, particles, which, to_light, s, HitSort::adaptive, t);
    OpticalDepths out;
    for (std::uint32_t i : which) out.lengths.push_back(all.lengths()[i]);
    return out;
}
}  // namespace smoketrace::textbook
