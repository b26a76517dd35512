#pragma once
// A bitonic sorting network over 64-bit keys held in AVX-512 registers: eight keys per register, up to
// kNetworkSortMaxRegisters registers. The optical-depth resolver's lists are short (with the thesis's
// default cutoff of 60 no list has more than 60 hits, with its largest, 120, no more than 120: hence 128
// keys) and a network sorts them with no branch, no memory
// traffic and a fixed number of compare-exchange steps, where rank_sort() (radix_sort.hpp) compares every
// key with every other and scatters through memory. Bench section "resolver", table "sort crossover",
// compares the two.
//
// Batcher's bitonic sort of 8R keys, viewed as one array i = 8r + lane: for k = 2, 4, …, 8R and
// j = k/2, …, 1, key i is compare-exchanged with key i ^ j, ascending where i & k == 0, descending
// elsewhere. A step with j >= 8 pairs whole registers (one min and one max each); one with j < 8 pairs
// lanes of the same register (a shuffle, a min and a masked max). Every loop below has a trip count known
// at compile time and is fully unrolled, so each mask is a constant. Unmasked operations are written in
// their maskz form with every lane set (see core/simd/lanes_avx512.hpp: GCC bug 105593); the same
// instructions.
//
// AVX-512 only: its lane shuffles and masked min / max have no counterpart in the lanes types
// (core/simd/lanes.hpp), and without AVX-512 the resolver sorts with rank_sort() instead. Its definition
// is the sorted order itself: tests/test_hit_resolver.cpp holds it against std::sort.
#include <smoketrace/core/simd/isa.hpp>

#include <cstdint>

namespace smoketrace {

inline constexpr unsigned kNetworkSortLanes = 8;         // 64-bit keys per AVX-512 register
inline constexpr unsigned kNetworkSortMaxRegisters = 16;  // 128 keys

}  // namespace smoketrace

#if defined(SMOKETRACE_SIMD_AVX512)
#include <immintrin.h>

namespace smoketrace {

inline constexpr __mmask8 kEveryKey = 0xFF;

namespace detail {

// Lane l of the register holding keys 8r..8r+7 paired with lane l ^ j (j = 1, 2, 4).
template <unsigned J>
[[gnu::always_inline]] inline __m512i partner_lanes(__m512i v) {
    if constexpr (J == 1) return _mm512_maskz_shuffle_epi32(0xFFFF, v, _MM_PERM_BADC);  // the 64-bit halves of each 128
    if constexpr (J == 2) return _mm512_maskz_permutex_epi64(kEveryKey, v, 0x4E);     // the 128-bit halves of each 256
    if constexpr (J == 4) return _mm512_maskz_shuffle_i64x2(kEveryKey, v, v, 0x4E);   // the 256-bit halves
}

// Bit `lane` set where key i = 8r + lane takes the larger of its pair at step (k, j): the upper key of an
// ascending pair or the lower key of a descending one.
constexpr __mmask8 takes_max(unsigned r, unsigned k, unsigned j) {
    unsigned bits = 0;
    for (unsigned lane = 0; lane < kNetworkSortLanes; ++lane) {
        const unsigned i = kNetworkSortLanes * r + lane;
        bits |= unsigned(((i & j) != 0) != ((i & k) != 0)) << lane;
    }
    return __mmask8(bits);
}

template <unsigned R, unsigned K, unsigned J>
[[gnu::always_inline]] inline void bitonic_step(__m512i (&v)[R]) {
    if constexpr (J >= kNetworkSortLanes) {
        constexpr unsigned apart = J / kNetworkSortLanes;
#pragma GCC unroll 16
        for (unsigned r = 0; r < R; ++r) {
            if ((r & apart) != 0) continue;  // r is the lower register of its pair
            const __m512i lo = _mm512_maskz_min_epu64(kEveryKey, v[r], v[r + apart]);
            const __m512i hi = _mm512_maskz_max_epu64(kEveryKey, v[r], v[r + apart]);
            const bool ascending = ((kNetworkSortLanes * r) & K) == 0;
            v[r] = ascending ? lo : hi;
            v[r + apart] = ascending ? hi : lo;
        }
    } else {
#pragma GCC unroll 16
        for (unsigned r = 0; r < R; ++r) {
            const __m512i p = partner_lanes<J>(v[r]);
            v[r] = _mm512_mask_max_epu64(_mm512_maskz_min_epu64(kEveryKey, v[r], p), takes_max(r, K, J), v[r], p);
        }
    }
}

template <unsigned R, unsigned K, unsigned J>
[[gnu::always_inline]] inline void bitonic_merge_steps(__m512i (&v)[R]) {
    bitonic_step<R, K, J>(v);
    if constexpr (J > 1) bitonic_merge_steps<R, K, J / 2>(v);
}

template <unsigned R, unsigned K>
[[gnu::always_inline]] inline void bitonic_stages(__m512i (&v)[R]) {
    bitonic_merge_steps<R, K, K / 2>(v);
    if constexpr (K < kNetworkSortLanes * R) bitonic_stages<R, 2 * K>(v);
}

}  // namespace detail

// Sorts the 8R unsigned 64-bit keys of v[0..R) ascending: key 8r + lane is lane `lane` of v[r].
// R is 1, 2, 4, 8 or 16. Pad unused lanes with UINT64_MAX to keep them at the end.
template <unsigned R>
[[gnu::always_inline]] inline void bitonic_sort(__m512i (&v)[R]) {
    static_assert(R >= 1 && R <= kNetworkSortMaxRegisters && (R & (R - 1)) == 0);
    detail::bitonic_stages<R, 2>(v);
}

}  // namespace smoketrace
#endif  // SMOKETRACE_SIMD_AVX512
