#pragma once
// Contract: optical_path_length() is textbook::length_in_smoke (eq. 3.1, textbook/optical_depth.hpp) to within
// 2(n − 1)·2^-53 of the length in double (eight running sums, not one), one float ulp once rounded; every HitSort
// gives the same bits. tests/test_textbook_optical_depth.cpp.
// The hit resolver: thesis 4.3.3 "compute pass". Turns each particle's optical-depth ray hits (collected in
// any order by the any-hit callback, thesis 4.3.2) into the optical path length through smoke toward the
// light (thesis 3.1, eq. 3.1).
#include <smoketrace/core/simd/level.hpp>
#include <smoketrace/smoke/light_ray.hpp>

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

namespace smoketrace {

// One particle surface crossed by an optical-depth ray: +1 entering a particle (front face), -1 leaving
// (back face). t is the distance along the ray from the particle centre, t >= 0, never NaN.
struct SurfaceHit {
    float t = 0.0f;
    std::int32_t value = 0;
};

// A SurfaceHit in 4 bytes, as the optical-depth pass keeps them (18 per ray at 10^6 particles without a
// cutoff: most of the pass's memory): t's bits with the sign bit set for a −1 (leaving a particle). Every
// kept t is a finite float >= the ray's tmin > 0, whose sign bit is free, so unpacking gives the same t
// and value bit for bit. Rotated left by one bit, it is a sort key: t's bits above the leaving flag, so
// that the keys' unsigned order is the order of t.
struct PackedSurfaceHit {
    std::uint32_t bits = 0;
};
inline constexpr std::uint32_t kPackedLeavingBit = 0x80000000u;
// `h`: t > 0 finite, value +1 or −1 (the any-hit shader's).
[[nodiscard]] inline PackedSurfaceHit pack_surface_hit(const SurfaceHit& h) {
    return {std::bit_cast<std::uint32_t>(h.t) | (h.value < 0 ? kPackedLeavingBit : 0u)};
}
[[nodiscard]] inline SurfaceHit unpack_surface_hit(PackedSurfaceHit p) {
    return SurfaceHit{std::bit_cast<float>(p.bits & ~kPackedLeavingBit), (p.bits & kPackedLeavingBit) != 0 ? -1 : +1};
}

// Every particle's hits in one flat buffer: particle i owns hits[offsets[i], offsets[i+1]).
// Variable-length lists: the cutoff is a quality knob, not a memory layout (method.md, thesis 6.1).
struct HitLists {
    std::vector<SurfaceHit> hits;
    std::vector<std::uint32_t> offsets{0};  // size particle_count() + 1, offsets.front() == 0

    [[nodiscard]] std::size_t particle_count() const { return offsets.empty() ? 0 : offsets.size() - 1; }
    [[nodiscard]] std::size_t hit_count() const { return hits.size(); }
    [[nodiscard]] std::span<SurfaceHit> of(std::size_t i) {
        return {hits.data() + offsets[i], hits.data() + offsets[i + 1]};
    }
    [[nodiscard]] std::span<const SurfaceHit> of(std::size_t i) const {
        return {hits.data() + offsets[i], hits.data() + offsets[i + 1]};
    }
    // Appends one particle owning `list` (a copy).
    void add_particle(std::span<const SurfaceHit> list) {
        hits.insert(hits.end(), list.begin(), list.end());
        offsets.push_back(static_cast<std::uint32_t>(hits.size()));
    }
    // No particles; keeps the capacity for the next frame.
    void clear() {
        hits.clear();
        offsets.assign(1, 0);
    }
};

// How resolve_optical_path_lengths() sorts each list by t. All three give bit-identical lengths.
enum class HitSort : std::uint8_t {
    adaptive,  // the fast path, picked by list length: with AVX-512 a sorting network for lists of up to
               // 128 hits (hit_resolver_avx512.hpp); else sort_by_float_key (radix_sort.hpp), a rank sort
               // for short lists and an LSD radix sort for long ones. The cost per hit stays flat as the
               // cutoff grows (method.md, thesis 6.2)
    std_sort,  // std::sort, the baseline
    bubble,    // the thesis's bubble sort, O(k^2), kept to reproduce table B.4
};

// Sorts one particle's hits by t with `method`: ascending t, and for HitSort::adaptive float_sort_key()
// order (-0 before +0). Hits of equal t come in an order that depends on the method, which
// optical_path_length() ignores. `scratch`: at least hits.size() elements for HitSort::adaptive, unused by
// the others.
void sort_hits_by_t(std::span<SurfaceHit> hits, std::span<SurfaceHit> scratch, HitSort method);

// Eq. 3.1 and the walk: the summed length of the stretches of the ray (from t = 0) that are inside smoke,
// given one particle's hits sorted by t. The counter starts at -sum(values) (eq. 3.1: the number of
// particles covering the ray origin); the ray is in smoke while the counter is > 0; gaps between separate
// clouds are not counted. Hits with equal t act together, so their order within a tie does not matter.
// The walk is detail::walk_sorted_hits() (hit_walk.hpp), with AVX-512 eight hits per instruction.
[[nodiscard]] double optical_path_length(std::span<const SurfaceHit> sorted_hits);

namespace detail {
// What HitSort::adaptive's sorting network (hit_resolver_avx512.hpp) does to a list, one comparison at a
// time: sorts it by the 64-bit key float_sort_key(t) · 2^32 + the value's bits, so ascending t, and
// hits of equal t by their values' bits as unsigned. The definition the network is tested against.
void network_sort_hits_scalar(std::span<SurfaceHit> hits);
}  // namespace detail

// One particle's optical path length: its hits sorted by t with `method` (in place), then
// optical_path_length(). The body of resolve_optical_path_lengths(), for hit lists kept elsewhere
// (OpticalDepthPass::resolve). Holds the sorts' working memory; one per thread.
class ListResolver {
public:
    [[nodiscard]] float operator()(std::span<SurfaceHit> hits, HitSort method);
    // The same bits for a list of packed hits, which stays as it is. With HitSort::adaptive and AVX-512 a list
    // the sorting network holds is sorted and walked in registers, straight from the packed hits
    // (hit_resolver_avx512.hpp); other lists are unpacked into this resolver's memory first.
    [[nodiscard]] float operator()(std::span<const PackedSurfaceHit> hits, HitSort method);

    // operator() at kernel level L (core/simd/dispatch.hpp), for a pass that runs at L already: operator()
    // itself chooses the process's level on every call. Instantiated for the levels of the binary only.
    template <simd::Level L>
    [[nodiscard]] float at_level(std::span<SurfaceHit> hits, HitSort method);
    template <simd::Level L>
    [[nodiscard]] float at_level(std::span<const PackedSurfaceHit> hits, HitSort method);

private:
    std::array<SurfaceHit, 256> small_;  // scratch for the usual short lists, no allocation
    std::vector<SurfaceHit> large_;      // grown once for longer ones
    std::vector<SurfaceHit> unpacked_;   // a packed list unpacked; only grows
};

// For each particle with status ok: sorts its hits by t with `method` (in place) and writes its optical
// path length; occluded / cutoff -> kFullyDarkPathLength ("fully dark", thesis 4.3.3). Parallel over
// particles (TBB); deterministic: the same lengths whatever the thread count.
// status and lengths: one entry per particle of `lists` (std::invalid_argument otherwise).
void resolve_optical_path_lengths(HitLists& lists, std::span<const DepthStatus> status, std::span<float> lengths,
                                  HitSort method);

namespace detail {
// The functions above at kernel level L (core/simd/dispatch.hpp): hit_resolver.cpp, compiled once per level,
// instantiates them for its level; the functions above (hit_resolver_dispatch.cpp) run the process's.
template <simd::Level L>
void sort_hits_by_t_at_level(std::span<SurfaceHit> hits, std::span<SurfaceHit> scratch, HitSort method);
template <simd::Level L>
double optical_path_length_at_level(std::span<const SurfaceHit> sorted_hits);
template <simd::Level L>
void resolve_optical_path_lengths_at_level(HitLists& lists, std::span<const DepthStatus> status,
                                           std::span<float> lengths, HitSort method);
}  // namespace detail

}  // namespace smoketrace
