#pragma once
// The stable ranks of a list of 32-bit keys, the core of rank_sort() (radix_sort.hpp): the definition,
// one key at a time. stable_ranks_avx512.hpp and stable_ranks_avx2.hpp compute the same ranks many keys
// per instruction; radix_sort.hpp's detail::stable_ranks() takes the one the build targets, and
// tests/test_hit_resolver.cpp holds each against this one.
#include <cstddef>
#include <cstdint>

namespace smoketrace::detail {

// ranks[i] = #{j : keys[j] < keys[i], or keys[j] == keys[i] and j < i}. `keys` holds n keys and is padded
// with UINT32_MAX up to the next multiple of kRankBlock: a padding lane is never less than a key, and
// being at j >= n > i it is never an earlier equal one either, so the kernels need no remainder loop.
inline constexpr std::size_t kRankBlock = 16;

inline void stable_ranks_scalar(const std::uint32_t* keys, std::size_t n, std::uint32_t* ranks) {
    for (std::size_t i = 0; i < n; ++i) {
        std::uint32_t rank = 0;
        const std::uint32_t k = keys[i];
        for (std::size_t j = 0; j < i; ++j) rank += keys[j] <= k;  // equal keys earlier in the input go first
        for (std::size_t j = i + 1; j < n; ++j) rank += keys[j] < k;
        ranks[i] = rank;
    }
}

}  // namespace smoketrace::detail
