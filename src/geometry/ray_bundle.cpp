// Ray bundles and the order that groups rays into them (see ray_bundle.hpp). A kernel source, compiled once
// per kernel level (core/simd/dispatch.hpp); bundle_order() chooses the level in ray_bundle_dispatch.cpp.
#include <smoketrace/core/radix_sort.hpp>
#include <smoketrace/geometry/ray_bundle.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

namespace smoketrace {
namespace {

// Cells per axis of the Morton code: 2^bits, the fewest (at least 1024) for which the grid has a cell per
// ray, so that a cell holds about one ray however many there are (a coarser grid leaves the rays within a
// cell in input order, and bundles of 10^7 rays spread further across the direction). At most 16 bits per
// axis: a 32-bit code.
constexpr unsigned kMinCellBits = 10;
constexpr unsigned kMaxCellBits = 16;

unsigned cell_bits(std::size_t rays) {
    unsigned bits = kMinCellBits;
    while (bits < kMaxCellBits && (std::uint64_t{1} << (2 * bits)) < rays) ++bits;
    return bits;
}

// The bits of a 16-bit value spread to the even bit positions of a 32-bit one.
std::uint32_t spread_bits(std::uint32_t v) {
    v = (v | (v << 8)) & 0x00FF00FFu;
    v = (v | (v << 4)) & 0x0F0F0F0Fu;
    v = (v | (v << 2)) & 0x33333333u;
    v = (v | (v << 1)) & 0x55555555u;
    return v;
}

}  // namespace

template <simd::Level L>
void detail::bundle_order_at_level(std::span<const glm::vec3> origins, const glm::vec3& direction,
                                   std::vector<std::uint32_t>& order, BundleOrderScratch& scratch) {
    static_assert(L == simd::kCompiledLevel);
    const std::size_t n = origins.size();
    order.resize(n);
    if (n == 0) return;
    // An orthonormal basis (u, v) of the plane perpendicular to the direction (Duff et al., "Building an
    // Orthonormal Basis, Revisited", JCGT 6(1), 2017): no branch on the direction but its z sign.
    const glm::dvec3 d = glm::normalize(glm::dvec3(direction));
    const double sign = std::copysign(1.0, d.z);
    const double a = -1.0 / (sign + d.z);
    const double b = d.x * d.y * a;
    const glm::dvec3 u(1.0 + sign * d.x * d.x * a, sign * b, -sign * d.x);
    const glm::dvec3 v(b, sign + d.y * d.y * a, -d.y);

    auto& entries = scratch.entries;
    entries.resize(n);
    double lo[2] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
    double hi[2] = {-lo[0], -lo[1]};
    for (const glm::vec3& o : origins) {
        const double p[2] = {glm::dot(glm::dvec3(o), u), glm::dot(glm::dvec3(o), v)};
        for (int k = 0; k < 2; ++k) {
            lo[k] = std::min(lo[k], p[k]);
            hi[k] = std::max(hi[k], p[k]);
        }
    }
    const double last_cell = double((1u << cell_bits(n)) - 1u);
    double scale[2];
    for (int k = 0; k < 2; ++k) scale[k] = hi[k] > lo[k] ? last_cell / (hi[k] - lo[k]) : 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        const glm::dvec3 o(origins[i]);
        const double p[2] = {glm::dot(o, u), glm::dot(o, v)};
        std::uint32_t q[2];
        for (int k = 0; k < 2; ++k) q[k] = static_cast<std::uint32_t>(std::min(last_cell, (p[k] - lo[k]) * scale[k]));
        entries[i] = {spread_bits(q[0]) | (spread_bits(q[1]) << 1), static_cast<std::uint32_t>(i)};
    }
    scratch.sorted.resize(n);
    radix_sort(std::span(entries), std::span(scratch.sorted),
               [](const BundleOrderScratch::Entry& e) { return e.code; });
    for (std::size_t i = 0; i < n; ++i) order[i] = entries[i].index;
}

// This copy's kernel (core/simd/dispatch.hpp); bundle_order() is in ray_bundle_dispatch.cpp.
template void detail::bundle_order_at_level<simd::kCompiledLevel>(std::span<const glm::vec3>, const glm::vec3&,
                                                                  std::vector<std::uint32_t>&, BundleOrderScratch&);

}  // namespace smoketrace
