#pragma once
// stable_ranks() (stable_ranks.hpp) with AVX-512: a block of 16 keys compared with one instruction per
// relation. Integer compares and counts, so the ranks are stable_ranks_scalar()'s exactly
// (tests/test_hit_resolver.cpp). A compare into a mask register and a popcount per block have no
// counterpart in the lanes types (core/simd/lanes.hpp), whose AVX2 form would accumulate in a register.
#include <smoketrace/core/simd/isa.hpp>
#include <smoketrace/core/stable_ranks.hpp>

#include <bit>
#include <cstddef>
#include <cstdint>

#if defined(SMOKETRACE_SIMD_AVX512)
#include <immintrin.h>

namespace smoketrace::detail {

inline void stable_ranks_avx512(const std::uint32_t* keys, std::size_t n, std::uint32_t* ranks) {
    const std::size_t blocks = (n + kRankBlock - 1) / kRankBlock;
    for (std::size_t i = 0; i < n; ++i) {
        std::uint32_t rank = 0;
        // Blocks before i's count keys <= k, blocks after it keys < k, i's own block both by lane: one
        // compare and one popcount per block, no branch inside the loops.
        const __m512i k = _mm512_set1_epi32(int(keys[i]));
        const std::size_t own = i / kRankBlock;
        for (std::size_t b = 0; b < own; ++b)
            rank += unsigned(
                std::popcount(unsigned(_mm512_cmple_epu32_mask(_mm512_load_si512(keys + kRankBlock * b), k))));
        {
            const __m512i block = _mm512_load_si512(keys + kRankBlock * own);
            const __mmask16 earlier = __mmask16((1u << (i % kRankBlock)) - 1u);
            rank += unsigned(std::popcount(unsigned(_mm512_cmplt_epu32_mask(block, k) |
                                                    _mm512_mask_cmpeq_epu32_mask(earlier, block, k))));
        }
        for (std::size_t b = own + 1; b < blocks; ++b)
            rank += unsigned(
                std::popcount(unsigned(_mm512_cmplt_epu32_mask(_mm512_load_si512(keys + kRankBlock * b), k))));
        ranks[i] = rank;
    }
}

}  // namespace smoketrace::detail
#endif  // SMOKETRACE_SIMD_AVX512
