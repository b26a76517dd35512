#pragma once
// Stable, allocation-free sorting of small and medium lists by a 32-bit key: an LSD radix sort, a rank sort
// for short lists (and the classic insertion sort it replaces), and sort_by_float_key() choosing between
// them. Used for the hit lists of the optical-depth resolver (thesis 4.3.3 used bubble sort; method.md,
// "What the thesis could not do": a sort whose cost per hit does not grow with the cutoff) and for the
// per-pixel billboard layers of the view compositor.
#include <smoketrace/core/simd/isa.hpp>
#include <smoketrace/core/stable_ranks.hpp>
#include <smoketrace/core/stable_ranks_avx2.hpp>
#include <smoketrace/core/stable_ranks_avx512.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>

namespace smoketrace {

// Maps a float to an unsigned key whose unsigned order is the float order (the IEEE-754 sign-flip trick):
// a negative float has all its bits flipped (larger magnitude -> smaller key), a positive one only its
// sign bit (so it lands above every negative). Consequences callers can rely on:
//   -inf < -FLT_MAX < ... < -denormals < -0 < +0 < +denormals < ... < FLT_MAX < +inf, all distinct keys;
//   -0 and +0 (equal as floats) get adjacent keys, -0 first, so a sort by this key is a strict refinement
//   of the float order.
// NaN is never passed: every float reaching a sort here was rejected at the boundary if NaN (a NaN would
// get a key above +inf or below -inf depending on its sign bit: deterministic but meaningless).
[[nodiscard]] constexpr std::uint32_t float_sort_key(float value) noexcept {
    const auto bits = std::bit_cast<std::uint32_t>(value);
    const std::uint32_t flip = (0u - (bits >> 31)) | 0x8000'0000u;  // all ones if negative, else the sign bit
    return bits ^ flip;
}

// Lists shorter than this are rank-sorted, longer ones radix-sorted: where the two cost the same per item
// with the AVX-512 rank sort (bench section "resolver", table "sort crossover"); past it the rank sort's
// O(n^2) compares grow while the radix sort's cost per item keeps falling. Without AVX-512 the rank sort
// compares fewer keys per instruction, so the crossover moves: re-measure there.
inline constexpr std::size_t kRadixSortMinItems = 256;
// rank_sort() keeps the keys of its list on the stack: its longest list (beyond the crossover, so that
// the benchmark can show where it loses).
inline constexpr std::size_t kRankSortMaxItems = 512;
static_assert(kRadixSortMinItems <= kRankSortMaxItems + 1);

// The radix sort's digit width adapts to the list: the widest digit with at most this many histogram
// buckets per item (so zeroing and scanning the histograms never outweighs scattering the items), then
// narrowed as far as the same number of passes allows. Fewer buckets per item means too many passes on
// short lists, fixed wide digits mean histograms larger than the list (bench "resolver", "sort crossover").
inline constexpr std::size_t kRadixBucketsPerItem = 4;
inline constexpr unsigned kRadixMinDigitBits = 4;   // below this the passes multiply for nothing
inline constexpr unsigned kRadixMaxDigitBits = 11;  // 2048 buckets: 3 passes cover any 32-bit key

namespace detail {

// Digit width for n items whose keys (minus the smallest) fit in key_bits bits: see kRadixBucketsPerItem.
[[nodiscard]] constexpr unsigned radix_digit_bits(std::size_t n, unsigned key_bits,
                                                  std::size_t buckets_per_item = kRadixBucketsPerItem) {
    unsigned widest = kRadixMinDigitBits;
    while (widest < kRadixMaxDigitBits && (std::size_t{2} << widest) <= buckets_per_item * n) ++widest;
    const unsigned passes = (key_bits + widest - 1) / widest;
    return (key_bits + passes - 1) / passes;
}

// LSD radix sort; see radix_sort() for the contract. fixed_digit_bits = 0 chooses the digit width from n
// (radix_digit_bits); the benchmark passes fixed widths to compare. Keys are sorted relative to the
// smallest, so only the bits in which they differ are sorted: the hit distances of one ray share their
// sign and top exponent bits, and 27 bits usually remain (4 passes of 7 bits for a 120-hit list).
// A pass whose digit is the same for every item is skipped.
template <class T, class KeyFn>
void radix_sort_impl(std::span<T> items, std::span<T> scratch, KeyFn key, unsigned fixed_digit_bits = 0,
                     std::size_t buckets_per_item = kRadixBucketsPerItem) {
    const std::size_t n = items.size();
    assert(scratch.size() >= n && "radix_sort: scratch must hold at least items.size() elements");
    assert(n <= UINT32_MAX && "radix_sort: bucket counters are 32-bit");
    assert(fixed_digit_bits <= kRadixMaxDigitBits);
    if (n < 2) return;

    std::uint32_t lowest = UINT32_MAX, highest = 0;
    for (const T& item : items) {
        const std::uint32_t k = key(item);
        lowest = k < lowest ? k : lowest;
        highest = k > highest ? k : highest;
    }
    const auto key_bits = static_cast<unsigned>(std::bit_width(highest - lowest));
    if (key_bits == 0) return;  // all keys equal: a stable sort changes nothing
    const unsigned bits = fixed_digit_bits ? fixed_digit_bits : radix_digit_bits(n, key_bits, buckets_per_item);
    const unsigned passes = (key_bits + bits - 1) / bits;
    const std::size_t buckets = std::size_t{1} << bits;
    const std::uint32_t mask = static_cast<std::uint32_t>(buckets - 1);

    // Histograms of every pass from one read of the items; only the buckets in use are zeroed.
    // The largest need is 3 passes x 2048 buckets (11-bit digits): 24 KiB of stack.
    constexpr std::size_t kMaxCounters = 3 * (std::size_t{1} << kRadixMaxDigitBits);
    static_assert(kMaxCounters >= ((32 + kRadixMaxDigitBits - 1) / kRadixMaxDigitBits) << kRadixMaxDigitBits);
    std::array<std::uint32_t, kMaxCounters> counts;  // NOLINT: zeroed below, as far as used
    assert(passes * buckets <= kMaxCounters);
    std::fill_n(counts.begin(), passes * buckets, 0u);
    for (const T& item : items) {
        const std::uint32_t k = key(item) - lowest;
        for (unsigned p = 0; p < passes; ++p) ++counts[p * buckets + ((k >> (p * bits)) & mask)];
    }

    T* src = items.data();
    T* dst = scratch.data();
    const std::uint32_t first_key = key(items[0]) - lowest;
    for (unsigned p = 0; p < passes; ++p) {
        const unsigned shift = p * bits;
        std::uint32_t* bucket = counts.data() + p * buckets;
        if (bucket[(first_key >> shift) & mask] == n) continue;  // every item shares this digit
        std::uint32_t sum = 0;  // exclusive prefix sum: bucket[d] becomes the first slot of digit d
        for (std::size_t d = 0; d < buckets; ++d) sum += std::exchange(bucket[d], sum);
        for (std::size_t i = 0; i < n; ++i) {
            const std::uint32_t d = ((key(src[i]) - lowest) >> shift) & mask;
            dst[bucket[d]++] = src[i];
        }
        std::swap(src, dst);
    }
    if (src != items.data()) std::copy(src, src + n, items.data());
}

}  // namespace detail

// Sorts items by key(item) -> std::uint32_t, ascending and stable, without allocating: `scratch` is caller
// supplied working memory of at least items.size() elements (its contents are overwritten).
template <class T, class KeyFn>
    requires std::copyable<T> && std::invocable<KeyFn&, const T&>
void radix_sort(std::span<T> items, std::span<T> scratch, KeyFn key) {
    detail::radix_sort_impl(items, scratch, key);
}

namespace detail {

// The stable rank of every key (stable_ranks.hpp): with AVX-512 a block of 16 keys per instruction and
// relation, with AVX2 in two halves, elsewhere the scalar definition.
inline void stable_ranks(const std::uint32_t* keys, std::size_t n, std::uint32_t* ranks) {
#if defined(SMOKETRACE_SIMD_AVX512)
    stable_ranks_avx512(keys, n, ranks);
#elif defined(SMOKETRACE_SIMD_AVX2)
    stable_ranks_avx2(keys, n, ranks);
#else
    stable_ranks_scalar(keys, n, ranks);
#endif
}

}  // namespace detail

// Stable rank sort: item i goes to slot #{j : key_j < key_i, or key_j == key_i and j < i}. O(n^2) compares,
// but branch-free over a contiguous, padded key array, 16 keys per AVX-512 compare, where insertion sort
// mispredicts its loop exit once per item. The loops are written in fixed blocks: plain loops, which GCC
// vectorises with a remainder whose trip count changes with every list, mispredict in the same way.
// key(item) -> std::uint32_t; `scratch`: at least items.size() elements. Lists longer than kRankSortMaxItems
// (whose keys would not fit its stack array) are handed to radix_sort, which gives the same order.
template <class T, class KeyFn>
    requires std::copyable<T> && std::invocable<KeyFn&, const T&>
void rank_sort(std::span<T> items, std::span<T> scratch, KeyFn key) {
    const std::size_t n = items.size();
    assert(scratch.size() >= n && "rank_sort: scratch must hold at least items.size() elements");
    if (n > kRankSortMaxItems) {
        radix_sort(items, scratch, key);
        return;
    }
    alignas(64) std::array<std::uint32_t, kRankSortMaxItems + detail::kRankBlock> keys;  // NOLINT: filled below
    std::array<std::uint32_t, kRankSortMaxItems> ranks;                                  // NOLINT
    for (std::size_t i = 0; i < n; ++i) keys[i] = key(items[i]);
    const std::size_t padded = (n + detail::kRankBlock - 1) / detail::kRankBlock * detail::kRankBlock;
    std::fill(keys.begin() + std::ptrdiff_t(n), keys.begin() + std::ptrdiff_t(padded), UINT32_MAX);
    detail::stable_ranks(keys.data(), n, ranks.data());
    for (std::size_t i = 0; i < n; ++i) scratch[ranks[i]] = items[i];
    std::copy(scratch.begin(), scratch.begin() + static_cast<std::ptrdiff_t>(n), items.begin());
}

// Stable insertion sort by key(item) (any type with operator<): the textbook short-list sort, no scratch
// needed. Slower than rank_sort (see above); kept for callers without scratch memory and as the baseline.
template <class T, class KeyFn>
    requires std::copyable<T> && std::invocable<KeyFn&, const T&>
void insertion_sort(std::span<T> items, KeyFn key) {
    for (std::size_t i = 1; i < items.size(); ++i) {
        T item = items[i];
        const auto item_key = key(item);
        std::size_t j = i;
        for (; j > 0 && item_key < key(items[j - 1]); --j) items[j] = items[j - 1];
        items[j] = item;
    }
}

// Sorts items ascending and stably by the float key(item) (never NaN), choosing rank sort for short lists
// and radix sort otherwise. Both order by float_sort_key(), so the result does not depend on which one ran
// (-0 before +0; equal keys keep their input order). `scratch`: at least items.size() elements.
template <class T, class KeyFn>
    requires std::copyable<T> && std::invocable<KeyFn&, const T&>
void sort_by_float_key(std::span<T> items, std::span<T> scratch, KeyFn key) {
    auto bits = [&key](const T& item) { return float_sort_key(key(item)); };
    if (items.size() < kRadixSortMinItems) {
        rank_sort(items, scratch, bits);
    } else {
        radix_sort(items, scratch, bits);
    }
}

}  // namespace smoketrace
