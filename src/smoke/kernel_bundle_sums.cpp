// A smooth density kernel's sums for the rays of one bundle, see kernel_bundle_sums.hpp.
#include <smoketrace/smoke/kernel_bundle_sums.hpp>

namespace smoketrace {

void BundleKernelSums::integrate(const DensityKernel& kernel, const glm::dvec3& unit_direction,
                                 std::array<double, kBundleWidth>& sums) {
    shares_.resize(exits_.size());
    integrate_stretches(kernel, unit_direction, exits_, shares_);
    sums.fill(0.0);
    for (std::size_t e = 0; e < shares_.size(); ++e) sums[lanes_[e]] += shares_[e];
}

}  // namespace smoketrace
