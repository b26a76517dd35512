// The hit resolver (thesis 4.3.3): sort each particle's hits by t, then eq. 3.1 and the in-smoke walk.
//
// Batched vs per-particle sorting (the design question of the resolver). Two ways to get every list sorted:
//   (a) one segmented radix sort over all particles' hits, keyed by (particle, t): LSD passes over t, then
//       over the particle index (4 passes of 9-10 bits), each streaming the whole buffer (~0.7 MB at 750
//       particles x 120 hits) with a 512-1024-way scatter, then one walk per particle;
//   (b) one small sort per particle (a sorting network up to 128 hits with AVX-512, a rank sort below
//       kRadixSortMinItems, radix above), each list staying in L1 (or registers) until the walk that follows.
// (b) is the faster at every list length the bench tries (section "resolver", table "segmented vs
// per-particle"), and it parallelises over particles with no shared histogram, so HitSort::radix is (b).
#include <smoketrace/smoke/hit_resolver.hpp>
#include <smoketrace/core/radix_sort.hpp>
#include <smoketrace/core/sorting_network.hpp>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cstddef>
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

#if defined(SMOKETRACE_SORTING_NETWORK)
// Lists this short are sorted by the bitonic network (sorting_network.hpp) rather than by rank_sort().
constexpr std::size_t kNetworkSortMaxHits = kNetworkSortLanes * kNetworkSortMaxRegisters;

// A hit as one 64-bit key: float_sort_key(t) in the high half, the value's bits in the low half, so that
// the keys' unsigned order is the order of t (hits of equal t ordered by value, which the walk of
// optical_path_length() ignores). In memory a SurfaceHit is t then value, which loads as the reverse.
static_assert(sizeof(SurfaceHit) == sizeof(std::uint64_t) && offsetof(SurfaceHit, value) == sizeof(float));

template <unsigned R>
void network_sort_hits(std::span<SurfaceHit> hits) {
    const std::size_t n = hits.size();
    const __m512i high_half = _mm512_set1_epi64(std::int64_t(0xFFFF'FFFF'0000'0000u));
    const __m512i sign_bit = _mm512_set1_epi64(std::int64_t(0x8000'0000'0000'0000u));
    __m512i v[R];
    auto lanes_of = [n](unsigned r) {  // the lanes of register r that hold a hit
        const std::size_t first = kNetworkSortLanes * r;
        return __mmask8(n >= first + kNetworkSortLanes ? 0xFFu : (1u << (n - first)) - 1u);
    };
    const unsigned used = unsigned((n + kNetworkSortLanes - 1) / kNetworkSortLanes);
#pragma GCC unroll 16
    for (unsigned r = 0; r < R; ++r) {
        if (r >= used) {
            v[r] = _mm512_set1_epi64(-1);  // padding: after every key
            continue;
        }
        const __m512i x = _mm512_maskz_ror_epi64(
            kEveryKey, _mm512_maskz_loadu_epi64(lanes_of(r), hits.data() + kNetworkSortLanes * r), 32);
        // float_sort_key() on the high half: a negative t has all its bits flipped, any other its sign bit.
        const __m512i negative = _mm512_maskz_srai_epi64(kEveryKey, x, 63);  // all ones where t < 0
        const __m512i flip = _mm512_or_si512(_mm512_and_si512(negative, high_half), sign_bit);
        v[r] = _mm512_mask_xor_epi64(_mm512_set1_epi64(-1), lanes_of(r), x, flip);
    }
    bitonic_sort<R>(v);
#pragma GCC unroll 16
    for (unsigned r = 0; r < used && r < R; ++r) {
        // The key's top bit is set for a t that was not negative: then only the sign bit was flipped.
        const __m512i top_bit = _mm512_maskz_srai_epi64(kEveryKey, v[r], 63);  // all ones where t >= 0
        const __m512i flip = _mm512_or_si512(_mm512_maskz_andnot_epi64(kEveryKey, top_bit, high_half), sign_bit);
        _mm512_mask_storeu_epi64(hits.data() + kNetworkSortLanes * r, lanes_of(r),
                                 _mm512_maskz_ror_epi64(kEveryKey, _mm512_xor_si512(v[r], flip), 32));
    }
}

// Sorts a list of at most kNetworkSortMaxHits hits by t with the smallest network that holds it.
void network_sort_hits(std::span<SurfaceHit> hits) {
    const std::size_t registers = (hits.size() + kNetworkSortLanes - 1) / kNetworkSortLanes;
    if (hits.size() < 2) return;
    if (registers == 1) return network_sort_hits<1>(hits);
    if (registers == 2) return network_sort_hits<2>(hits);
    if (registers <= 4) return network_sort_hits<4>(hits);
    if (registers <= 8) return network_sort_hits<8>(hits);
    return network_sort_hits<16>(hits);
}
#endif

}  // namespace

void sort_hits_by_t(std::span<SurfaceHit> hits, std::span<SurfaceHit> scratch, HitSort method) {
    switch (method) {
        case HitSort::radix:
#if defined(SMOKETRACE_SORTING_NETWORK)
            if (hits.size() <= kNetworkSortMaxHits) {
                network_sort_hits(hits);
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
// below, which the scalar one repeats so that both give the same bits.
namespace {

constexpr std::size_t kWalkLanes = 8;

// (s0 + s4, s1 + s5, s2 + s6, s3 + s7), then (those 0 + 2, 1 + 3), then the two: pairwise, in the order
// of the AVX-512 reduction below.
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
}  // namespace detail

#if defined(__AVX512F__)
namespace {

// The walk eight hits at a time: each lane i of a register holds hit 8c + i as loaded (t in the low half,
// the value in the high half), the counters come from a prefix sum of the values across the lanes, and
// lane i adds gap 8c + i to its running sum where its counter is > 0. No branch on the hits.
double optical_path_length_avx512(std::span<const SurfaceHit> sorted_hits) {
    constexpr __mmask8 kEveryLane = 0xFF;
    const std::size_t n = sorted_hits.size();
    if (n == 0) return 0.0;
    const SurfaceHit* hits = sorted_hits.data();
    auto lanes_below = [](std::size_t count) {  // the first min(count, 8) lanes
        return __mmask8(count >= kWalkLanes ? 0xFFu : (1u << count) - 1u);
    };
    const __m512i zero = _mm512_setzero_si512();
    auto values_of = [&](__m512i h) { return _mm512_maskz_srai_epi64(kEveryLane, h, 32); };
    auto t_of = [&](__m512i h) {  // the low halves, as floats widened to double
        return _mm512_maskz_cvtps_pd(kEveryLane, _mm256_castsi256_ps(_mm512_maskz_cvtepi64_epi32(kEveryLane, h)));
    };

    __m512i total = zero;  // eq. 3.1: counter_start = -sum of hit values
    for (std::size_t c = 0; c < n; c += kWalkLanes)
        total = _mm512_add_epi64(total, values_of(_mm512_maskz_loadu_epi64(lanes_below(n - c), hits + c)));
    alignas(64) std::int64_t lane_totals[kWalkLanes];
    _mm512_store_si512(lane_totals, total);
    std::int64_t counter_start = 0;
    for (const std::int64_t t : lane_totals) counter_start -= t;

    __m512d sums = _mm512_setzero_pd();
    if (counter_start > 0) sums = _mm512_mask_mov_pd(sums, 1, _mm512_set1_pd(static_cast<double>(hits[0].t)));
    __m512i counter = _mm512_set1_epi64(counter_start);  // before the register's first hit
    const __m512i last_lane = _mm512_set1_epi64(kWalkLanes - 1);
    for (std::size_t c = 0; c < n; c += kWalkLanes) {
        const __m512i h = _mm512_maskz_loadu_epi64(lanes_below(n - c), hits + c);
        const __m512i next = _mm512_maskz_loadu_epi64(lanes_below(n - c - 1), hits + c + 1);
        __m512i v = values_of(h);  // inclusive prefix sum over the lanes: shifted by 1, 2 and 4
        v = _mm512_add_epi64(v, _mm512_maskz_alignr_epi64(kEveryLane, v, zero, kWalkLanes - 1));
        v = _mm512_add_epi64(v, _mm512_maskz_alignr_epi64(kEveryLane, v, zero, kWalkLanes - 2));
        v = _mm512_add_epi64(v, _mm512_maskz_alignr_epi64(kEveryLane, v, zero, kWalkLanes - 4));
        const __m512i after = _mm512_add_epi64(counter, v);  // the counter after each lane's hit
        counter = _mm512_maskz_permutexvar_epi64(kEveryLane, last_lane, after);
        // Gaps exist up to hit n - 2.
        const __mmask8 in_smoke = _mm512_mask_cmpgt_epi64_mask(lanes_below(n - c - 1), after, zero);
        sums = _mm512_mask_add_pd(sums, in_smoke, sums, _mm512_sub_pd(t_of(next), t_of(h)));
    }
    // sum_lanes(): the halves, then the quarters, then the two left.
    const __m256d q =
        _mm256_add_pd(_mm512_maskz_extractf64x4_pd(0xF, sums, 0), _mm512_maskz_extractf64x4_pd(0xF, sums, 1));
    const __m128d p = _mm_add_pd(_mm256_castpd256_pd128(q), _mm256_extractf128_pd(q, 1));
    return _mm_cvtsd_f64(_mm_add_sd(p, _mm_unpackhi_pd(p, p)));
}

}  // namespace
#endif

double optical_path_length(std::span<const SurfaceHit> sorted_hits) {
    assert(std::is_sorted(sorted_hits.begin(), sorted_hits.end(),
                          [](const SurfaceHit& a, const SurfaceHit& b) { return a.t < b.t; }));
    assert(sorted_hits.empty() || sorted_hits.front().t >= 0.0f);  // hits lie ahead of the origin (TMin > 0)
#if defined(__AVX512F__)
    return optical_path_length_avx512(sorted_hits);
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

float ListResolver::operator()(std::span<SurfaceHit> hits, HitSort method) {
    std::span<SurfaceHit> scratch(small_);
    if (method == HitSort::radix && hits.size() > small_.size()) {
        if (hits.size() > large_.size()) large_.resize(hits.size());
        scratch = large_;
    }
    sort_hits_by_t(hits, scratch, method);
    return static_cast<float>(optical_path_length(hits));
}

}  // namespace smoketrace
