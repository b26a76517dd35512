// The hit resolver (thesis 4.3.3): sort each particle's hits by t, then eq. 3.1 and the in-smoke walk.
//
// Batched vs per-particle sorting (the design question of the resolver). Two ways to get every list sorted:
//   (a) one segmented radix sort over all particles' hits, keyed by (particle, t): LSD passes over t, then
//       over the particle index (4 passes of 9-10 bits), each streaming the whole buffer (~0.7 MB at 750
//       particles x 120 hits) with a 512-1024-way scatter, then one walk per particle;
//   (b) one small sort per particle (a sorting network up to 128 hits with AVX-512, a rank sort below
//       kRadixSortMinItems, radix above), each list staying in L1 (or registers) until the walk that follows.
// Measured in bench section "resolver" (table "segmented vs per-particle", one thread, 750 particles):
// (b) is 1.25-1.55x faster at every list length from 20 to 300 hits (120 hits: 7.9 vs 11.5 ns per hit,
// sort and walk), and it parallelises over particles with no shared histogram, so HitSort::radix is (b).
#include <smoketrace/hit_resolver.hpp>
#include <smoketrace/radix_sort.hpp>
#include <smoketrace/sorting_network.hpp>

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

// The result is double: a stretch t_exit - t_enter of two floats is exact in double (unless their magnitudes
// differ by more than 2^29), so the rounding is in the running sum (relative error <= stretches * 2^-53), far
// below the float the caller stores; a float accumulator would lose ~2^-24 per stretch. Cost: one double add
// per stretch.
double optical_path_length(std::span<const SurfaceHit> sorted_hits) {
    assert(std::is_sorted(sorted_hits.begin(), sorted_hits.end(),
                          [](const SurfaceHit& a, const SurfaceHit& b) { return a.t < b.t; }));
    assert(sorted_hits.empty() || sorted_hits.front().t >= 0.0f);  // hits lie ahead of the origin (TMin > 0)
    std::int32_t counter = 0;  // eq. 3.1: counter_start = -sum of hit values = particles covering the origin
    for (const SurfaceHit& hit : sorted_hits) counter -= hit.value;

    // The counter is applied a whole group of equal-t hits at a time, and a stretch opens or closes only
    // between groups: which of two coincident surfaces (a particle ending exactly where another begins)
    // comes first then changes nothing, so any sort that orders t gives bit-identical lengths.
    double length = 0.0;
    float enter = 0.0f;  // the ray origin: a stretch that is open at t = 0 starts there
    const std::size_t n = sorted_hits.size();
    std::size_t i = 0;
    while (i < n) {
        const float t = sorted_hits[i].t;
        const bool was_in_smoke = counter > 0;
        do {
            counter += sorted_hits[i].value;
            ++i;
        } while (i < n && sorted_hits[i].t == t);  // -0 == +0: one group
        const bool in_smoke = counter > 0;
        if (in_smoke == was_in_smoke) continue;
        if (in_smoke) {
            enter = t;
        } else {
            length += static_cast<double>(t) - static_cast<double>(enter);
        }
    }
    // After the last hit the counter is counter_start + sum = 0: every stretch has closed.
    return length;
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
    // least kParticlesPerTask particles: a list takes ~0.1 µs, a task's hand-over several times that.
    constexpr std::size_t kParticlesPerTask = 64;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, particles, kParticlesPerTask),
                      [&](const tbb::blocked_range<std::size_t>& r) {
        // Scratch for the radix sort: on the stack for the usual short lists, else grown once per task.
        std::array<SurfaceHit, 256> small;
        std::vector<SurfaceHit> large;
        for (std::size_t i = r.begin(); i < r.end(); ++i) {
            if (status[i] != DepthStatus::ok) {
                lengths[i] = kFullyDarkPathLength;
                continue;
            }
            const std::span<SurfaceHit> hits = lists.of(i);
            std::span<SurfaceHit> scratch(small);
            if (method == HitSort::radix && hits.size() > small.size()) {
                if (hits.size() > large.size()) large.resize(hits.size());
                scratch = large;
            }
            sort_hits_by_t(hits, scratch, method);
            lengths[i] = static_cast<float>(optical_path_length(hits));
        }
    });
}

}  // namespace smoketrace
