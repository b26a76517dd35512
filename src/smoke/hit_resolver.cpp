// The hit resolver (thesis 4.3.3): sort each particle's hits by t, then eq. 3.1 and the in-smoke walk. A kernel
// source, compiled once per kernel level (core/simd/dispatch.hpp); the public functions choose the level in
// hit_resolver_dispatch.cpp.
// Each list is sorted on its own (HitSort::adaptive), not all lists in one segmented sort: a short list stays in
// L1 or registers until its walk, and the lists sort in parallel with no shared histogram (docs/fast-paths.md).
#include <smoketrace/smoke/hit_resolver.hpp>
#include <smoketrace/core/radix_sort.hpp>
#include <smoketrace/core/simd/isa.hpp>
#include <smoketrace/smoke/hit_resolver_avx512.hpp>
#include <smoketrace/smoke/hit_walk.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace smoketrace {
namespace {

// The thesis's sort (4.3.3): plain bubble sort, swapping neighbours out of order; stable.
void bubble_sort_by_t(std::span<SurfaceHit> hits) {
    const std::size_t n = hits.size();
    for (std::size_t pass = 0; pass + 1 < n; ++pass) {
        for (std::size_t j = 0; j + 1 < n - pass; ++j) {
            if (hits[j + 1].t < hits[j].t) std::swap(hits[j], hits[j + 1]);
        }
    }
}

}  // namespace

template <simd::Level L>
void detail::sort_hits_by_t_at_level(std::span<SurfaceHit> hits, std::span<SurfaceHit> scratch, HitSort method) {
    static_assert(L == simd::kCompiledLevel);
    switch (method) {
        case HitSort::adaptive:
#if defined(SMOKETRACE_SIMD_AVX512)
            if (hits.size() <= detail::kNetworkSortMaxHits) {
                detail::network_sort_hits_avx512(hits);
                return;
            }
#endif
            sort_by_float_key(hits, scratch, [](const SurfaceHit& h) { return h.t; });
            return;
        case HitSort::std_sort:
            std::sort(hits.begin(), hits.end(), [](const SurfaceHit& a, const SurfaceHit& b) { return a.t < b.t; });
            return;
        case HitSort::bubble:
            bubble_sort_by_t(hits);
            return;
    }
}

namespace detail {
void network_sort_hits_scalar(std::span<SurfaceHit> hits) {
    auto key = [](const SurfaceHit& h) {
        return std::uint64_t{float_sort_key(h.t)} << 32 | std::bit_cast<std::uint32_t>(h.value);
    };
    std::sort(hits.begin(), hits.end(), [&](const SurfaceHit& a, const SurfaceHit& b) { return key(a) < key(b); });
}
}  // namespace detail

template <simd::Level L>
double detail::optical_path_length_at_level(std::span<const SurfaceHit> sorted_hits) {
    static_assert(L == simd::kCompiledLevel);
    assert(std::is_sorted(sorted_hits.begin(), sorted_hits.end(),
                          [](const SurfaceHit& a, const SurfaceHit& b) { return a.t < b.t; }));
    assert(sorted_hits.empty() || sorted_hits.front().t >= 0.0f);  // hits lie ahead of the origin (TMin > 0)
    using Walk = detail::FastWalkLanes;
    return detail::walk_sorted_hits<Walk>(Walk::SortedHits{sorted_hits});
}

template <simd::Level L>
void detail::resolve_optical_path_lengths_at_level(HitLists& lists, std::span<const DepthStatus> status,
                                                   std::span<float> lengths, HitSort method) {
    static_assert(L == simd::kCompiledLevel);
    const std::size_t particles = lists.particle_count();
    if (status.size() != particles || lengths.size() != particles) {
        throw std::invalid_argument("resolve_optical_path_lengths: " + std::to_string(particles) +
                                    " particles but " + std::to_string(status.size()) + " statuses and " +
                                    std::to_string(lengths.size()) + " lengths");
    }
    if (lists.offsets.back() != lists.hits.size()) {
        throw std::invalid_argument("resolve_optical_path_lengths: offsets end at " +
                                    std::to_string(lists.offsets.back()) + " but there are " +
                                    std::to_string(lists.hits.size()) + " hits");
    }
    // Each particle writes only its own list and length: deterministic for any partitioning. Tasks of at
    // least kParticlesPerTask particles: one list takes far less time than handing a task to a thread.
    constexpr std::size_t kParticlesPerTask = 64;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, particles, kParticlesPerTask),
                      [&](const tbb::blocked_range<std::size_t>& r) {
        ListResolver resolve;
        for (std::size_t i = r.begin(); i < r.end(); ++i)
            lengths[i] = status[i] == DepthStatus::ok ? resolve.at_level<L>(lists.of(i), method) : kFullyDarkPathLength;
    });
}

template <simd::Level L>
float ListResolver::at_level(std::span<const PackedSurfaceHit> hits, HitSort method) {
    static_assert(L == simd::kCompiledLevel);
#if defined(SMOKETRACE_SIMD_AVX512)
    if (method == HitSort::adaptive && hits.size() <= detail::kNetworkSortMaxHits)
        return static_cast<float>(detail::resolve_packed_hits_avx512(hits));
#endif
    if (unpacked_.size() < hits.size()) unpacked_.resize(hits.size());  // only grows: no refill per list
    for (std::size_t j = 0; j < hits.size(); ++j) unpacked_[j] = unpack_surface_hit(hits[j]);
    return at_level<L>(std::span(unpacked_.data(), hits.size()), method);
}

template <simd::Level L>
float ListResolver::at_level(std::span<SurfaceHit> hits, HitSort method) {
    static_assert(L == simd::kCompiledLevel);
    std::span<SurfaceHit> scratch(small_);
    if (method == HitSort::adaptive && hits.size() > small_.size()) {
        if (hits.size() > large_.size()) large_.resize(hits.size());
        scratch = large_;
    }
    detail::sort_hits_by_t_at_level<L>(hits, scratch, method);
    return static_cast<float>(detail::optical_path_length_at_level<L>(hits));
}

// This copy's kernels (core/simd/dispatch.hpp).
constexpr simd::Level kLevel = simd::kCompiledLevel;
template void detail::sort_hits_by_t_at_level<kLevel>(std::span<SurfaceHit>, std::span<SurfaceHit>, HitSort);
template double detail::optical_path_length_at_level<kLevel>(std::span<const SurfaceHit>);
template void detail::resolve_optical_path_lengths_at_level<kLevel>(HitLists&, std::span<const DepthStatus>,
                                                                    std::span<float>, HitSort);
template float ListResolver::at_level<kLevel>(std::span<SurfaceHit>, HitSort);
template float ListResolver::at_level<kLevel>(std::span<const PackedSurfaceHit>, HitSort);

}  // namespace smoketrace
