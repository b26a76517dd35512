#pragma once
// Contract: each ray's candidates (as a set, bit for bit) and commit are textbook::trace's, as trace()'s are
// (below); tests/test_textbook_trace.cpp holds the optical-depth pass's bundles there.
// trace_bundle(): trace() (trace.hpp) for the rays of a bundle, up to kBundleWidth rays sharing one
// direction (ray_bundle.hpp), traced together. What each ray sees is exactly what trace() would show it:
//
//   results[i] == trace(scene, bundle.ray(i), flags, inclusion_mask, any_hit_i, limits), where
//   any_hit_i(hit) = any_hit(i, hit),
//
// with every DXR rule of trace.hpp, the cutoff and SKIP_CLOSEST_HIT_SHADER applied to each ray on its own
// (a ray that ends its search, by accept-and-end, a first hit or the cutoff, drops out; the others go on).
// The candidates of one ray and their t are those trace() reports, bit for bit; only their order may
// differ (DXR gives none), and candidates of different rays interleave. A ray that commits nothing meets
// them in trace<TlasWalk::all_hits>'s order: lane by lane the walk is that one (bundle_traversal.hpp), which
// lets a caller sum per-candidate values, such as a density kernel's shares, to the same bits either way
// (smoke/kernel_bundle_sums.hpp; tests/test_trace_bundle.cpp holds the order). Per-ray counters: tlas_nodes and
// boxes_tested count the top-level nodes the ray entered and the boxes tested for it, which equal
// trace<TlasWalk::all_hits>'s when nothing is committed; the rest count the ray's own work, as in trace().
//
// Under the shared walk (bundle_traversal.hpp) each instance the walk reaches goes through the rules once
// for the bundle (rules 1-3 depend on the flags and mask, which the rays share) and then through each
// entering ray's RaySearch (ray_search.hpp), the same code trace() runs; a world sphere is tested for all
// entering rays at once (ray_sphere_bundle.hpp) and its roots handed to each ray's search.
#include <smoketrace/accel/bundle_traversal.hpp>
#include <smoketrace/geometry/ray_bundle.hpp>
#include <smoketrace/trace/ray_search.hpp>
#include <smoketrace/geometry/ray_sphere_bundle.hpp>
#include <smoketrace/accel/accel_scene.hpp>
#include <smoketrace/accel/trace_types.hpp>

#include <array>
#include <bit>
#include <cstdint>
#include <type_traits>
#include <utility>

namespace smoketrace {

using BundleResults = std::array<TraceResult, kBundleWidth>;  // [i] for lane i; lanes >= count are default

namespace detail {
template <class AnyHit, std::size_t... I>
std::array<RaySearch<LaneAnyHit<AnyHit>>, kBundleWidth> make_lane_searches(
    const AccelScene& scene, const RayBundle& bundle, std::uint32_t flags,
    std::array<LaneAnyHit<AnyHit>, kBundleWidth>& hits, const TraceLimits& limits, float* tmax,
    std::index_sequence<I...>) {
    return {RaySearch<LaneAnyHit<AnyHit>>(scene, bundle.ray(I), flags, hits[I], limits, tmax[I])...};
}
}  // namespace detail

// any_hit(unsigned lane, const TraceHit&) -> AnyHitDecision, for every candidate of every ray.
template <class AnyHit>
BundleResults trace_bundle(const AccelScene& scene, const RayBundle& bundle, std::uint32_t flags,
                           std::uint8_t inclusion_mask, AnyHit&& any_hit, const TraceLimits& limits = {}) {
    using Callback = std::remove_reference_t<AnyHit>;
    std::array<LaneAnyHit<Callback>, kBundleWidth> lane_hits;
    for (unsigned i = 0; i < kBundleWidth; ++i) lane_hits[i] = {&any_hit, i};
    alignas(64) float tmax[kBundleWidth];  // each lane's, written by its search, read by the walk
    auto searches = detail::make_lane_searches(scene, bundle, flags, lane_hits, limits, tmax,
                                               std::make_index_sequence<kBundleWidth>{});
    unsigned live = bundle.lanes();
    alignas(64) std::uint32_t sphere_tests[kBundleWidth] = {};  // world spheres tested per lane, here

    const InstanceFilter filter(flags, inclusion_mask);
    const Bvh& tlas = scene.tlas();
    // Inlined into the walk: a bundle enters several leaves per ray, and a function call per leaf showed
    // in the optical-depth pass's time.
    auto visit_leaf = [&](std::uint32_t first, std::uint32_t count, unsigned lanes) __attribute__((always_inline)) {
        const unsigned entered = lanes;  // a lane leaves `lanes` when its search ends
        for (std::uint32_t k = first; k < first + count && lanes != 0; ++k) {
            const std::uint32_t index = tlas.prim_indices[k];
            const InstanceRecord& inst = scene.leaf_record(k);
            bool opaque;
            if (!filter.admits(inst, opaque)) continue;  // rules 1-3, once for the bundle
            if (inst.path == InstancePath::world_sphere) {
                BundleSphereCrossings x;
                sphere_crossings_bundle(bundle, lanes, tmax, inst.object_to_world_translation, inst.sphere.offset,
                                        inst.sphere.radius, x);
                count_lanes(sphere_tests, lanes);
                // Each ray's entry before its exit, as trace() reports them; rays are independent.
                for (unsigned m = x.enter; m != 0; m &= m - 1) {
                    const unsigned i = unsigned(std::countr_zero(m));
                    if (searches[i].report_sphere_entry(index, inst, opaque, static_cast<float>(x.t_enter[i])))
                        lanes &= ~(1u << i);
                }
                for (unsigned m = x.exit & lanes; m != 0; m &= m - 1) {
                    const unsigned i = unsigned(std::countr_zero(m));
                    if (searches[i].report_sphere_exit(index, inst, opaque, static_cast<float>(x.t_exit[i])))
                        lanes &= ~(1u << i);
                }
            } else if (inst.path == InstancePath::object_space) {
                // The direction's part of the object-space ray, once for the bundle.
                const auto od = RaySearch<LaneAnyHit<Callback>>::object_direction(scene.detail(index, inst),
                                                                                  glm::dvec3(bundle.direction));
                for (unsigned m = lanes; m != 0; m &= m - 1) {
                    const unsigned i = unsigned(std::countr_zero(m));
                    if (searches[i].visit_object_space(index, inst, opaque, od)) lanes &= ~(1u << i);
                }
            } else {
                for (unsigned m = lanes; m != 0; m &= m - 1) {
                    const unsigned i = unsigned(std::countr_zero(m));
                    if (searches[i].visit(index, inst, opaque)) lanes &= ~(1u << i);
                }
            }
        }
        live &= ~(entered & ~lanes);
    };
    BundleStats stats;
    const BundleBoxTest box_test(bundle);
    traverse_wide_bvh_bundle(scene.wide_tlas(), box_test, tmax, live, inclusion_mask, visit_leaf, stats);

    BundleResults results;
    for (unsigned i = 0; i < bundle.count; ++i) {
        searches[i].count_world_spheres(sphere_tests[i]);
        results[i] = searches[i].finish(TraversalStats{stats.nodes_visited[i], stats.boxes_tested[i], 0});
    }
    return results;
}

}  // namespace smoketrace
