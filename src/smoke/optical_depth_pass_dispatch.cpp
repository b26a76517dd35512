// The optical-depth pass's entry points (optical_depth_pass.hpp): each runs its kernel, compiled in
// optical_depth_pass.cpp, at the process's kernel level (core/simd/dispatch.hpp).
#include <smoketrace/core/memory_budget.hpp>
#include <smoketrace/core/simd/dispatch.hpp>
#include <smoketrace/smoke/optical_depth_pass.hpp>

#include <algorithm>
#include <limits>

namespace smoketrace {

std::uint64_t default_max_total_hits() {
    return std::min<std::uint64_t>(std::numeric_limits<std::uint32_t>::max(),
                                   machine_memory_bytes() / 2 / kPeakBytesPerStoredHit);
}

void OpticalDepthPass::run(const SmokeScene& smoke, std::span<const Particle> particles,
                           std::span<const std::uint32_t> which, const glm::vec3& to_light,
                           const OpticalDepthSettings& settings, OpticalDepthHits& out) {
    trace(smoke, particles, which, to_light, settings);
    gather(out);
}

void OpticalDepthPass::trace(const SmokeScene& smoke, std::span<const Particle> particles,
                             std::span<const std::uint32_t> which, const glm::vec3& to_light,
                             const OpticalDepthSettings& settings) {
    simd::at_active_level(
        [&]<simd::Level L> { trace_at_level<L>(smoke, particles, which, to_light, settings); });
}

void OpticalDepthPass::resolve(HitSort method, std::span<float> lengths) {
    simd::at_active_level([&]<simd::Level L> { resolve_at_level<L>(method, lengths); });
}

}  // namespace smoketrace
