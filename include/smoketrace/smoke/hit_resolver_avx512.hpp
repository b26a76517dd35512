#pragma once
// The hit resolver's AVX-512 kernels (hit_resolver.cpp): the sorting network for one particle's hits, the
// lanes of the walk (hit_walk.hpp) eight hits per register, and both at once in registers for a list of
// packed hits. Neither maps onto the lanes types (core/simd/lanes.hpp): the network lives on lane shuffles
// and masked min / max (core/sorting_network_avx512.hpp), the walk on a prefix sum across lanes and 64-bit
// integer lanes. Each gives its scalar definition's bits (detail::network_sort_hits_scalar, the walk on
// ScalarWalkLanes; for packed hits, the unpacked list's), which tests/test_hit_resolver.cpp checks.
#include <smoketrace/core/simd/isa.hpp>
#include <smoketrace/core/sorting_network_avx512.hpp>
#include <smoketrace/smoke/hit_resolver.hpp>
#include <smoketrace/smoke/hit_walk.hpp>

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

// walk_sorted_hits()'s lanes (hit_walk.hpp) in one 512-bit register each: the counters of eight hits at once
// from a prefix sum of their values across the lanes (shifted by 1, 2 and 4), the in-smoke gaps added by
// masked adds, the sums reduced in ScalarWalkLanes' order. No branch on the hits.
struct Avx512WalkLanes {
    using Ints = __m512i;
    using Doubles = __m512d;
    using Mask = __mmask8;
    static constexpr __mmask8 kEveryLane = 0xFF;

    static Mask first_lanes(std::ptrdiff_t count) {  // the first min(count, 8) lanes; none for count <= 0
        return __mmask8(count >= std::ptrdiff_t(kWalkLanes) ? 0xFFu : count <= 0 ? 0u : (1u << count) - 1u);
    }
    static Ints splat(std::int64_t x) { return _mm512_set1_epi64(x); }
    static Ints add(Ints a, Ints b) { return _mm512_add_epi64(a, b); }
    static Ints inclusive_prefix_sum(Ints s) {
        const __m512i zero = _mm512_setzero_si512();
        s = _mm512_add_epi64(s, _mm512_maskz_alignr_epi64(kEveryLane, s, zero, kWalkLanes - 1));
        s = _mm512_add_epi64(s, _mm512_maskz_alignr_epi64(kEveryLane, s, zero, kWalkLanes - 2));
        return _mm512_add_epi64(s, _mm512_maskz_alignr_epi64(kEveryLane, s, zero, kWalkLanes - 4));
    }
    static Ints broadcast_last(Ints v) {
        return _mm512_maskz_permutexvar_epi64(kEveryLane, _mm512_set1_epi64(kWalkLanes - 1), v);
    }
    static Mask positive(Ints v, Mask m) { return _mm512_mask_cmpgt_epi64_mask(m, v, _mm512_setzero_si512()); }
    static Doubles zero() { return _mm512_setzero_pd(); }
    static Doubles with_first(Doubles s, double x) { return _mm512_mask_mov_pd(s, 1, _mm512_set1_pd(x)); }
    static Doubles add_gaps(Doubles sums, Mask m, Doubles t, Doubles t_next) {
        return _mm512_mask_add_pd(sums, m, sums, _mm512_sub_pd(t_next, t));
    }
    static std::int64_t sum(Ints v) {
        const __m256i q = _mm256_add_epi64(_mm512_maskz_extracti64x4_epi64(0xF, v, 0),
                                           _mm512_maskz_extracti64x4_epi64(0xF, v, 1));
        const __m128i p = _mm_add_epi64(_mm256_castsi256_si128(q), _mm256_extracti128_si256(q, 1));
        return _mm_cvtsi128_si64(p) + _mm_extract_epi64(p, 1);
    }
    static double sum(Doubles s) {  // the halves, then the quarters, then the two left
        const __m256d q =
            _mm256_add_pd(_mm512_maskz_extractf64x4_pd(0xF, s, 0), _mm512_maskz_extractf64x4_pd(0xF, s, 1));
        const __m128d p = _mm_add_pd(_mm256_castpd256_pd128(q), _mm256_extractf128_pd(q, 1));
        return _mm_cvtsd_f64(_mm_add_sd(p, _mm_unpackhi_pd(p, p)));
    }
    static ScalarWalkLanes::Ints ints(Ints v) {
        ScalarWalkLanes::Ints r;
        _mm512_storeu_si512(r.data(), v);
        return r;
    }
    static std::uint32_t bits(Mask m) { return m; }
    static Doubles t_of_low_halves(Ints h) {  // floats in the low halves, widened to double
        return _mm512_maskz_cvtps_pd(kEveryLane, _mm256_castsi256_ps(_mm512_maskz_cvtepi64_epi32(kEveryLane, h)));
    }

    // A sorted list in memory: lane i of block b holds hit 8b + i as loaded (t in the low half, the value
    // in the high half); masked loads leave lanes past the list 0.
    struct SortedHits {
        static constexpr unsigned kMaxBlocks = 0;  // any length
        std::span<const SurfaceHit> hits;
        [[nodiscard]] std::size_t size() const { return hits.size(); }
        [[nodiscard]] double first_t() const { return static_cast<double>(hits[0].t); }
        [[nodiscard]] __m512i load(std::size_t first) const {
            return _mm512_maskz_loadu_epi64(first_lanes(std::ptrdiff_t(hits.size()) - std::ptrdiff_t(first)),
                                            hits.data() + first);
        }
        [[nodiscard]] Ints values(std::size_t b) const {
            return _mm512_maskz_srai_epi64(kEveryLane, load(b * kWalkLanes), 32);
        }
        [[nodiscard]] Doubles t(std::size_t b) const { return t_of_low_halves(load(b * kWalkLanes)); }
        [[nodiscard]] Doubles t_next(std::size_t b) const { return t_of_low_halves(load(b * kWalkLanes + 1)); }
    };
};

// R registers of sorted keys (resolve_packed_hits_avx512() below) as walk_sorted_hits()'s hits: the count
// hits first, then the padding, which the walk sees with value 0.
template <unsigned R>
struct SortedKeysAvx512 {
    using L = Avx512WalkLanes;
    static constexpr unsigned kMaxBlocks = R;
    const __m512i* v;
    std::ptrdiff_t count;
    [[nodiscard]] std::size_t size() const { return std::size_t(count); }
    [[nodiscard]] static __m512d t_of(__m512i k) {  // t's bits, as floats widened to double
        return L::t_of_low_halves(_mm512_maskz_srli_epi64(L::kEveryLane, k, 1));
    }
    [[nodiscard]] double first_t() const { return _mm512_cvtsd_f64(t_of(v[0])); }
    [[nodiscard]] __m512i values(std::size_t b) const {  // +1 entering, −1 leaving
        const __m512i one = _mm512_set1_epi64(1);
        return _mm512_maskz_sub_epi64(L::first_lanes(count - std::ptrdiff_t(kWalkLanes * b)), one,
                                      _mm512_maskz_slli_epi64(L::kEveryLane, _mm512_and_si512(v[b], one), 1));
    }
    [[nodiscard]] __m512d t(std::size_t b) const { return t_of(v[b]); }
    [[nodiscard]] __m512d t_next(std::size_t b) const {  // hit i + 1 in lane i
        const __m512i after = b + 1 < R ? v[b + 1] : _mm512_set1_epi64(-1);
        return t_of(_mm512_maskz_alignr_epi64(L::kEveryLane, after, v[b], 1));
    }
};

// A list of at most kNetworkSortMaxHits packed hits (hit_resolver.hpp), sorted and walked without leaving the
// registers: the bits of network_sort_hits_avx512() and the walk on the unpacked list. Each key is a hit's
// packed bits rotated left by one (t above the leaving flag), zero-extended; its next hit comes from the
// registers (valignq) rather than from a load at one hit's offset, which would straddle two stores of the
// sort and wait for them, and for every store before them, to reach the cache. Inlined into the dispatcher
// below: most lists fit one or two registers, and out of line each would pay a call around a short walk.
template <unsigned R>
[[gnu::always_inline]] static inline double resolve_packed_hits_avx512(const PackedSurfaceHit* packed, std::size_t n) {
    static_assert(kWalkLanes == kNetworkSortLanes, "one register of keys is one register of the walk");
    static_assert(sizeof(PackedSurfaceHit) == sizeof(std::uint32_t));
    using L = Avx512WalkLanes;
    const std::ptrdiff_t count = std::ptrdiff_t(n);
    const unsigned used = unsigned((n + kNetworkSortLanes - 1) / kNetworkSortLanes);
    const __m512i all_ones = _mm512_set1_epi64(-1);  // padding: after every key
    __m512i v[R];
#pragma GCC unroll 16
    for (unsigned r = 0; r < R; ++r) {
        if (r >= used) {
            v[r] = all_ones;
            continue;
        }
        const __mmask8 lanes = L::first_lanes(count - std::ptrdiff_t(kNetworkSortLanes * r));
        const __m512i bits = _mm512_maskz_loadu_epi32(__mmask16(lanes), packed + kNetworkSortLanes * r);
        const __m512i keys = _mm512_maskz_rol_epi32(__mmask16(lanes), bits, 1);
        v[r] = _mm512_mask_cvtepu32_epi64(all_ones, lanes, _mm512_maskz_extracti64x4_epi64(0xF, keys, 0));
    }
    bitonic_sort<R>(v);

    return walk_sorted_hits<L>(SortedKeysAvx512<R>{v, count});
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

}  // namespace smoketrace::detail
#endif  // SMOKETRACE_SIMD_AVX512

namespace smoketrace::detail {
// The lanes the resolver walks with, and explain's story with it.
#if defined(SMOKETRACE_SIMD_AVX512)
using FastWalkLanes = Avx512WalkLanes;
#else
using FastWalkLanes = ScalarWalkLanes;
#endif
}  // namespace smoketrace::detail
