// The hit resolver's public functions (hit_resolver.hpp): each runs its kernel, compiled in hit_resolver.cpp,
// at the process's kernel level (core/simd/dispatch.hpp). The per-list ones choose it on every call (a switch on
// a value set once); the passes, which run at one level already, call the kernels directly.
#include <smoketrace/core/simd/dispatch.hpp>
#include <smoketrace/smoke/hit_resolver.hpp>

namespace smoketrace {

void sort_hits_by_t(std::span<SurfaceHit> hits, std::span<SurfaceHit> scratch, HitSort method) {
    simd::at_active_level([&]<simd::Level L> { detail::sort_hits_by_t_at_level<L>(hits, scratch, method); });
}

double optical_path_length(std::span<const SurfaceHit> sorted_hits) {
    return simd::at_active_level([&]<simd::Level L> { return detail::optical_path_length_at_level<L>(sorted_hits); });
}

void resolve_optical_path_lengths(HitLists& lists, std::span<const DepthStatus> status, std::span<float> lengths,
                                  HitSort method) {
    simd::at_active_level(
        [&]<simd::Level L> { detail::resolve_optical_path_lengths_at_level<L>(lists, status, lengths, method); });
}

float ListResolver::operator()(std::span<SurfaceHit> hits, HitSort method) {
    return simd::at_active_level([&]<simd::Level L> { return at_level<L>(hits, method); });
}

float ListResolver::operator()(std::span<const PackedSurfaceHit> hits, HitSort method) {
    return simd::at_active_level([&]<simd::Level L> { return at_level<L>(hits, method); });
}

}  // namespace smoketrace
