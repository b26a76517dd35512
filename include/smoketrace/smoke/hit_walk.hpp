#pragma once
// Eq. 3.1 and the in-smoke walk (thesis 3.1, 4.3.3), written once: walk_sorted_hits() over a lane type of
// kWalkLanes lanes. ScalarWalkLanes (here) is plain C++; Avx512WalkLanes (hit_resolver_avx512.hpp) runs the
// same steps eight hits per instruction, so both give the same bits, and explain's story (optical_depth_story)
// watches the very walk the resolver runs through a WalkSteps parameter that compiles away for the pass.
#include <smoketrace/smoke/hit_resolver.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>

namespace smoketrace::detail {

// The walk's running sums: gap i between hits i and i + 1 goes into sum i mod kWalkLanes, and the sums are
// added pairwise at the end. A gap between two floats is exact in double (unless their magnitudes differ by
// more than 2^29), so the only rounding is in these additions, far below the float the caller stores.
inline constexpr std::size_t kWalkLanes = 8;

// kWalkLanes lanes in plain C++: the walk where there is no AVX-512, and the definition the AVX-512 lanes
// are tested against (tests/test_hit_resolver.cpp). A Mask has bit i for lane i.
struct ScalarWalkLanes {
    using Ints = std::array<std::int64_t, kWalkLanes>;
    using Doubles = std::array<double, kWalkLanes>;
    using Mask = std::uint32_t;

    static Mask first_lanes(std::ptrdiff_t count) {  // the first min(count, 8) lanes; none for count <= 0
        return count >= std::ptrdiff_t(kWalkLanes) ? 0xFFu : count <= 0 ? 0u : (1u << count) - 1u;
    }
    static Ints splat(std::int64_t x) {
        Ints r;
        r.fill(x);
        return r;
    }
    static Ints add(const Ints& a, const Ints& b) {
        Ints r;
        for (std::size_t i = 0; i < kWalkLanes; ++i) r[i] = a[i] + b[i];
        return r;
    }
    static Ints inclusive_prefix_sum(Ints v) {  // lane i: v_0 + … + v_i
        for (std::size_t i = 1; i < kWalkLanes; ++i) v[i] += v[i - 1];
        return v;
    }
    static Ints broadcast_last(const Ints& v) { return splat(v[kWalkLanes - 1]); }
    static Mask positive(const Ints& v, Mask m) {  // the lanes of m where v > 0
        Mask r = 0;
        for (std::size_t i = 0; i < kWalkLanes; ++i) r |= (m >> i & 1u) != 0 && v[i] > 0 ? 1u << i : 0u;
        return r;
    }
    static Doubles zero() { return Doubles{}; }
    static Doubles with_first(Doubles s, double x) {
        s[0] = x;
        return s;
    }
    static Doubles add_gaps(Doubles sums, Mask m, const Doubles& t, const Doubles& t_next) {
        for (std::size_t i = 0; i < kWalkLanes; ++i)
            if ((m >> i & 1u) != 0) sums[i] += t_next[i] - t[i];
        return sums;
    }
    static std::int64_t sum(const Ints& v) {
        std::int64_t s = 0;
        for (const std::int64_t x : v) s += x;
        return s;
    }
    static double sum(const Doubles& s) {  // the halves, then the quarters, then the two left
        const double q0 = s[0] + s[4], q1 = s[1] + s[5], q2 = s[2] + s[6], q3 = s[3] + s[7];
        return (q0 + q2) + (q1 + q3);
    }
    static Ints ints(const Ints& v) { return v; }
    static Mask bits(Mask m) { return m; }

    // A sorted list in memory, kWalkLanes hits at a time (lanes past the list: value 0, t 0).
    struct SortedHits {
        static constexpr unsigned kMaxBlocks = 0;  // any length
        std::span<const SurfaceHit> hits;
        [[nodiscard]] std::size_t size() const { return hits.size(); }
        [[nodiscard]] double first_t() const { return static_cast<double>(hits[0].t); }
        [[nodiscard]] Ints values(std::size_t b) const {
            Ints r{};
            for (std::size_t i = 0; i < kWalkLanes && b * kWalkLanes + i < hits.size(); ++i)
                r[i] = hits[b * kWalkLanes + i].value;
            return r;
        }
        [[nodiscard]] Doubles t(std::size_t b, std::size_t from = 0) const {  // lane i: hit b·8 + i + from
            Doubles r{};
            for (std::size_t i = 0; i < kWalkLanes && b * kWalkLanes + i + from < hits.size(); ++i)
                r[i] = static_cast<double>(hits[b * kWalkLanes + i + from].t);
            return r;
        }
        [[nodiscard]] Doubles t_next(std::size_t b) const { return t(b, 1); }
    };
};

// What walk_sorted_hits() tells its steps: the counter's start, then for each block of kWalkLanes hits
// starting at hit `first`, the counter after each and which gaps after them are in smoke (bit i: the gap
// from hit first + i to the next). The pass passes NoWalkSteps, and the walk builds nothing for it.
struct NoWalkSteps {
    void start(std::int64_t) {}
    void block(std::size_t, const ScalarWalkLanes::Ints&, std::uint32_t) {}
};

// Runs `body(b)` for each block b < blocks; fully unrolled for a list held in at most MaxBlocks registers,
// so that the registers stay registers.
template <unsigned MaxBlocks, class Body>
[[gnu::always_inline]] inline void for_each_block(std::size_t blocks, Body&& body) {
    if constexpr (MaxBlocks == 0) {
        for (std::size_t b = 0; b < blocks; ++b) body(b);
    } else {
#pragma GCC unroll 16
        for (std::size_t b = 0; b < MaxBlocks; ++b) {
            if (b >= blocks) break;
            body(b);
        }
    }
}

// Eq. 3.1 and the walk: the summed length of the stretches of the ray (from t = 0) inside smoke, given one
// particle's hits sorted by t (`hits`: size(), first_t(), and values(b), t(b), t_next(b) for the block of
// hits b·8 … b·8 + 7, t_next holding each hit's successor; lanes past the list have value 0). The counter
// starts at −Σ values, the number of particles covering the origin, and after hit i it weighs the gap
// (t_i, t_{i+1}): in smoke when > 0. A stretch open at the origin adds the gap (0, t_0). Inside a group of
// equal-t hits the gaps are 0, so whichever order a sort leaves a tie in, only the counter after the whole
// group weighs a nonzero gap: any sort that orders t gives the same bits. After the last hit the counter is 0.
template <class L, class Hits, class Steps = NoWalkSteps>
[[gnu::always_inline]] inline double walk_sorted_hits(const Hits& hits, Steps&& steps = {}) {
    constexpr bool kTold = !std::is_same_v<std::remove_cvref_t<Steps>, NoWalkSteps>;
    const std::size_t n = hits.size();
    if (n == 0) return 0.0;
    const std::size_t blocks = (n + kWalkLanes - 1) / kWalkLanes;
    typename L::Ints total = L::splat(0);
    for_each_block<Hits::kMaxBlocks>(blocks, [&](std::size_t b) { total = L::add(total, hits.values(b)); });
    const std::int64_t counter_start = -L::sum(total);
    if constexpr (kTold) steps.start(counter_start);

    typename L::Doubles sums = L::zero();
    if (counter_start > 0) sums = L::with_first(sums, hits.first_t());  // in smoke from the origin
    typename L::Ints counter = L::splat(counter_start);                 // before the block's first hit
    for_each_block<Hits::kMaxBlocks>(blocks, [&](std::size_t b) {
        const std::ptrdiff_t first = std::ptrdiff_t(b * kWalkLanes);
        const typename L::Ints after = L::add(counter, L::inclusive_prefix_sum(hits.values(b)));
        const typename L::Mask in_smoke = L::positive(after, L::first_lanes(std::ptrdiff_t(n) - first - 1));
        sums = L::add_gaps(sums, in_smoke, hits.t(b), hits.t_next(b));
        if constexpr (kTold) steps.block(std::size_t(first), L::ints(after), L::bits(in_smoke));
        counter = L::broadcast_last(after);
    });
    return L::sum(sums);
}

}  // namespace smoketrace::detail
