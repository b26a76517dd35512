#pragma once
// The hit resolver's AVX-512 kernels (hit_resolver.cpp): the sorting network for one particle's hits, the
// walk eight hits at a time, and both at once in registers for a list of packed hits. None maps onto the
// lanes types (core/simd/lanes.hpp): the network lives on lane shuffles and masked min / max
// (core/sorting_network_avx512.hpp), the walk on masked loads, a prefix sum across lanes and 64-bit integer
// lanes. Each gives its scalar definition's bits (hit_resolver.hpp: detail::network_sort_hits_scalar,
// detail::optical_path_length_scalar; for packed hits, the unpacked list's), which tests/test_hit_resolver.cpp
// checks.
#include <smoketrace/core/simd/isa.hpp>
#include <smoketrace/core/sorting_network_avx512.hpp>
#include <smoketrace/smoke/hit_resolver.hpp>

#include <bit>
#include <cstddef>
#include <cstdint>
#include <span>

#if defined(SMOKETRACE_SIMD_AVX512)
#include <immintrin.h>

namespace smoketrace::detail {

// Lists this short are sorted by the bitonic network rather than by rank_sort().
inline constexpr std::size_t kNetworkSortMaxHits = kNetworkSortLanes * kNetworkSortMaxRegisters;

// A hit as one 64-bit key: float_sort_key(t) in the high half, the value's bits in the low half, so that
// the keys' unsigned order is the order of t (hits of equal t ordered by value, which the walk of
// optical_path_length() ignores). In memory a SurfaceHit is t then value, which loads as the reverse.
static_assert(sizeof(SurfaceHit) == sizeof(std::uint64_t) && offsetof(SurfaceHit, value) == sizeof(float));

// Internal linkage (static): GCC's inliner then takes the small networks into sort_hits_by_t() and keeps
// the walk out of line; as `inline` functions they would be weighed otherwise.
template <unsigned R>
static void network_sort_hits_avx512(std::span<SurfaceHit> hits) {
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

// Sorts a list of at most kNetworkSortMaxHits hits as network_sort_hits_scalar() does, with the smallest
// network that holds it.
[[maybe_unused]] static void network_sort_hits_avx512(std::span<SurfaceHit> hits) {
    const std::size_t registers = (hits.size() + kNetworkSortLanes - 1) / kNetworkSortLanes;
    if (hits.size() < 2) return;
    if (registers == 1) return network_sort_hits_avx512<1>(hits);
    if (registers == 2) return network_sort_hits_avx512<2>(hits);
    if (registers <= 4) return network_sort_hits_avx512<4>(hits);
    if (registers <= 8) return network_sort_hits_avx512<8>(hits);
    return network_sort_hits_avx512<16>(hits);
}

// One register of eq. 3.1's walk, shared by the walk from memory and the walk of packed hits in registers:
// lane i holds hit i's value (+1 entering, −1 leaving) and the times t of hit i and hit i + 1. The counter
// after each lane's hit is `counter` (before the register's first hit) plus an inclusive prefix sum of the
// values across the lanes (shifted by 1, 2 and 4); lane i adds gap i to its running sum where that counter
// is > 0 and `gaps` has its bit (a gap exists up to hit n − 2). Returns the counter after the last lane.
static inline __m512i walk_register_avx512(__m512i values, __m512d t, __m512d t_next, __mmask8 gaps, __m512i counter,
                                           __m512d& sums) {
    constexpr __mmask8 kEveryLane = 0xFF;
    const __m512i zero = _mm512_setzero_si512();
    __m512i s = values;
    s = _mm512_add_epi64(s, _mm512_maskz_alignr_epi64(kEveryLane, s, zero, kWalkLanes - 1));
    s = _mm512_add_epi64(s, _mm512_maskz_alignr_epi64(kEveryLane, s, zero, kWalkLanes - 2));
    s = _mm512_add_epi64(s, _mm512_maskz_alignr_epi64(kEveryLane, s, zero, kWalkLanes - 4));
    const __m512i after = _mm512_add_epi64(counter, s);
    const __mmask8 in_smoke = _mm512_mask_cmpgt_epi64_mask(gaps, after, zero);
    sums = _mm512_mask_add_pd(sums, in_smoke, sums, _mm512_sub_pd(t_next, t));
    return _mm512_maskz_permutexvar_epi64(kEveryLane, _mm512_set1_epi64(kWalkLanes - 1), after);
}

// The walk's kWalkLanes sums added as sum_lanes() of hit_resolver.cpp does: the halves, then the quarters,
// then the two left.
static inline double sum_lanes_avx512(__m512d sums) {
    const __m256d q =
        _mm256_add_pd(_mm512_maskz_extractf64x4_pd(0xF, sums, 0), _mm512_maskz_extractf64x4_pd(0xF, sums, 1));
    const __m128d p = _mm_add_pd(_mm256_castpd256_pd128(q), _mm256_extractf128_pd(q, 1));
    return _mm_cvtsd_f64(_mm_add_sd(p, _mm_unpackhi_pd(p, p)));
}

// A list of at most kNetworkSortMaxHits packed hits (hit_resolver.hpp), sorted and walked without leaving the
// registers: the bits of network_sort_hits_avx512() and optical_path_length_avx512() on the unpacked
// list. Each key is a hit's packed bits rotated left by one (t above the leaving flag), zero-extended;
// its next hit comes from the registers (valignq) rather than from a load at one hit's offset, which would
// straddle two stores of the sort and wait for them, and for every store before them, to reach the cache.
template <unsigned R>
static double resolve_packed_hits_avx512(const PackedSurfaceHit* packed, std::size_t n) {
    static_assert(kWalkLanes == kNetworkSortLanes, "one register of keys is one register of the walk");
    static_assert(sizeof(PackedSurfaceHit) == sizeof(std::uint32_t));
    auto lanes_below = [](std::ptrdiff_t count) {  // the first min(count, 8) lanes; none for count <= 0
        return __mmask8(count >= std::ptrdiff_t(kWalkLanes) ? 0xFFu : count <= 0 ? 0u : (1u << count) - 1u);
    };
    const std::ptrdiff_t count = std::ptrdiff_t(n);
    const unsigned used = unsigned((n + kNetworkSortLanes - 1) / kNetworkSortLanes);
    const __m512i all_ones = _mm512_set1_epi64(-1);  // padding: after every key
    const __m512i one = _mm512_set1_epi64(1);
    __m512i v[R];
#pragma GCC unroll 16
    for (unsigned r = 0; r < R; ++r) {
        if (r >= used) {
            v[r] = all_ones;
            continue;
        }
        const __mmask8 lanes = lanes_below(count - std::ptrdiff_t(kNetworkSortLanes * r));
        const __m512i bits = _mm512_maskz_loadu_epi32(__mmask16(lanes), packed + kNetworkSortLanes * r);
        const __m512i keys = _mm512_maskz_rol_epi32(__mmask16(lanes), bits, 1);
        v[r] = _mm512_mask_cvtepu32_epi64(all_ones, lanes, _mm512_maskz_extracti64x4_epi64(0xF, keys, 0));
    }
    bitonic_sort<R>(v);

    // The sorted keys hold the n hits first, then the padding.
    constexpr __mmask8 kEveryLane = 0xFF;
    auto values_of = [&](__m512i k) {  // +1 entering, −1 leaving
        return _mm512_sub_epi64(one, _mm512_maskz_slli_epi64(kEveryLane, _mm512_and_si512(k, one), 1));
    };
    auto t_of = [&](__m512i k) {  // t's bits, as floats widened to double
        const __m512i t_bits = _mm512_maskz_srli_epi64(kEveryLane, k, 1);
        return _mm512_maskz_cvtps_pd(kEveryLane, _mm256_castsi256_ps(_mm512_maskz_cvtepi64_epi32(kEveryLane, t_bits)));
    };
    std::int64_t leaving = 0;  // eq. 3.1: counter_start = −sum of hit values = leaving − entering
#pragma GCC unroll 16
    for (unsigned r = 0; r < R; ++r) {
        if (r >= used) break;
        const __mmask8 lanes = lanes_below(count - std::ptrdiff_t(kNetworkSortLanes * r));
        leaving += std::popcount(unsigned(_mm512_mask_test_epi64_mask(lanes, v[r], one)));
    }
    const std::int64_t counter_start = 2 * leaving - count;

    __m512d sums = _mm512_setzero_pd();
    if (counter_start > 0) sums = _mm512_mask_mov_pd(sums, 1, t_of(v[0]));  // in smoke from the origin
    __m512i counter = _mm512_set1_epi64(counter_start);  // before the register's first hit
#pragma GCC unroll 16
    for (unsigned r = 0; r < R; ++r) {
        if (r >= used) break;
        const __m512i h = v[r];
        // Hit i + 1 in lane i.
        const __m512i next = _mm512_maskz_alignr_epi64(kEveryLane, r + 1 < R ? v[r + 1] : all_ones, h, 1);
        counter = walk_register_avx512(values_of(h), t_of(h), t_of(next),
                                       lanes_below(count - std::ptrdiff_t(kNetworkSortLanes * r) - 1), counter, sums);
    }
    return sum_lanes_avx512(sums);
}

// resolve_packed_hits_avx512<R> with the smallest network that holds the list (at most kNetworkSortMaxHits).
[[maybe_unused]] static double resolve_packed_hits_avx512(std::span<const PackedSurfaceHit> hits) {
    const std::size_t registers = (hits.size() + kNetworkSortLanes - 1) / kNetworkSortLanes;
    if (hits.empty()) return 0.0;
    if (registers == 1) return resolve_packed_hits_avx512<1>(hits.data(), hits.size());
    if (registers == 2) return resolve_packed_hits_avx512<2>(hits.data(), hits.size());
    if (registers <= 4) return resolve_packed_hits_avx512<4>(hits.data(), hits.size());
    if (registers <= 8) return resolve_packed_hits_avx512<8>(hits.data(), hits.size());
    return resolve_packed_hits_avx512<16>(hits.data(), hits.size());
}

// optical_path_length() eight hits at a time: each lane i of a register holds hit 8c + i as loaded (t in
// the low half, the value in the high half), the counters come from a prefix sum of the values across
// the lanes, and lane i adds gap 8c + i to its running sum i where its counter is > 0: the kWalkLanes sums
// of optical_path_length_scalar(), reduced in its order. No branch on the hits.
[[maybe_unused]] static double optical_path_length_avx512(std::span<const SurfaceHit> sorted_hits) {
    static_assert(kWalkLanes == 8, "one 512-bit register of hits");
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
    for (std::size_t c = 0; c < n; c += kWalkLanes) {
        const __m512i h = _mm512_maskz_loadu_epi64(lanes_below(n - c), hits + c);
        const __m512i next = _mm512_maskz_loadu_epi64(lanes_below(n - c - 1), hits + c + 1);
        counter = walk_register_avx512(values_of(h), t_of(h), t_of(next), lanes_below(n - c - 1), counter, sums);
    }
    return sum_lanes_avx512(sums);
}

}  // namespace smoketrace::detail
#endif  // SMOKETRACE_SIMD_AVX512
