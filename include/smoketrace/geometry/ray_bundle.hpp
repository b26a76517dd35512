#pragma once
// A ray bundle: up to kBundleWidth rays that share one direction, such as the rays toward a directional
// light (the optical-depth rays of thesis 4.3.2). trace_bundle() traces them together (trace_bundle.hpp);
// bundle_order() decides which rays go together.
//
// Why bundles: every optical-depth ray of a frame goes the same way, and rays from neighbouring
// particles cross the same part of the scene. Traced one by one, each walks nearly the same top-level
// nodes again; traced thirty-two together, a node is fetched and decided once for all of them and its
// boxes tested for the thirty-two in two AVX-512 operations per step. The decisions at a node or an
// instance (where to go next) are the walk's mispredicted branches, and a bundle pays them once for all
// its rays: the wider the bundle, the fewer nodes and instance visits per ray (docs/design.md).
#include <smoketrace/core/simd/level.hpp>
#include <smoketrace/geometry/ray.hpp>

#include <glm/vec3.hpp>

#include <cassert>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

namespace smoketrace {

// A multiple of 16 (AVX-512 registers of floats), and at most 32: a set of lanes is an unsigned.
inline constexpr unsigned kBundleWidth = 32;
static_assert(kBundleWidth % 16 == 0 && kBundleWidth <= 32);

// The rays, structure of arrays: lane i is origin (x[i], y[i], z[i]), [tmin[i], tmax[i]], and the shared
// direction. Lanes [count, kBundleWidth) are unused; they hold lane 0's ray so that every lane is a
// valid ray for the SIMD kernels.
struct RayBundle {
    glm::vec3 direction{0.0f, 0.0f, 1.0f};
    unsigned count = 0;
    alignas(64) float x[kBundleWidth] = {};
    alignas(64) float y[kBundleWidth] = {};
    alignas(64) float z[kBundleWidth] = {};
    alignas(64) float tmin[kBundleWidth] = {};
    alignas(64) float tmax[kBundleWidth] = {};

    // An empty bundle of rays along `dir` (need not be unit length: t is in its units, as for Ray).
    explicit RayBundle(const glm::vec3& dir) : direction(dir) {}

    // Adds a ray (count < kBundleWidth) and returns its lane.
    unsigned add(const glm::vec3& origin, float t_min, float t_max = std::numeric_limits<float>::infinity()) {
        assert(count < kBundleWidth);
        const unsigned lane = count++;
        // The first ray also fills the unused lanes (see above).
        for (unsigned i = lane; i < (lane == 0 ? kBundleWidth : lane + 1); ++i) {
            x[i] = origin.x;
            y[i] = origin.y;
            z[i] = origin.z;
            tmin[i] = t_min;
            tmax[i] = t_max;
        }
        return lane;
    }
    [[nodiscard]] bool full() const { return count == kBundleWidth; }
    // The bit of every lane in use (a shift by 32 would be undefined).
    [[nodiscard]] unsigned lanes() const { return count == 32 ? ~0u : (1u << count) - 1u; }
    [[nodiscard]] glm::vec3 origin(unsigned lane) const { return {x[lane], y[lane], z[lane]}; }
    [[nodiscard]] Ray ray(unsigned lane) const { return Ray{origin(lane), tmin[lane], direction, tmax[lane]}; }
};

// A permutation of [0, origins.size()) in which rays from `origins` along `direction` (nonzero) that lie
// close together come close together, so that consecutive groups of kBundleWidth make good bundles: the
// Morton (Z-order) curve over the origins projected onto the plane perpendicular to `direction`, on a
// grid over their bounding rectangle of 2^b x 2^b cells, b the least in 10 … 16 with a cell per ray (1024 x
// 1024 up to 2^20 rays). Equal codes keep their input order.
// Deterministic, and O(n) (radix-sorted codes). `order` and `scratch` are resized; keeping them between
// frames allocates nothing.
struct BundleOrderScratch {
    struct Entry {
        std::uint32_t code;
        std::uint32_t index;
    };
    std::vector<Entry> entries, sorted;
};
void bundle_order(std::span<const glm::vec3> origins, const glm::vec3& direction, std::vector<std::uint32_t>& order,
                  BundleOrderScratch& scratch);

namespace detail {
// bundle_order() at kernel level L (core/simd/dispatch.hpp): ray_bundle.cpp, compiled once per level,
// instantiates it for its level; bundle_order() (ray_bundle_dispatch.cpp) runs the process's.
template <simd::Level L>
void bundle_order_at_level(std::span<const glm::vec3> origins, const glm::vec3& direction,
                           std::vector<std::uint32_t>& order, BundleOrderScratch& scratch);
}  // namespace detail

}  // namespace smoketrace
