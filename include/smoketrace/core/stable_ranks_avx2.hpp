#pragma once
// stable_ranks() (stable_ranks.hpp) with AVX2: a block of 16 keys in two halves of 8 lanes, unsigned
// order from signed compares after flipping the sign bits. Integer compares and counts, so the ranks are
// stable_ranks_scalar()'s exactly (tests/test_hit_resolver.cpp, in the x86-64-v3 build).
#include <smoketrace/core/simd/isa.hpp>
#include <smoketrace/core/stable_ranks.hpp>

#include <cstddef>
#include <cstdint>

#if defined(SMOKETRACE_SIMD_AVX2)
#include <immintrin.h>

namespace smoketrace::detail {

inline void stable_ranks_avx2(const std::uint32_t* keys, std::size_t n, std::uint32_t* ranks) {
    const std::size_t blocks = (n + kRankBlock - 1) / kRankBlock;
    for (std::size_t i = 0; i < n; ++i) {
        // A compare gives −1 per true lane, so subtracting it counts; blocks before i's count keys > k,
        // which the rank then subtracts from their size.
        const __m256i flip = _mm256_set1_epi32(int(0x8000'0000u));
        const __m256i k = _mm256_set1_epi32(int(keys[i] ^ 0x8000'0000u));
        auto half = [&](std::size_t at) {
            return _mm256_xor_si256(_mm256_load_si256(reinterpret_cast<const __m256i*>(keys + at)), flip);
        };
        const std::size_t own = i / kRankBlock;
        __m256i greater_before = _mm256_setzero_si256(), less = _mm256_setzero_si256();
        for (std::size_t b = 0; b < own; ++b)
            for (std::size_t h = 0; h < kRankBlock; h += 8)
                greater_before = _mm256_sub_epi32(greater_before, _mm256_cmpgt_epi32(half(kRankBlock * b + h), k));
        const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        const __m256i position = _mm256_set1_epi32(int(i % kRankBlock));
        for (std::size_t h = 0; h < kRankBlock; h += 8) {
            const __m256i block = half(kRankBlock * own + h);
            const __m256i earlier = _mm256_cmpgt_epi32(position, _mm256_add_epi32(lane, _mm256_set1_epi32(int(h))));
            const __m256i before = _mm256_or_si256(_mm256_cmpgt_epi32(k, block),
                                                   _mm256_and_si256(_mm256_cmpeq_epi32(k, block), earlier));
            less = _mm256_sub_epi32(less, before);
        }
        for (std::size_t b = own + 1; b < blocks; ++b)
            for (std::size_t h = 0; h < kRankBlock; h += 8)
                less = _mm256_sub_epi32(less, _mm256_cmpgt_epi32(k, half(kRankBlock * b + h)));
        const __m256i total = _mm256_sub_epi32(less, greater_before);
        const __m128i sum4 = _mm_add_epi32(_mm256_castsi256_si128(total), _mm256_extracti128_si256(total, 1));
        const __m128i sum2 = _mm_add_epi32(sum4, _mm_shuffle_epi32(sum4, _MM_SHUFFLE(1, 0, 3, 2)));
        const __m128i sum1 = _mm_add_epi32(sum2, _mm_shuffle_epi32(sum2, _MM_SHUFFLE(2, 3, 0, 1)));
        ranks[i] = std::uint32_t(kRankBlock * own) + std::uint32_t(_mm_cvtsi128_si32(sum1));
    }
}

}  // namespace smoketrace::detail
#endif  // SMOKETRACE_SIMD_AVX2
