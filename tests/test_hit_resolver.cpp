// The hit resolver (thesis 4.3.3) and its sorts: float_sort_key, radix / insertion sort against
// std::stable_sort, eq. 3.1 and the in-smoke walk against exact answers, and the three HitSort methods
// against each other and against an independent interval-union computation. The kernels written for one
// instruction set (stable_ranks_avx512 / _avx2, the sorting network, the AVX-512 walk) against their
// scalar definitions, bit for bit, in the builds that have that set.
#include <smoketrace/core/prng.hpp>
#include <smoketrace/core/radix_sort.hpp>
#include <smoketrace/core/simd/isa.hpp>
#include <smoketrace/core/sorting_network_avx512.hpp>
#include <smoketrace/core/stable_ranks.hpp>
#include <smoketrace/core/stable_ranks_avx2.hpp>
#include <smoketrace/core/stable_ranks_avx512.hpp>
#include <smoketrace/smoke/hit_resolver.hpp>
#include <smoketrace/smoke/hit_resolver_avx512.hpp>
#include <smoketrace/smoke/hit_walk.hpp>

#include <catch2/catch.hpp>
#include <tbb/task_arena.h>

#include <algorithm>
#include <bit>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

using namespace smoketrace;

namespace {


template <class T>
void shuffle(std::vector<T>& v, Pcg32& rng) {
    for (std::size_t i = v.size(); i > 1; --i) std::swap(v[i - 1], v[rng.below(static_cast<std::uint32_t>(i))]);
}

struct Keyed {
    std::uint32_t key;
    std::uint32_t index;  // input position: checks stability
    bool operator==(const Keyed&) const = default;
};

bool same_bits(float a, float b) { return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b); }

// Key distributions that exercise every radix pass, skipped passes and ties.
std::vector<Keyed> make_keys(std::size_t n, int kind, Pcg32& rng) {
    std::vector<Keyed> v(n);
    for (std::size_t i = 0; i < n; ++i) {
        std::uint32_t k = 0;
        switch (kind) {
            case 0: k = rng.next_u32(); break;                   // all four digits vary
            case 1: k = rng.below(5) * 0x0101'0101u; break;      // few distinct keys: ties everywhere
            case 2: k = rng.below(256) << 24; break;             // only the top digit varies
            case 3: k = 0xDEAD'BEEFu; break;                     // all equal: every pass skipped
            case 4: k = 0x3F80'0000u | (rng.next_u32() & 0x0000'0FFFu); break;  // only the low 12 bits vary
            case 5: k = (rng.below(4) << 30) | rng.below(4); break;  // top and bottom vary: middle passes skipped
            case 6: k = rng.below(3) == 0 ? UINT32_MAX : rng.below(3) == 0 ? 0u : rng.next_u32(); break;  // extremes:
                    // UINT32_MAX is also the rank sort's padding, which must never count
        }
        v[i] = {k, static_cast<std::uint32_t>(i)};
    }
    return v;
}

// Edges of the rank sort's 16-key blocks (15, 16, 17, …) and of the sort thresholds.
const std::vector<std::size_t> kSortSizes = {0,  1,  2,  3,  15, 16, 17, 31, 32, 33, 63, 64, 65, 100,
                                             kRadixSortMinItems - 1, kRadixSortMinItems, kRadixSortMinItems + 1,
                                             kRankSortMaxItems, 257, 1000, 4096, 100000};

// Reference optical path length, independent of the walk: the measure of the union of the particles'
// chords clipped to the ray [0, inf), by sorting the intervals and merging them, in double.
struct Interval {
    float a, b;  // entry and exit distance, a < b; a <= 0: the particle covers the ray origin
};

double union_length(std::vector<Interval> intervals) {
    std::vector<std::pair<double, double>> clipped;
    for (const Interval& iv : intervals) {
        if (iv.b > 0.0f) clipped.emplace_back(std::max(0.0, static_cast<double>(iv.a)), static_cast<double>(iv.b));
    }
    std::sort(clipped.begin(), clipped.end());
    double total = 0.0;
    std::size_t i = 0;
    while (i < clipped.size()) {
        const double start = clipped[i].first;
        double end = clipped[i].second;
        for (++i; i < clipped.size() && clipped[i].first <= end; ++i) end = std::max(end, clipped[i].second);
        total += end - start;
    }
    return total;
}

// The hits an optical-depth ray would report for these chords: no entry behind or at the origin.
std::vector<SurfaceHit> hits_of(const std::vector<Interval>& intervals) {
    std::vector<SurfaceHit> hits;
    for (const Interval& iv : intervals) {
        if (iv.a > 0.0f) hits.push_back({iv.a, +1});
        if (iv.b > 0.0f) hits.push_back({iv.b, -1});
    }
    return hits;
}

// Random chords along one ray. On a grid (multiples of 1/8) endpoints coincide often: touching and
// nested particles and ties in t. Otherwise endpoints are arbitrary floats.
std::vector<Interval> random_intervals(Pcg32& rng, std::size_t count, bool on_grid) {
    std::vector<Interval> v;
    while (v.size() < count) {
        float a, b;
        if (on_grid) {
            a = static_cast<float>(static_cast<int>(rng.below(160)) - 16) * 0.125f;  // [-2, 18)
            b = a + static_cast<float>(1 + rng.below(24)) * 0.125f;
        } else {
            a = static_cast<float>(double(rng.uniform01()) * 22.0 - 2.0);
            b = static_cast<float>(static_cast<double>(a) + 0.01 + double(rng.uniform01()) * 3.0);
        }
        v.push_back({a, b});
    }
    return v;
}

std::vector<float> resolve(HitLists lists, std::span<const DepthStatus> status, HitSort method) {
    std::vector<float> lengths(lists.particle_count(), -1.0f);
    resolve_optical_path_lengths(lists, status, lengths, method);
    return lengths;
}

}  // namespace

TEST_CASE("float_sort_key orders floats like operator<", "[resolver]") {
    const float denorm = std::numeric_limits<float>::denorm_min();
    const float inf = std::numeric_limits<float>::infinity();
    const std::vector<float> ladder = {-inf, -FLT_MAX, -1.5f, -1.0f, -FLT_MIN, -2 * denorm, -denorm, -0.0f,
                                       0.0f, denorm,   2 * denorm, FLT_MIN, 1e-7f, 1.0f, 1.5f, FLT_MAX, inf};
    for (std::size_t i = 1; i < ladder.size(); ++i) {
        INFO("between " << ladder[i - 1] << " and " << ladder[i]);
        CHECK(float_sort_key(ladder[i - 1]) < float_sort_key(ladder[i]));
    }
    // -0 and +0 compare equal as floats: adjacent keys, -0 first.
    CHECK(float_sort_key(0.0f) == float_sort_key(-0.0f) + 1);

    Pcg32 rng(1);
    for (int i = 0; i < 200000; ++i) {
        const float a = std::bit_cast<float>(rng.next_u32());
        const float b = std::bit_cast<float>(rng.next_u32());
        if (std::isnan(a) || std::isnan(b)) continue;
        INFO(a << " vs " << b);
        CHECK((a < b) == (float_sort_key(a) < float_sort_key(b)));
        CHECK((a == b) == (float_sort_key(a) == float_sort_key(b)));  // random bits: never both zeros
    }
}

TEST_CASE("radix, rank and insertion sort match std::stable_sort", "[resolver]") {
    Pcg32 rng(2);
    auto by_key = [](const Keyed& x) { return x.key; };
    for (const std::size_t n : kSortSizes) {
        for (int kind = 0; kind < 7; ++kind) {
            INFO("n = " << n << ", key kind " << kind);
            std::vector<Keyed> input = make_keys(n, kind, rng);
            std::vector<Keyed> expected = input;
            std::stable_sort(expected.begin(), expected.end(),
                             [](const Keyed& a, const Keyed& b) { return a.key < b.key; });

            std::vector<Keyed> items = input, scratch(n);
            radix_sort(std::span{items}, std::span{scratch}, by_key);
            CHECK(items == expected);

            for (const unsigned digit_bits : {1u, 4u, 7u, 8u, 11u}) {  // fixed widths, as the benchmark compares
                INFO("digit bits " << digit_bits);
                items = input;
                detail::radix_sort_impl(std::span{items}, std::span{scratch}, by_key, digit_bits);
                CHECK(items == expected);
            }
            for (const std::size_t buckets_per_item : {1u, 16u}) {  // other automatic widths
                items = input;
                detail::radix_sort_impl(std::span{items}, std::span{scratch}, by_key, 0, buckets_per_item);
                CHECK(items == expected);
            }

            items = input;  // beyond kRankSortMaxItems: handed to the radix sort
            rank_sort(std::span{items}, std::span{scratch}, by_key);
            CHECK(items == expected);
            if (n <= 4096) {  // O(n^2)
                items = input;
                insertion_sort(std::span{items}, by_key);
                CHECK(items == expected);
            }
        }
    }
}

TEST_CASE("radix_sort accepts a scratch buffer longer than the items", "[resolver]") {
    Pcg32 rng(3);
    std::vector<Keyed> items = make_keys(300, 0, rng), scratch(1000);
    std::vector<Keyed> expected = items;
    std::stable_sort(expected.begin(), expected.end(), [](const Keyed& a, const Keyed& b) { return a.key < b.key; });
    radix_sort(std::span{items}, std::span{scratch}, [](const Keyed& x) { return x.key; });
    CHECK(items == expected);
}

TEST_CASE("sort_by_float_key sorts floats stably on both sides of the threshold", "[resolver]") {
    struct Layer {
        float depth;
        std::uint32_t index;
        bool operator==(const Layer&) const = default;
    };
    Pcg32 rng(4);
    for (const std::size_t n : kSortSizes) {
        for (int kind = 0; kind < 3; ++kind) {
            INFO("n = " << n << ", kind " << kind);
            std::vector<Layer> items(n);
            for (std::size_t i = 0; i < n; ++i) {
                float d = 0.0f;
                if (kind == 0) {  // any non-NaN float, negatives, denormals and infinities included
                    do d = std::bit_cast<float>(rng.next_u32());
                    while (std::isnan(d));
                } else if (kind == 1) {  // distances along a ray with many ties
                    d = static_cast<float>(rng.below(64)) * 0.25f;
                } else {  // signed zeros: -0 must come before +0, ties stable
                    d = rng.below(2) ? 0.0f : -0.0f;
                }
                items[i] = {d, static_cast<std::uint32_t>(i)};
            }
            std::vector<Layer> expected = items;
            std::stable_sort(expected.begin(), expected.end(), [](const Layer& a, const Layer& b) {
                return float_sort_key(a.depth) < float_sort_key(b.depth);
            });
            std::vector<Layer> scratch(n);
            sort_by_float_key(std::span{items}, std::span{scratch}, [](const Layer& l) { return l.depth; });
            CHECK(items == expected);
        }
    }
}

// The rank kernels of the build against stable_ranks_scalar(), rank for rank: every length across the
// 16-key blocks up to kRankSortMaxItems, keys with ties and extremes (UINT32_MAX is also the padding).
TEST_CASE("stable_ranks: each instruction-set kernel gives the scalar ranks", "[resolver]") {
    Pcg32 rng(12);
    for (std::size_t n = 0; n <= kRankSortMaxItems; n += n < 70 ? 1 : 37) {
        for (int kind = 0; kind < 7; ++kind) {
            INFO("n = " << n << ", key kind " << kind);
            alignas(64) std::uint32_t keys[kRankSortMaxItems + detail::kRankBlock];
            const std::vector<Keyed> input = make_keys(n, kind, rng);
            for (std::size_t i = 0; i < n; ++i) keys[i] = input[i].key;
            const std::size_t padded = (n + detail::kRankBlock - 1) / detail::kRankBlock * detail::kRankBlock;
            std::fill(keys + n, keys + padded, UINT32_MAX);
            std::vector<std::uint32_t> expected(n), got(n);
            detail::stable_ranks_scalar(keys, n, expected.data());
#if defined(SMOKETRACE_SIMD_AVX512)
            detail::stable_ranks_avx512(keys, n, got.data());
            CHECK(got == expected);
#endif
#if defined(SMOKETRACE_SIMD_AVX2)
            std::fill(got.begin(), got.end(), 0u);
            detail::stable_ranks_avx2(keys, n, got.data());
            CHECK(got == expected);
#endif
            std::fill(got.begin(), got.end(), 0u);
            detail::stable_ranks(keys, n, got.data());  // the one rank_sort() uses
            CHECK(got == expected);
        }
    }
}

#if defined(SMOKETRACE_SIMD_AVX512)
// bitonic_sort() of 8R keys in memory (64-byte aligned), in place.
template <unsigned R>
void bitonic_sort_keys(std::uint64_t* keys) {
    __m512i v[R];
    for (unsigned r = 0; r < R; ++r) v[r] = _mm512_load_si512(keys + kNetworkSortLanes * r);
    bitonic_sort<R>(v);
    for (unsigned r = 0; r < R; ++r) _mm512_store_si512(keys + kNetworkSortLanes * r, v[r]);
}

// The network on its own, for each register count, against std::sort: random keys, few distinct keys,
// all equal, and the extremes (UINT64_MAX is also the resolver's padding).
template <unsigned R>
void check_bitonic_sort(Pcg32& rng) {
    constexpr std::size_t n = kNetworkSortLanes * R;
    for (int kind = 0; kind < 4; ++kind) {
        for (int round = 0; round < 50; ++round) {
            INFO(R << " registers, key kind " << kind);
            alignas(64) std::uint64_t keys[n];
            for (std::uint64_t& k : keys) {
                const std::uint64_t random = (std::uint64_t(rng.next_u32()) << 32) | rng.next_u32();
                switch (kind) {
                    case 0: k = random; break;
                    case 1: k = rng.below(3) * 0x0123'4567'89AB'CDEFu; break;
                    case 2: k = 42; break;
                    case 3: k = rng.below(3) == 0 ? UINT64_MAX : rng.below(2) == 0 ? 0u : random; break;
                }
            }
            std::vector<std::uint64_t> expected(keys, keys + n);
            std::sort(expected.begin(), expected.end());
            bitonic_sort_keys<R>(keys);
            CHECK(std::vector<std::uint64_t>(keys, keys + n) == expected);
        }
    }
}

TEST_CASE("the bitonic sorting network sorts 8 to 128 keys like std::sort", "[resolver]") {
    Pcg32 rng(11);
    check_bitonic_sort<1>(rng);
    check_bitonic_sort<2>(rng);
    check_bitonic_sort<4>(rng);
    check_bitonic_sort<8>(rng);
    check_bitonic_sort<16>(rng);
}

// The network's hit lists, loaded as keys and stored back, against network_sort_hits_scalar(): every
// length up to kNetworkSortMaxHits, with negative t, ±0, ties in t with different values, and values
// of both signs, compared bit for bit.
TEST_CASE("network_sort_hits_avx512 orders hits as its scalar definition does", "[resolver]") {
    Pcg32 rng(14);
    const float ladder[] = {-std::numeric_limits<float>::infinity(), -2.5f, -0.0f, 0.0f, 1e-30f, 0.5f, 3.0f, 1e30f};
    for (std::size_t n = 0; n <= detail::kNetworkSortMaxHits; ++n) {
        for (int round = 0; round < 20; ++round) {
            std::vector<SurfaceHit> hits(n);
            for (SurfaceHit& h : hits) {
                h.t = round % 2 == 0 ? ladder[rng.below(8)] : std::bit_cast<float>(rng.next_u32() & 0xBFFF'FFFFu);
                h.value = std::int32_t(rng.below(5)) - 2;
            }
            std::vector<SurfaceHit> expected = hits;
            detail::network_sort_hits_scalar(expected);
            detail::network_sort_hits_avx512(hits);
            INFO("n = " << n << ", round " << round);
            for (std::size_t i = 0; i < n; ++i) {
                CHECK(same_bits(hits[i].t, expected[i].t));
                CHECK(hits[i].value == expected[i].value);
            }
        }
    }
}
#endif

// Every length around the network's register sizes and past them, for the three methods: the hits come
// out in float_sort_key() order of t, and they are the hits that went in.
TEST_CASE("sort_hits_by_t orders any list by t and keeps its hits", "[resolver]") {
    Pcg32 rng(12);
    auto key_then_value = [](const SurfaceHit& a, const SurfaceHit& b) {
        return float_sort_key(a.t) != float_sort_key(b.t) ? float_sort_key(a.t) < float_sort_key(b.t)
                                                          : a.value < b.value;
    };
    std::vector<std::size_t> sizes;
    for (std::size_t n = 0; n <= 140; ++n) sizes.push_back(n);
    for (const std::size_t n : {255u, 256u, 300u}) sizes.push_back(n);
    for (const std::size_t n : sizes) {
        for (int kind = 0; kind < 3; ++kind) {
            std::vector<SurfaceHit> input(n);
            for (SurfaceHit& h : input) {
                if (kind == 0) {  // any non-NaN float: negatives, denormals, infinities, both zeros
                    do h.t = std::bit_cast<float>(rng.next_u32());
                    while (std::isnan(h.t));
                } else if (kind == 1) {  // distances on a grid: ties everywhere
                    h.t = static_cast<float>(rng.below(8)) * 0.5f;
                } else {  // signed zeros: -0 sorts before +0
                    h.t = rng.below(2) ? 0.0f : -0.0f;
                }
                h.value = rng.below(2) ? +1 : -1;
            }
            std::vector<SurfaceHit> expected = input;
            std::sort(expected.begin(), expected.end(), key_then_value);
            for (const HitSort method : {HitSort::adaptive, HitSort::std_sort, HitSort::bubble}) {
                INFO(n << " hits, kind " << kind << ", method " << int(method));
                std::vector<SurfaceHit> hits = input, scratch(n);
                sort_hits_by_t(hits, scratch, method);
                // Ascending t; the radix method also puts -0 before +0 (equal as floats).
                auto before = [&](const SurfaceHit& a, const SurfaceHit& b) {
                    return method == HitSort::adaptive ? float_sort_key(a.t) < float_sort_key(b.t) : a.t < b.t;
                };
                const bool ordered = std::is_sorted(hits.begin(), hits.end(), before);
                CHECK(ordered);
                std::sort(hits.begin(), hits.end(), key_then_value);  // the same hits, in any tie order
                const bool same = std::equal(hits.begin(), hits.end(), expected.begin(), expected.end(),
                                             [](const SurfaceHit& a, const SurfaceHit& b) {
                                                 return same_bits(a.t, b.t) && a.value == b.value;
                                             });
                CHECK(same);
            }
        }
    }
}

// Hand-built rays. Every endpoint and every difference is exactly representable, so the expected lengths
// are exact and compared with ==.
TEST_CASE("optical_path_length: eq. 3.1 and the in-smoke walk on hand-built rays", "[resolver]") {
    auto length = [](std::vector<SurfaceHit> hits) {
        std::sort(hits.begin(), hits.end(), [](const SurfaceHit& a, const SurfaceHit& b) { return a.t < b.t; });
        return optical_path_length(hits);
    };
    SECTION("empty list: nothing in smoke") { CHECK(length({}) == 0.0); }
    SECTION("single particle seen from its centre: starts inside, leaves at its radius") {
        CHECK(length({{0.75f, -1}}) == 0.75);
    }
    SECTION("two overlapping particles form one stretch") {
        CHECK(length({{1.0f, -1}, {0.5f, +1}, {2.0f, -1}}) == 2.0);
    }
    SECTION("two disjoint clouds: the gap does not count") {
        CHECK(length({{1.0f, -1}, {3.0f, +1}, {4.5f, -1}}) == 2.5);
    }
    SECTION("a particle nested in another adds nothing") {
        CHECK(length({{0.5f, -1}, {1.0f, +1}, {4.0f, -1}, {2.0f, +1}, {3.0f, -1}}) == 3.5);
    }
    SECTION("origin covered by 3 particles: counter starts at 3") {
        CHECK(length({{1.0f, -1}, {2.0f, -1}, {3.0f, -1}, {4.0f, +1}, {6.0f, -1}}) == 5.0);
    }
    SECTION("origin outside smoke: counter starts at 0, the stretch before the first entry does not count") {
        CHECK(length({{1.0f, +1}, {2.0f, -1}}) == 1.0);
    }
    SECTION("touching particles: one leaves where the next enters") {
        CHECK(length({{1.0f, -1}, {1.0f, +1}, {2.0f, -1}}) == 2.0);
    }
}

TEST_CASE("optical_path_length does not depend on the order of equal-t hits", "[resolver]") {
    SECTION("every order of two tie groups gives the same union") {
        // Counter 2 at t = 0. At t = 2 one particle ends, two begin, one more ends: in some orders the counter
        // touches 0 inside the group. At t = 5 two end and one begins. Union [0, 5] u [7, 8] u [8.5, 9].
        std::vector<SurfaceHit> hits = {{1.0f, -1}, {2.0f, -1}, {2.0f, +1}, {2.0f, +1}, {2.0f, -1}, {5.0f, -1},
                                        {5.0f, +1}, {5.0f, -1}, {7.0f, +1}, {8.0f, -1}, {8.5f, +1}, {9.0f, -1}};
        auto by_value = [](const SurfaceHit& a, const SurfaceHit& b) { return a.value < b.value; };
        std::sort(hits.begin() + 1, hits.begin() + 5, by_value);
        std::sort(hits.begin() + 5, hits.begin() + 8, by_value);
        int orders = 0;
        do {
            do {
                CHECK(optical_path_length(hits) == 6.5);
                ++orders;
            } while (std::next_permutation(hits.begin() + 5, hits.begin() + 8, by_value));
        } while (std::next_permutation(hits.begin() + 1, hits.begin() + 5, by_value));
        CHECK(orders == 6 * 3);  // distinct orders of {-1,-1,+1,+1} times those of {-1,-1,+1}
    }
    SECTION("a tie where a per-hit walk would round differently") {
        // The origin's particle ends at x0; after a gap, smoke from e to t2 with two particles touching at t1.
        // Closing and reopening the stretch at t1 adds (t1 - e) + (t2 - t1) to x0 in double, which rounds
        // differently from adding (t2 - e) once (values found by search; large t makes the rounding visible).
        const float x0 = 0x1.450e96p-7f, e = 0x1.aca7dep+2f, t1 = 0x1.5eae0cp+25f, t2 = 0x1.2b2d7cp+26f;
        const std::vector<SurfaceHit> exit_first = {{x0, -1}, {e, +1}, {t1, -1}, {t1, +1}, {t2, -1}};
        const std::vector<SurfaceHit> entry_first = {{x0, -1}, {e, +1}, {t1, +1}, {t1, -1}, {t2, -1}};
        // Guard that the case discriminates: a walk that closes a stretch at every hit depends on the order.
        auto per_hit_walk = [](const std::vector<SurfaceHit>& hits) {
            int counter = 1;
            double length = 0.0, enter = 0.0;
            for (const SurfaceHit& h : hits) {
                const int before = counter;
                counter += h.value;
                if (before <= 0 && counter > 0) enter = h.t;
                if (before > 0 && counter <= 0) length += static_cast<double>(h.t) - enter;
            }
            return length;
        };
        REQUIRE(per_hit_walk(exit_first) != per_hit_walk(entry_first));

        const double expected = static_cast<double>(x0) + (static_cast<double>(t2) - static_cast<double>(e));
        CHECK(optical_path_length(exit_first) == expected);
        CHECK(optical_path_length(entry_first) == expected);
    }
}

// With AVX-512, optical_path_length() walks on Avx512WalkLanes, eight hits per instruction; it must give
// the bits of the same walk on ScalarWalkLanes (elsewhere it is that walk). Lists of every length
// up to 3 registers and beyond, with ties, origins inside smoke and t spread over many binades, so that
// the sums round.
TEST_CASE("optical_path_length gives the bits of the scalar walk", "[resolver]") {
    Pcg32 rng(13);
    for (int round = 0; round < 4000; ++round) {
        const std::size_t chords = rng.below(40);
        std::vector<SurfaceHit> hits = hits_of(random_intervals(rng, chords, round % 2 == 0));
        if (round % 3 == 0) {
            for (SurfaceHit& h : hits) h.t = std::ldexp(h.t, int(rng.below(40)) - 20);  // binades apart
        }
        std::sort(hits.begin(), hits.end(), [](const SurfaceHit& a, const SurfaceHit& b) { return a.t < b.t; });
        INFO("round " << round << ", " << hits.size() << " hits");
        const double scalar =
            detail::walk_sorted_hits<detail::ScalarWalkLanes>(detail::ScalarWalkLanes::SortedHits{hits});
        CHECK(std::bit_cast<std::uint64_t>(optical_path_length(hits)) == std::bit_cast<std::uint64_t>(scalar));
#if defined(SMOKETRACE_SIMD_AVX512)
        const double avx512 =
            detail::walk_sorted_hits<detail::Avx512WalkLanes>(detail::Avx512WalkLanes::SortedHits{hits});
        CHECK(std::bit_cast<std::uint64_t>(avx512) == std::bit_cast<std::uint64_t>(scalar));
#endif
    }
}

TEST_CASE("a list of packed hits resolves to the bits of the list unpacked", "[resolver]") {
    // Lists of 0..200 chords (0..400 hits: every network size, and past the largest to the unpacking path),
    // half on a grid to force ties, a third spread over many binades, in any-hit order.
    Pcg32 rng(29);
    ListResolver packed_resolver, resolver;
    for (int round = 0; round < 3000; ++round) {
        const std::size_t chords = round < 200 ? std::size_t(round) : rng.below(201);
        std::vector<SurfaceHit> hits = hits_of(random_intervals(rng, chords, round % 2 == 0));
        if (round % 3 == 0) {
            for (SurfaceHit& h : hits) h.t = std::ldexp(h.t, int(rng.below(40)) - 20);
        }
        shuffle(hits, rng);
        std::vector<PackedSurfaceHit> packed;
        for (const SurfaceHit& h : hits) {
            packed.push_back(pack_surface_hit(h));
            const SurfaceHit back = unpack_surface_hit(packed.back());
            REQUIRE((same_bits(back.t, h.t) && back.value == h.value));
        }
        INFO("round " << round << ", " << hits.size() << " hits");
        for (const HitSort method : {HitSort::adaptive, HitSort::std_sort}) {
            std::vector<SurfaceHit> unpacked = hits;
            const float expected = resolver(unpacked, method);
            CHECK(same_bits(packed_resolver(std::span<const PackedSurfaceHit>(packed), method), expected));
        }
    }
}

TEST_CASE("the three HitSort methods give bit-identical lengths equal to the interval union", "[resolver]") {
    // 4000 particles: lists of 0..160 chords (up to ~320 hits, past the thesis's largest cutoff), half on a
    // grid to force ties, a few particles occluded or over the cutoff.
    Pcg32 rng(5);
    constexpr std::size_t kParticles = 4000;
    HitLists lists;
    std::vector<DepthStatus> status(kParticles, DepthStatus::ok);
    std::vector<double> expected(kParticles);
    std::vector<std::size_t> stretches(kParticles);
    for (std::size_t i = 0; i < kParticles; ++i) {
        const std::vector<Interval> intervals = random_intervals(rng, rng.below(161), i % 2 == 0);
        std::vector<SurfaceHit> hits = hits_of(intervals);
        shuffle(hits, rng);  // any-hit order
        lists.add_particle(hits);
        expected[i] = union_length(intervals);
        stretches[i] = intervals.size();
        if (i % 97 == 3) status[i] = DepthStatus::occluded;
        if (i % 89 == 5) status[i] = DepthStatus::cutoff;
    }

    const std::vector<float> radix = resolve(lists, status, HitSort::adaptive);
    const std::vector<float> std_sort = resolve(lists, status, HitSort::std_sort);
    const std::vector<float> bubble = resolve(lists, status, HitSort::bubble);
    std::vector<float> radix_one_thread;
    tbb::task_arena(1).execute([&] { radix_one_thread = resolve(lists, status, HitSort::adaptive); });

    for (std::size_t i = 0; i < kParticles; ++i) {
        INFO("particle " << i << ", " << lists.of(i).size() << " hits");
        REQUIRE(same_bits(radix[i], std_sort[i]));
        REQUIRE(same_bits(radix[i], bubble[i]));
        REQUIRE(same_bits(radix[i], radix_one_thread[i]));
        if (status[i] != DepthStatus::ok) {
            CHECK(radix[i] == std::numeric_limits<float>::infinity());
            continue;
        }
        // The walk sums exact float differences in double, at most two per chord (each addition rounds by
        // <= 2^-53 relative; eight running sums and three pairwise levels add fewer levels than that), and
        // the caller stores a float (rounding <= half a float ulp, 2^-24 relative).
        const double tolerance =
            expected[i] * (0x1.0p-24 + static_cast<double>(2 * stretches[i] + 4) * DBL_EPSILON);
        CHECK(std::abs(static_cast<double>(radix[i]) - expected[i]) <= tolerance);
    }
}

TEST_CASE("occluded and cutoff particles are fully dark whatever their hits", "[resolver]") {
    HitLists lists;
    lists.add_particle(std::vector<SurfaceHit>{{1.0f, -1}});
    lists.add_particle(std::vector<SurfaceHit>{{2.0f, -1}, {0.5f, +1}, {1.0f, -1}});
    lists.add_particle(std::vector<SurfaceHit>{});
    lists.add_particle(std::vector<SurfaceHit>{{3.0f, -1}});
    const std::vector<DepthStatus> status = {DepthStatus::occluded, DepthStatus::cutoff, DepthStatus::ok,
                                             DepthStatus::ok};
    for (const HitSort method : {HitSort::adaptive, HitSort::std_sort, HitSort::bubble}) {
        const std::vector<float> lengths = resolve(lists, status, method);
        CHECK(lengths[0] == std::numeric_limits<float>::infinity());
        CHECK(lengths[1] == std::numeric_limits<float>::infinity());
        CHECK(lengths[2] == 0.0f);
        CHECK(lengths[3] == 3.0f);
    }
}

TEST_CASE("resolve_optical_path_lengths sorts each ok list in place and checks its spans", "[resolver]") {
    HitLists lists;
    lists.add_particle(std::vector<SurfaceHit>{{2.0f, -1}, {0.5f, +1}, {1.0f, -1}});
    std::vector<float> lengths(1);
    const std::vector<DepthStatus> ok = {DepthStatus::ok};
    resolve_optical_path_lengths(lists, ok, lengths, HitSort::adaptive);
    CHECK(lists.hits[0].t == 0.5f);
    CHECK(lists.hits[1].t == 1.0f);
    CHECK(lists.hits[2].t == 2.0f);

    std::vector<float> too_few;
    CHECK_THROWS_AS(resolve_optical_path_lengths(lists, ok, too_few, HitSort::adaptive), std::invalid_argument);
    CHECK_THROWS_AS(resolve_optical_path_lengths(lists, {}, lengths, HitSort::adaptive), std::invalid_argument);
    lists.hits.pop_back();  // offsets now point past the buffer
    CHECK_THROWS_AS(resolve_optical_path_lengths(lists, ok, lengths, HitSort::adaptive), std::invalid_argument);
}
