// bundle_order() (ray_bundle.hpp): its kernel, compiled in ray_bundle.cpp, at the process's kernel level
// (core/simd/dispatch.hpp).
#include <smoketrace/core/simd/dispatch.hpp>
#include <smoketrace/geometry/ray_bundle.hpp>

namespace smoketrace {

void bundle_order(std::span<const glm::vec3> origins, const glm::vec3& direction, std::vector<std::uint32_t>& order,
                  BundleOrderScratch& scratch) {
    simd::at_active_level(
        [&]<simd::Level L> { detail::bundle_order_at_level<L>(origins, direction, order, scratch); });
}

}  // namespace smoketrace
