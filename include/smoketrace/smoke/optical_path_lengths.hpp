#pragma once
// Per-particle optical path lengths, kept up to date frame by frame: the optical-depth pass (4.3.2)
// followed by the hit resolver (4.3.3) for this frame's particle group (4.4.2); particles outside the
// group keep their last values.
#include <smoketrace/core/frame_timings.hpp>
#include <smoketrace/smoke/hit_resolver.hpp>
#include <smoketrace/smoke/optical_depth_pass.hpp>

#include <vector>

namespace smoketrace {

class OpticalPathLengths {
public:
    explicit OpticalPathLengths(std::size_t particle_count);

    // Traces and resolves the particles `which`; fills timings.od_pass and timings.resolve.
    void update(const SmokeScene& scene, std::span<const Particle> particles, std::span<const std::uint32_t> which,
                const glm::vec3& to_light, const OpticalDepthSettings& settings, HitSort sort, FrameTimings& timings);

    // Optical path length l of each particle (eq. 3.1 walk); +inf when occluded or cut off;
    // NaN-free. Before a particle's first update its length is 0 (fully lit).
    [[nodiscard]] const std::vector<float>& lengths() const { return lengths_; }
    [[nodiscard]] const std::vector<DepthStatus>& status() const { return status_; }
    [[nodiscard]] const std::vector<std::uint32_t>& hit_counts() const { return hit_counts_; }

private:
    OpticalDepthPass pass_;
    std::vector<float> group_lengths_;
    std::vector<float> lengths_;
    std::vector<DepthStatus> status_;
    std::vector<std::uint32_t> hit_counts_;
};

}  // namespace smoketrace
