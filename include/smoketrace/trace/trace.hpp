#pragma once
// Contract: textbook::trace's candidates, commit and counters, bit for bit, under nearest_first on a scene without
// the world-space paths (in a mesh BLAS of several leaves: the same candidates in its own order, its own node
// counts); all_hits: the same candidates before the commit; the world-space paths: t within float rounding.
// tests/test_textbook_trace.cpp.
// trace(): DirectX Raytracing's TraceRay() on the CPU, over a two-level AccelScene. Every ray of smoketrace
// (optical-depth, view and shadow rays) goes through this function or through trace_bundle()
// (trace_bundle.hpp), which traces rays that share a direction together and gives each what this
// function would. Both run the rules below through RaySearch (ray_search.hpp), where they are implemented.
//
// The rules, from the DXR specification (microsoft/DirectX-Specs, d3d/Raytracing.md):
//  1. Instance inclusion: an instance is visible to a ray iff (InstanceMask & InclusionMask) != 0. Each
//     TLAS node stores, per child, the OR of the masks below it, so a subtree no visible instance lives in is never
//     entered.
//  2. Opacity: a primitive is opaque iff its geometry is opaque (BottomLevel::opaque); the instance
//     flags FORCE_OPAQUE / FORCE_NON_OPAQUE override the geometry, and the ray flags FORCE_OPAQUE /
//     FORCE_NON_OPAQUE override both.
//  3. CULL_OPAQUE / CULL_NON_OPAQUE skip primitives whose final opacity is opaque / non-opaque.
//  4. CULL_BACK_FACING_TRIANGLES / CULL_FRONT_FACING_TRIANGLES skip triangle hits of that facing,
//     except in instances flagged TRIANGLE_CULL_DISABLE. They never apply to procedural primitives
//     (spheres). Facing is decided in object space (a mirroring transform does not flip it), with the
//     instance flag TRIANGLE_FRONT_CLOCKWISE reversing it (instance.hpp).
//  5. An opaque hit in [tmin, tmax] is committed at once, with no any-hit call; tmax becomes its t.
//  6. A non-opaque hit in [tmin, tmax] calls any_hit(candidate) → AnyHitDecision. ignore: nothing is
//     committed; accept: the candidate is committed and tmax becomes its t; accept_and_end: committed,
//     and the search ends. Candidates come in no guaranteed order of t, but only ever with t inside
//     [tmin, the current committed tmax].
//  7. ACCEPT_FIRST_HIT_AND_END_SEARCH: the first commit (opaque, or accepted by any-hit) ends the search.
//  8. SKIP_CLOSEST_HIT_SHADER: the caller learns whether something was committed, but gets no hit data
//     (TraceResult::hit is left default).
//  9. NO_DUPLICATE_ANYHIT_INVOCATION is always in force: each primitive is referenced by exactly one
//     BLAS leaf and each instance by exactly one TLAS leaf (no spatial splits), so a primitive is tested
//     once per ray and any-hit is called at most once per reported hit — once per triangle, and for a
//     sphere once for its entry and once for its exit (the two ReportHit()s of an intersection shader).
//     At a shared edge or vertex of a mesh only one triangle reports the hit (ray_triangle.hpp).
// Beyond DXR: per-call counters, and a cutoff (TraceLimits::max_any_hit_invocations = K): any-hit is
// called at most K times; a (K+1)-th non-opaque candidate ends the search, uncalled, and sets
// TraceResult::cut_off. A ray with exactly K candidates is therefore never cut off.
//
// Two kinds of instance skip the object-space ray (InstancePath, accel_scene.hpp): a single sphere under a
// similarity transform (every sphere stand-in) is tested as a sphere in world space, and a one-leaf mesh
// of a few triangles (every billboard, the ground) as triangles kept transformed to world space. The
// hits, their order and the counters are those of the general path; t (and barycentrics) differ by
// rounding only. AccelScene(InstancePaths::object_space_only) turns both off.
#include <smoketrace/accel/bvh_traversal.hpp>
#include <smoketrace/trace/ray_search.hpp>
#include <smoketrace/accel/accel_scene.hpp>
#include <smoketrace/accel/trace_types.hpp>
#include <smoketrace/accel/wide_bvh_traversal.hpp>

#include <cstdint>
#include <type_traits>

namespace smoketrace {

// How trace() walks the top level, chosen by the call site (trace<TlasWalk::all_hits>(…)): a hint, like
// Embree's coherent / incoherent context flags. The hits and the committed result are the same either
// way; what differs is the order any-hit sees candidates in, the counters and the speed. A template
// argument, not a field of TraceLimits: a call site then holds one traversal loop, with the instance
// visit and the sphere test inlined into it; behind a run-time choice of two loops the compiler inlines
// neither.
enum class TlasWalk : std::uint8_t {
    // The binary TLAS, strictly near to far: the nearer child first at every node. For rays that stop
    // early or shrink tmax (closest hit, shadow rays, the compositor's layers with early termination).
    nearest_first,
    // The 4-wide TLAS (wide_bvh.hpp), each node's children in the ray's order along the node's axis,
    // leaves before inner children: half the nodes and fewer mispredicted branches, at the cost of a
    // looser order. For a lone ray that collects every hit, where order does not matter; camera rays,
    // which commit and stop early, lose more to the looser order than they gain (docs/design.md). Rays
    // that share a direction are faster still traced together: trace_bundle.hpp.
    all_hits,
};

template <TlasWalk Walk = TlasWalk::nearest_first, class AnyHit = AcceptAll>
TraceResult trace(const AccelScene& scene, const Ray& ray, std::uint32_t flags, std::uint8_t inclusion_mask,
                  AnyHit&& any_hit = {}, const TraceLimits& limits = {}) {
    float tmax;  // the search's, read by the walk at every step
    RaySearch<std::remove_reference_t<AnyHit>> search(scene, ray, flags, any_hit, limits, tmax);
    const InstanceFilter filter(flags, inclusion_mask);
    const Bvh& tlas = scene.tlas();
    auto visit_instances = [&](std::uint32_t first, std::uint32_t count) {
        for (std::uint32_t k = first; k < first + count; ++k) {
            const std::uint32_t index = tlas.prim_indices[k];
            const InstanceRecord& inst = scene.leaf_record(k);
            bool opaque;
            if (!filter.admits(inst, opaque)) continue;  // rules 1-3
            if (search.visit(index, inst, opaque)) return true;
        }
        return false;
    };
    TraversalStats tlas_stats;
    const BoxRay world_ray(ray);
    if constexpr (Walk == TlasWalk::all_hits) {
        traverse_wide_bvh(scene.wide_tlas(), world_ray, tmax, inclusion_mask, visit_instances, tlas_stats);
    } else {
        const std::uint8_t* node_masks = scene.tlas_node_masks().data();
        traverse_bvh(tlas, world_ray, tmax, visit_instances, tlas_stats,
                     [&](std::uint32_t node) { return (node_masks[node] & inclusion_mask) != 0; });
    }
    return search.finish(tlas_stats);
}

}  // namespace smoketrace
