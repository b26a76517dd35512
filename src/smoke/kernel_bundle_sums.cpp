// A smooth density kernel's sums for the rays of one bundle, see kernel_bundle_sums.hpp.
#include <smoketrace/smoke/kernel_bundle_sums.hpp>

namespace smoketrace {

void BundleKernelSums::integrate(const DensityKernel& kernel, const glm::dvec3& unit_direction, const RayBundle& bundle,
                                 std::span<const Particle> particles, unsigned lanes,
                                 std::array<double, kBundleWidth>& sums) {
    // Each lane's exits in a stretch of their own, in walk order; written in place, not pushed.
    std::array<std::uint32_t, kBundleWidth + 1> first{};
    for (unsigned lane = 0; lane < kBundleWidth; ++lane)
        first[lane + 1] = first[lane] + ((lanes >> lane) & 1u ? std::uint32_t(exits_[lane].size()) : 0u);
    stretches_.resize(first[kBundleWidth]);
    for (unsigned lane = 0; lane < kBundleWidth; ++lane) {
        if (first[lane + 1] == first[lane]) continue;
        const glm::vec3 origin = bundle.origin(lane);
        std::uint32_t e = first[lane];
        for (const std::uint32_t p : exits_[lane]) stretches_.set(e++, origin, particles[p].center, particles[p].radius);
    }
    shares_.resize(stretches_.size());
    integrate_stretches(kernel, unit_direction, stretches_, shares_);
    for (unsigned lane = 0; lane < kBundleWidth; ++lane) {
        double sum = 0.0;
        for (std::uint32_t e = first[lane]; e < first[lane + 1]; ++e) sum += shares_[e];
        sums[lane] = sum;
    }
}

}  // namespace smoketrace
