#include <smoketrace/optical_depths.hpp>

namespace smoketrace {

OpticalDepths::OpticalDepths(std::size_t n) : lengths_(n, 0.0f), status_(n, DepthStatus::ok), hit_counts_(n, 0) {}

void OpticalDepths::update(const SmokeScene& scene, std::span<const Particle> particles,
                           std::span<const std::uint32_t> which, const glm::vec3& to_light,
                           const OpticalDepthSettings& settings, HitSort sort, FrameTimings& timings) {
    StageClock clock;
    pass_.run(scene, particles, which, to_light, settings, hits_);
    timings.od_pass = clock.lap_ms();
    group_lengths_.resize(which.size());
    resolve_optical_path_lengths(hits_.lists, hits_.status, group_lengths_, sort);
    for (std::size_t i = 0; i < which.size(); ++i) {
        lengths_[which[i]] = group_lengths_[i];
        status_[which[i]] = hits_.status[i];
        hit_counts_[which[i]] = hits_.hit_counts[i];
    }
    timings.resolve = clock.lap_ms();
}

}  // namespace smoketrace
