#pragma once
// textbook::trace(): DXR's TraceRay() over the two-level AccelScene, in the plainest form that keeps every
// rule of trace/trace.hpp (1-9, the counters and the cutoff): the binary TLAS walked with one stack, nearer
// child first; each instance entered by taking the ray into its object space and walking its binary BLAS the
// same way. Thesis 2.2 (BVHs, instancing) and 4.3.2 (the any-hit shader); ../shared/docs/method.md.
#include <smoketrace/accel/accel_scene.hpp>
#include <smoketrace/accel/bvh.hpp>
#include <smoketrace/accel/trace_types.hpp>
#include <smoketrace/geometry/aabb.hpp>
#include <smoketrace/geometry/ray.hpp>
#include <smoketrace/geometry/ray_sphere.hpp>
#include <smoketrace/geometry/ray_triangle.hpp>

#include <cstdint>
#include <type_traits>
#include <utility>

namespace smoketrace::textbook {

// Calls leaf(first, count) for every leaf of `bvh` whose box the ray enters before tmax (re-read at every step: a
// commit in a leaf narrows the rest of the walk), nearer child first; leaf returns true to end the walk.
// admit(node) may refuse a node before its box is tested (rule 1). Counts the nodes entered and boxes tested.
template <class Admit, class Leaf>
bool walk_bvh(const Bvh& bvh, const Ray& ray, const float& tmax, Admit&& admit, Leaf&& leaf, std::uint32_t& nodes,
              std::uint32_t& boxes) {
    if (bvh.nodes.empty() || !admit(0u)) return false;
    const BoxRay box_ray(ray);
    struct Entry { std::uint32_t node; float t; };  // t: where the ray enters the node's box
    Entry stack[kMaxBvhDepth + 1];
    int size = 0;
    float t = 0.0f;
    ++boxes;
    if (intersect(bvh.nodes[0].bounds, box_ray, tmax, t)) stack[size++] = {0, t};
    while (size > 0) {
        const Entry e = stack[--size];
        // A box entered beyond a commit made since it was pushed holds nothing the ray can still take.
        if (!(e.t <= tmax * kSlabFarScale)) continue;
        ++nodes;
        const BvhNode& n = bvh.nodes[e.node];
        if (n.is_leaf() && leaf(n.first, n.count)) return true;
        if (n.is_leaf()) continue;
        Entry met[2];
        int count = 0;
        for (std::uint32_t child = n.first; child < n.first + 2; ++child) {
            if (!admit(child)) continue;
            ++boxes;
            if (intersect(bvh.nodes[child].bounds, box_ray, tmax, t)) met[count++] = {child, t};
        }
        if (count == 2 && met[1].t < met[0].t) std::swap(met[0], met[1]);
        while (count > 0) stack[size++] = met[--count];  // the nearer last, so that it is popped first
    }
    return false;
}

// Rules 1-3: whether the ray searches instance `inst` at all, and if so whether its primitives are opaque.
inline bool admits(const Instance& inst, const BottomLevel& blas, std::uint32_t flags, std::uint8_t inclusion_mask,
                   bool& opaque) {
    if ((inst.mask & inclusion_mask) == 0) return false;  // rule 1
    // Rule 2: the geometry's opacity, overridden by the instance's FORCE_OPAQUE, then its FORCE_NON_OPAQUE,
    // then the ray's FORCE_OPAQUE, then the ray's FORCE_NON_OPAQUE.
    opaque = blas.opaque;
    if (inst.flags & instance_flag_force_opaque) opaque = true;
    if (inst.flags & instance_flag_force_non_opaque) opaque = false;
    if (flags & ray_flag_force_opaque) opaque = true;
    if (flags & ray_flag_force_non_opaque) opaque = false;
    return !(opaque ? (flags & ray_flag_cull_opaque) : (flags & ray_flag_cull_non_opaque));  // rule 3
}

// One ray's search: rules 4-8 and the cutoff, for the candidates of the instances that rules 1-3 admit.
template <class AnyHit>
struct Search {
    AnyHit& any_hit;
    std::uint32_t flags;
    std::uint32_t max_any_hit;  // TraceLimits::max_any_hit_invocations (0: no cutoff)
    float tmax;                 // the ray's, lowered by each commit
    TraceResult result;

    // Rules 5-8 and the cutoff for one candidate. Returns true when the search has ended.
    bool report(const TraceHit& candidate, bool opaque) {
        AnyHitDecision decision = AnyHitDecision::accept;  // rule 5: an opaque hit is committed at once
        if (!opaque) {
            // The cutoff: the (K+1)-th non-opaque candidate ends the search without an any-hit call.
            if (max_any_hit != 0 && result.counters.any_hit_invocations >= max_any_hit) {
                result.cut_off = true;
                return true;
            }
            ++result.counters.any_hit_invocations;
            decision = any_hit(candidate);  // rule 6
            if (decision == AnyHitDecision::ignore) return false;
        }
        ++result.counters.hits_accepted;
        result.hit = true;
        if (!(flags & ray_flag_skip_closest_hit_shader)) result.committed = candidate;  // rule 8
        tmax = candidate.t;
        // AcceptHitAndEndSearch(), or rule 7.
        return decision == AnyHitDecision::accept_and_end || (flags & ray_flag_accept_first_hit_and_end_search);
    }

    // Instance `index`, admitted with opacity `opaque`, in its object space: x = L⁻¹·(x − translation), the
    // translation subtracted first in double (a small particle far from the origin keeps its precision), t kept.
    // Rule 9 holds as each primitive lies in one BLAS leaf, each instance in one TLAS leaf. True: the search ended.
    bool visit(std::uint32_t index, const Instance& inst, const BottomLevel& blas, bool opaque, const Ray& world) {
        const glm::dmat3 to_object = inst.object_to_world.inverse().linear;
        const glm::dvec3 o = to_object * (glm::dvec3(world.origin) - inst.object_to_world.translation);
        const glm::dvec3 d = to_object * glm::dvec3(world.direction);
        const Ray ray{glm::vec3(o), world.tmin, glm::vec3(d), world.tmax};  // spheres take o and d unrounded
        const TriangleRay triangle_ray(ray);  // the watertight test's set-up, shared by all the triangles
        // Rule 4: facing culls apply to triangles, not in an instance flagged TRIANGLE_CULL_DISABLE; the facing
        // is the object-space one (a mirroring transform does not flip it).
        const bool cull = !(inst.flags & instance_flag_triangle_cull_disable);
        const bool cull_front = cull && (flags & ray_flag_cull_front_facing_triangles);
        const bool cull_back = cull && (flags & ray_flag_cull_back_facing_triangles);
        const bool front_clockwise = inst.flags & instance_flag_triangle_front_clockwise;
        ++result.counters.instances_entered;
        TraceHit hit{.instance_index = index, .instance_id = inst.user_id, .geometry = blas.kind};
        auto leaf = [&](std::uint32_t first, std::uint32_t count) {
            for (std::uint32_t k = first; k < first + count; ++k) {
                ++result.counters.primitives_tested;
                if (blas.kind == GeometryKind::triangles) {
                    const MeshBlas::Triangle& tri = blas.mesh.leaf_triangles()[k];
                    TriangleHit th;
                    if (!intersect_triangle(triangle_ray, tri.v0, tri.v1, tri.v2, tmax, th)) continue;
                    const bool front = th.front_face != front_clockwise;
                    if (front ? cull_front : cull_back) continue;  // rule 4
                    hit.t = th.t;
                    hit.barycentrics = th.barycentrics;
                    hit.primitive_index = blas.mesh.primitive_id(k);
                    hit.kind = front ? HitKind::front_face : HitKind::back_face;
                    if (report(hit, opaque)) return true;
                    continue;
                }
                // A sphere is crossed twice, entering (front face) and leaving (back face): two reports, each
                // only if it lies in [tmin, tmax] when its turn comes.
                const Sphere& s = blas.spheres.leaf_spheres()[k];
                SphereRoots roots;
                if (!sphere_roots(o, d, glm::dvec3(s.center), double(s.radius), roots)) continue;
                for (int side = 0; side < 2; ++side) {
                    hit.t = static_cast<float>(side == 0 ? roots.t_enter : roots.t_exit);
                    if (!(hit.t >= ray.tmin && hit.t <= tmax)) continue;
                    hit.object_point = glm::vec3(o + double(hit.t) * d);
                    hit.primitive_index = blas.spheres.primitive_id(k);
                    hit.kind = side == 0 ? HitKind::front_face : HitKind::back_face;
                    if (report(hit, opaque)) return true;
                }
            }
            return false;
        };
        const Bvh& bvh = blas.kind == GeometryKind::triangles ? blas.mesh.bvh() : blas.spheres.bvh();
        // A BLAS of one leaf (a particle's sphere, a billboard's quad) is tested without its box: the TLAS
        // leaf's box around the instance has just been entered.
        if (!bvh.empty() && bvh.nodes[0].is_leaf()) {
            ++result.counters.blas_nodes;
            return leaf(bvh.nodes[0].first, bvh.nodes[0].count);
        }
        return walk_bvh(bvh, ray, tmax, [](std::uint32_t) { return true; }, leaf, result.counters.blas_nodes,
                        result.counters.boxes_tested);
    }
};

// Every candidate hit of `ray` goes through any_hit(const TraceHit&) -> AnyHitDecision (ignore, accept or
// accept_and_end) unless it is opaque; candidates arrive nearest-first by box, in no guaranteed order of t.
template <class AnyHit = AcceptAll>
TraceResult trace(const AccelScene& scene, const Ray& ray, std::uint32_t flags, std::uint8_t inclusion_mask,
                  AnyHit&& any_hit = {}, const TraceLimits& limits = {}) {
    Search<std::remove_reference_t<AnyHit>> search{any_hit, flags, limits.max_any_hit_invocations, ray.tmax, {}};
    const Bvh& tlas = scene.tlas();
    // Rule 1 for whole subtrees: each TLAS node keeps the OR of the instance masks below it.
    auto admit = [&](std::uint32_t node) { return (scene.tlas_node_masks()[node] & inclusion_mask) != 0; };
    auto leaf = [&](std::uint32_t first, std::uint32_t count) {
        for (std::uint32_t k = first; k < first + count; ++k) {
            const std::uint32_t index = tlas.prim_indices[k];
            const Instance inst = scene.instance(index);
            const BottomLevel& blas = scene.bottom_level(inst.blas);
            bool opaque = false;
            if (admits(inst, blas, flags, inclusion_mask, opaque) && search.visit(index, inst, blas, opaque, ray))
                return true;
        }
        return false;
    };
    walk_bvh(tlas, ray, search.tmax, admit, leaf, search.result.counters.tlas_nodes,
             search.result.counters.boxes_tested);
    return search.result;
}

}  // namespace smoketrace::textbook
