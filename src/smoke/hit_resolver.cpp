// The hit resolver (thesis 4.3.3): sort each particle's hits by t, then eq. 3.1 and the in-smoke walk.
//
// Batched vs per-particle sorting (the design question of the resolver). Two ways to get every list sorted:
//   (a) one segmented radix sort over all particles' hits, keyed by (particle, t): LSD passes over t, then
//       over the particle index (4 passes of 9-10 bits), each streaming the whole buffer (~0.7 MB at 750
//       particles x 120 hits) with a 512-1024-way scatter, then one walk per particle;
//   (b) one small sort per particle (a sorting network up to 128 hits with AVX-512, a rank sort below
//       kRadixSortMinItems, radix above), each list staying in L1 (or registers) until the walk that follows.
// (b) is the faster at every list length the bench tries (section "resolver", table "segmented vs
// per-particle"), and it parallelises over particles with no shared histogram, so HitSort::adaptive is (b).
#include <smoketrace/smoke/hit_resolver.hpp>
#include <smoketrace/core/radix_sort.hpp>
#include <smoketrace/core/simd/isa.hpp>
#include <smoketrace/smoke/hit_resolver_avx512.hpp>

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

void sort_hits_by_t(std::span<SurfaceHit> hits, std::span<SurfaceHit> scratch, HitSort method) {
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

// The walk, as a sum over the gaps between consecutive hits: the gap (t_i, t_{i+1}) is in smoke when the
// counter after hit i is > 0, and the in-smoke gaps add up to the in-smoke stretches. Inside a group of
// equal-t hits the gaps are 0, so whichever order a sort leaves a tie in, only the counter after the
// whole group weighs a nonzero gap: any sort that orders t gives bit-identical lengths. The stretch open
// at the origin (counter_start > 0) adds the gap (0, t_0).
//
// The sum is in double: a gap t_{i+1} - t_i between two floats is exact in double (unless their
// magnitudes differ by more than 2^29), so the only rounding is in the additions, far below the float the
// caller stores (a float accumulator would lose ~2^-24 per gap). The gaps are summed in kWalkLanes
// running sums, gap i into sum i mod kWalkLanes, then added pairwise: the order of the AVX-512 walk
// (hit_resolver_avx512.hpp), which the scalar one repeats so that both give the same bits.
namespace {

using detail::kWalkLanes;

// (s0 + s4, s1 + s5, s2 + s6, s3 + s7), then (those 0 + 2, 1 + 3), then the two: pairwise, in the order
// of the AVX-512 reduction.
double sum_lanes(const double (&s)[kWalkLanes]) {
    const double q0 = s[0] + s[4], q1 = s[1] + s[5], q2 = s[2] + s[6], q3 = s[3] + s[7];
    return (q0 + q2) + (q1 + q3);
}

}  // namespace

namespace detail {
double optical_path_length_scalar(std::span<const SurfaceHit> sorted_hits) {
    const std::size_t n = sorted_hits.size();
    if (n == 0) return 0.0;
    std::int64_t counter = 0;  // eq. 3.1: counter_start = -sum of hit values = particles covering the origin
    for (const SurfaceHit& hit : sorted_hits) counter -= hit.value;
    double sums[kWalkLanes] = {};
    if (counter > 0) sums[0] = static_cast<double>(sorted_hits[0].t);  // in smoke from the origin
    for (std::size_t i = 0; i + 1 < n; ++i) {
        counter += sorted_hits[i].value;
        const double gap = static_cast<double>(sorted_hits[i + 1].t) - static_cast<double>(sorted_hits[i].t);
        sums[i % kWalkLanes] += counter > 0 ? gap : 0.0;  // + 0.0 leaves a sum >= +0 unchanged
    }
    // After the last hit the counter is counter_start + sum = 0: the last gap is closed.
    return sum_lanes(sums);
}

void network_sort_hits_scalar(std::span<SurfaceHit> hits) {
    auto key = [](const SurfaceHit& h) {
        return std::uint64_t{float_sort_key(h.t)} << 32 | std::bit_cast<std::uint32_t>(h.value);
    };
    std::sort(hits.begin(), hits.end(), [&](const SurfaceHit& a, const SurfaceHit& b) { return key(a) < key(b); });
}
}  // namespace detail

double optical_path_length(std::span<const SurfaceHit> sorted_hits) {
    assert(std::is_sorted(sorted_hits.begin(), sorted_hits.end(),
                          [](const SurfaceHit& a, const SurfaceHit& b) { return a.t < b.t; }));
    assert(sorted_hits.empty() || sorted_hits.front().t >= 0.0f);  // hits lie ahead of the origin (TMin > 0)
#if defined(SMOKETRACE_SIMD_AVX512)
    return detail::optical_path_length_avx512(sorted_hits);
#else
    return detail::optical_path_length_scalar(sorted_hits);
#endif
}

void resolve_optical_path_lengths(HitLists& lists, std::span<const DepthStatus> status, std::span<float> lengths,
                                  HitSort method) {
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
            lengths[i] = status[i] == DepthStatus::ok ? resolve(lists.of(i), method) : kFullyDarkPathLength;
    });
}

float ListResolver::operator()(std::span<const PackedSurfaceHit> hits, HitSort method) {
#if defined(SMOKETRACE_SIMD_AVX512)
    if (method == HitSort::adaptive && hits.size() <= detail::kNetworkSortMaxHits)
        return static_cast<float>(detail::resolve_packed_hits_avx512(hits));
#endif
    if (unpacked_.size() < hits.size()) unpacked_.resize(hits.size());  // only grows: no refill per list
    for (std::size_t j = 0; j < hits.size(); ++j) unpacked_[j] = unpack_surface_hit(hits[j]);
    return (*this)(std::span(unpacked_.data(), hits.size()), method);
}

float ListResolver::operator()(std::span<SurfaceHit> hits, HitSort method) {
    std::span<SurfaceHit> scratch(small_);
    if (method == HitSort::adaptive && hits.size() > small_.size()) {
        if (hits.size() > large_.size()) large_.resize(hits.size());
        scratch = large_;
    }
    sort_hits_by_t(hits, scratch, method);
    return static_cast<float>(optical_path_length(hits));
}

}  // namespace smoketrace
