#include <smoketrace/smoke/optical_path_lengths.hpp>

namespace smoketrace {

OpticalPathLengths::OpticalPathLengths(std::size_t n)
    : lengths_(n, 0.0f), status_(n, DepthStatus::ok), hit_counts_(n, 0) {}

void OpticalPathLengths::update(const SmokeScene& scene, std::span<const Particle> particles,
                           std::span<const std::uint32_t> which, const glm::vec3& to_light,
                           const OpticalDepthSettings& settings, HitSort sort, FrameTimings& timings) {
    StageClock clock;
    pass_.trace(scene, particles, which, to_light, settings);
    timings.od_pass = clock.lap_ms(timings.usage.od_pass);
    // The hits resolved where the pass kept them: gathering them into one buffer first (pass_.gather(),
    // then resolve_optical_path_lengths()) gives the same lengths after copying every hit once more.
    group_lengths_.resize(which.size());
    if (settings.progress) settings.progress->begin("resolve", 0);
    pass_.resolve(sort, group_lengths_);
    for (std::size_t i = 0; i < which.size(); ++i) {
        lengths_[which[i]] = group_lengths_[i];
        status_[which[i]] = pass_.status()[i];
        hit_counts_[which[i]] = pass_.hit_counts()[i];
    }
    timings.resolve = clock.lap_ms(timings.usage.resolve);
}

}  // namespace smoketrace
