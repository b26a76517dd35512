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

#include <glm/vec3.hpp>

#include <cstdint>
#include <type_traits>
#include <utility>

namespace smoketrace::textbook {

// Calls leaf(first, count) for every leaf of `bvh` whose box the ray enters before tmax, the nearer child
// first. `tmax` is re-read at every step: a commit made in a leaf narrows the rest of the walk. admit(node)
// may refuse a node before its box is tested (the TLAS's instance masks, rule 1). leaf returns true to end
// the walk. Counts the nodes entered and the boxes tested.
template <class Admit, class Leaf>
bool walk_bvh(const Bvh& bvh, const Ray& ray, const float& tmax, Admit&& admit, Leaf&& leaf, std::uint32_t& nodes,
              std::uint32_t& boxes) {
    if (bvh.nodes.empty() || !admit(0u)) return false;
    const BoxRay box_ray(ray);
    struct Entry {
        std::uint32_t node;
        float t;  // where the ray enters the node's box
    };
    Entry stack[kMaxBvhDepth + 1];
    int size = 0;
    float t = 0.0f;
    ++boxes;
    if (intersect(bvh.nodes[0].bounds, box_ray, tmax, t)) stack[size++] = {0, t};
    while (size > 0) {
        const Entry e = stack[--size];
        // A box entered beyond the nearest commit since it was pushed holds no hit the ray can still take
        // (the far widening of the slab test, aabb.hpp, applies here too).
        if (!(e.t <= tmax * kSlabFarScale)) continue;
        ++nodes;
        const BvhNode& n = bvh.nodes[e.node];
        if (n.is_leaf()) {
            if (leaf(n.first, n.count)) return true;
            continue;
        }
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
bool admits(const Instance& inst, const BottomLevel& blas, std::uint32_t flags, std::uint8_t inclusion_mask,
            bool& opaque);

// An instance's view of the ray: the ray in object space (t is kept: the direction is not normalised) and what
// rule 4 needs to know of the instance.
struct ObjectRay {
    glm::dvec3 origin, direction;  // in double: what the sphere test takes
    Ray ray;                       // rounded to float: what the box and the triangle tests take
    TriangleRay triangle_ray;      // the watertight test's set-up for `ray`, shared by all its triangles
    bool cull_back = false, cull_front = false;  // rule 4, for this instance's triangles
    bool front_clockwise = false;                // TRIANGLE_FRONT_CLOCKWISE
};
ObjectRay object_ray(const Instance& inst, const BottomLevel& blas, const Ray& world_ray, std::uint32_t flags);

// The state of one ray's search: rules 5-8 and the cutoff, applied to every candidate that passed rules 1-4.
template <class AnyHit>
struct Search {
    AnyHit& any_hit;
    std::uint32_t flags;
    std::uint32_t max_any_hit;  // TraceLimits::max_any_hit_invocations (0: no cutoff)
    float tmax;                 // the ray's, lowered by each commit
    bool ended = false;
    TraceResult result;

    Search(AnyHit& callback, std::uint32_t ray_flags, const Ray& ray, const TraceLimits& limits)
        : any_hit(callback), flags(ray_flags), max_any_hit(limits.max_any_hit_invocations), tmax(ray.tmax) {}

    // Returns true when the search has ended.
    bool report(const TraceHit& candidate, bool opaque) {
        AnyHitDecision decision = AnyHitDecision::accept;  // rule 5: an opaque hit is committed at once
        if (!opaque) {
            // The cutoff: the (K+1)-th non-opaque candidate ends the search without an any-hit call.
            if (max_any_hit != 0 && result.counters.any_hit_invocations >= max_any_hit) {
                result.cut_off = true;
                return ended = true;
            }
            ++result.counters.any_hit_invocations;
            decision = any_hit(candidate);  // rule 6
            if (decision == AnyHitDecision::ignore) return false;
        }
        ++result.counters.hits_accepted;
        result.hit = true;
        if (!(flags & ray_flag_skip_closest_hit_shader)) result.committed = candidate;  // rule 8
        tmax = candidate.t;
        ended = decision == AnyHitDecision::accept_and_end || (flags & ray_flag_accept_first_hit_and_end_search) != 0;
        return ended;  // rule 7 (and AcceptHitAndEndSearch)
    }

    // Instance `index`, admitted with final opacity `opaque`: its BLAS walked in object space. Rule 9 holds by
    // construction: each primitive lies in one BLAS leaf, and each instance in one TLAS leaf.
    bool visit(std::uint32_t index, const Instance& inst, const BottomLevel& blas, bool opaque, const Ray& world_ray) {
        const ObjectRay o = object_ray(inst, blas, world_ray, flags);
        ++result.counters.instances_entered;
        TraceHit hit;
        hit.instance_index = index;
        hit.instance_id = inst.user_id;
        hit.geometry = blas.kind;
        auto leaf = [&](std::uint32_t first, std::uint32_t count) {
            for (std::uint32_t k = first; k < first + count; ++k) {
                ++result.counters.primitives_tested;
                if (blas.kind == GeometryKind::triangles) {
                    const MeshBlas::Triangle& tri = blas.mesh.leaf_triangles()[k];
                    TriangleHit th;
                    if (!intersect_triangle(o.triangle_ray, tri.v0, tri.v1, tri.v2, tmax, th)) continue;
                    const bool front = th.front_face != o.front_clockwise;
                    if (front ? o.cull_front : o.cull_back) continue;  // rule 4
                    hit.t = th.t;
                    hit.barycentrics = th.barycentrics;
                    hit.primitive_index = blas.mesh.primitive_id(k);
                    hit.kind = front ? HitKind::front_face : HitKind::back_face;
                    if (report(hit, opaque)) return true;
                } else {
                    // A sphere is crossed twice, entering (front face) and leaving (back face): two reports,
                    // each only if it lies in [tmin, tmax] when its turn comes.
                    const Sphere& s = blas.spheres.leaf_spheres()[k];
                    SphereRoots roots;
                    if (!sphere_roots(o.origin, o.direction, glm::dvec3(s.center), double(s.radius), roots)) continue;
                    for (int side = 0; side < 2; ++side) {
                        const float t_hit = static_cast<float>(side == 0 ? roots.t_enter : roots.t_exit);
                        if (!(t_hit >= o.ray.tmin && t_hit <= tmax)) continue;
                        hit.t = t_hit;
                        hit.object_point = glm::vec3(o.origin + double(t_hit) * o.direction);
                        hit.primitive_index = blas.spheres.primitive_id(k);
                        hit.kind = side == 0 ? HitKind::front_face : HitKind::back_face;
                        if (report(hit, opaque)) return true;
                    }
                }
            }
            return false;
        };
        const Bvh& bvh = blas.kind == GeometryKind::triangles ? blas.mesh.bvh() : blas.spheres.bvh();
        // A BLAS of one leaf (a particle's sphere, a billboard's quad) is tested without its box: the TLAS
        // leaf's box around the instance has just been entered.
        if (bvh.nodes[0].is_leaf()) {
            ++result.counters.blas_nodes;
            return leaf(bvh.nodes[0].first, bvh.nodes[0].count);
        }
        return walk_bvh(bvh, o.ray, tmax, [](std::uint32_t) { return true; }, leaf, result.counters.blas_nodes,
                        result.counters.boxes_tested);
    }
};

// Every candidate hit of `ray` goes through any_hit(const TraceHit&) -> AnyHitDecision (ignore, accept or
// accept_and_end) unless it is opaque; candidates arrive nearest-first by box, in no guaranteed order of t.
template <class AnyHit = AcceptAll>
TraceResult trace(const AccelScene& scene, const Ray& ray, std::uint32_t flags, std::uint8_t inclusion_mask,
                  AnyHit&& any_hit = {}, const TraceLimits& limits = {}) {
    Search<std::remove_reference_t<AnyHit>> search(any_hit, flags, ray, limits);
    const Bvh& tlas = scene.tlas();
    // Rule 1 for whole subtrees: each TLAS node keeps the OR of the instance masks below it.
    auto admit = [&](std::uint32_t node) { return (scene.tlas_node_masks()[node] & inclusion_mask) != 0; };
    auto leaf = [&](std::uint32_t first, std::uint32_t count) {
        for (std::uint32_t k = first; k < first + count; ++k) {
            const std::uint32_t index = tlas.prim_indices[k];
            const Instance inst = scene.instance(index);
            const BottomLevel& blas = scene.bottom_level(inst.blas);
            bool opaque = false;
            if (!admits(inst, blas, flags, inclusion_mask, opaque)) continue;
            if (search.visit(index, inst, blas, opaque, ray)) return true;
        }
        return false;
    };
    walk_bvh(tlas, ray, search.tmax, admit, leaf, search.result.counters.tlas_nodes,
             search.result.counters.boxes_tested);
    return search.result;
}

}  // namespace smoketrace::textbook
