#pragma once
// trace(): DirectX Raytracing's TraceRay() on the CPU, over a two-level Scene. Every ray of smoketrace
// (optical-depth, view and shadow rays) goes through this one function.
//
// The rules implemented, from the DXR specification (microsoft/DirectX-Specs, d3d/Raytracing.md):
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
// Two kinds of instance skip the object-space ray (InstancePath, scene.hpp): a single sphere under a
// similarity transform (every sphere stand-in) is tested as a sphere in world space, and a one-leaf mesh
// of a few triangles (every billboard, the ground) as triangles kept transformed to world space. The
// hits, their order and the counters are those of the general path; t (and barycentrics) differ by
// rounding only. Scene(InstancePaths::object_space_only) turns both off.
#include <smoketrace/any_hit.hpp>
#include <smoketrace/blas_traversal.hpp>
#include <smoketrace/ray_sphere.hpp>
#include <smoketrace/scene.hpp>
#include <smoketrace/wide_bvh_traversal.hpp>

#include <cstdint>

namespace smoketrace {

// DXR's RAY_FLAG values.
enum RayFlags : std::uint32_t {
    ray_flag_none = 0x00,
    ray_flag_force_opaque = 0x01,
    ray_flag_force_non_opaque = 0x02,
    ray_flag_accept_first_hit_and_end_search = 0x04,
    ray_flag_skip_closest_hit_shader = 0x08,
    ray_flag_cull_back_facing_triangles = 0x10,
    ray_flag_cull_front_facing_triangles = 0x20,
    ray_flag_cull_opaque = 0x40,
    ray_flag_cull_non_opaque = 0x80,
};

// DXR's HIT_KIND_TRIANGLE_FRONT_FACE / BACK_FACE; spheres report entry as front and exit as back.
enum class HitKind : std::uint8_t { front_face = 0xFE, back_face = 0xFF };

// A candidate (seen by any-hit) or the committed hit.
struct TraceHit {
    float t = 0.0f;
    glm::vec2 barycentrics{0.0f};   // triangles: weights of v1 and v2
    glm::vec3 object_point{0.0f};   // spheres: the hit point in object space (on the sphere)
    std::uint32_t instance_index = ~0u;  // InstanceIndex()
    std::uint32_t instance_id = 0;       // InstanceID() (Instance::user_id)
    std::uint32_t primitive_index = ~0u; // PrimitiveIndex()
    HitKind kind = HitKind::front_face;  // HitKind()
    GeometryKind geometry = GeometryKind::triangles;

    [[nodiscard]] bool front_face() const { return kind == HitKind::front_face; }
};

struct TraceCounters {
    std::uint32_t tlas_nodes = 0;          // TLAS nodes visited (4-wide nodes and leaves)
    std::uint32_t blas_nodes = 0;          // BLAS nodes visited, summed over instances
    std::uint32_t boxes_tested = 0;
    std::uint32_t instances_entered = 0;   // instances whose geometry was tested (past rules 1-3)
    std::uint32_t primitives_tested = 0;
    std::uint32_t any_hit_invocations = 0;
    std::uint32_t hits_accepted = 0;       // commits, opaque or by any-hit
};

// How trace() walks the top level, chosen by the call site (trace<TlasWalk::all_hits>(…)): a hint, like
// Embree's coherent / incoherent context flags. The hits and the committed result are the same either
// way; what differs is the order any-hit sees candidates in, the counters and the speed. A template
// argument, not a field of TraceLimits: a call site then holds one traversal loop, with the instance
// visit and the sphere test inlined into it (with both loops behind a run-time choice, the compiler
// inlined neither, and the optical-depth pass lost 6-8 %).
enum class TlasWalk : std::uint8_t {
    // The binary TLAS, strictly near to far: the nearer child first at every node. For rays that stop
    // early or shrink tmax (closest hit, shadow rays, the compositor's layers with early termination).
    nearest_first,
    // The 4-wide TLAS (wide_bvh.hpp), each node's children in the ray's order along the node's axis,
    // leaves before inner children: half the nodes and a third fewer branch mispredictions, at the cost
    // of a looser order. For rays that collect every hit (the optical-depth pass): 18 % faster over
    // icosahedra and 35 % over spheres there, but camera rays over billboards 35 % slower.
    all_hits,
};

struct TraceLimits {
    std::uint32_t max_any_hit_invocations = 0;  // 0 = no cutoff
};

struct TraceResult {
    bool hit = false;      // something was committed
    bool cut_off = false;  // the any-hit cutoff ended the search
    TraceHit committed;    // valid when hit, unless SKIP_CLOSEST_HIT_SHADER was set
    TraceCounters counters;
};

// The any-hit callback for rays that need none: accept every candidate (DXR without an any-hit shader).
struct AcceptAll {
    constexpr AnyHitDecision operator()(const TraceHit&) const { return AnyHitDecision::accept; }
};

template <TlasWalk Walk = TlasWalk::nearest_first, class AnyHit = AcceptAll>
TraceResult trace(const Scene& scene, const Ray& ray, std::uint32_t flags, std::uint8_t inclusion_mask,
                  AnyHit&& any_hit = {}, const TraceLimits& limits = {}) {
    TraceResult result;
    TraceCounters& c = result.counters;
    float tmax = ray.tmax;
    bool ended = false;
    const Bvh& tlas = scene.tlas();
    const BoxRay world_ray(ray);
    const glm::dvec3 world_origin(ray.origin), world_dir(ray.direction);
    // Locals, not reads through `ray` and `limits`: the any-hit callback could alias them for all the
    // compiler knows, which would force a reload after every call.
    const float tmin = ray.tmin;
    const std::uint32_t max_any_hit = limits.max_any_hit_invocations;
    const bool skip_closest = (flags & ray_flag_skip_closest_hit_shader) != 0;
    const bool end_on_first = (flags & ray_flag_accept_first_hit_and_end_search) != 0;
    // Rules 2-3, the ray's part, hoisted out of the instance loop: the instance's opacity
    // (InstanceRecord::opaque) is overridden by the ray's FORCE_OPAQUE, and both by its FORCE_NON_OPAQUE.
    const bool ray_force_opaque = (flags & ray_flag_force_opaque) != 0;
    const bool ray_allows_opaque = (flags & ray_flag_force_non_opaque) == 0;
    const bool cull_opaque = (flags & ray_flag_cull_opaque) != 0;
    const bool cull_non_opaque = (flags & ray_flag_cull_non_opaque) != 0;

    // Rules 5-8 and the cutoff, for a candidate that passed rules 1-4. make_hit() supplies its TraceHit
    // and is called only where the hit is used, so that what nobody reads is never computed: inlined,
    // a world-sphere candidate that the any-hit callback only counts costs no object_point. Returns
    // true to end the search.
    auto report = [&, max_any_hit, skip_closest, end_on_first](bool opaque, auto&& make_hit) {
        auto commit = [&](const TraceHit& cand, AnyHitDecision decision) {
            ++c.hits_accepted;
            result.hit = true;
            if (!skip_closest) result.committed = cand;  // rule 8
            tmax = cand.t;
            if (decision == AnyHitDecision::accept_and_end || end_on_first) ended = true;  // rule 7
        };
        if (opaque) {  // rule 5
            commit(make_hit(), AnyHitDecision::accept);
            return ended;
        }
        // Rule 6, with the cutoff: a candidate beyond the K allowed any-hit calls ends the search
        // without a call, so exactly K candidates are never reported as cut off.
        if (max_any_hit != 0 && c.any_hit_invocations >= max_any_hit) {
            result.cut_off = true;
            ended = true;
            return true;
        }
        ++c.any_hit_invocations;
        const TraceHit& cand = make_hit();
        const AnyHitDecision decision = any_hit(cand);
        if (decision != AnyHitDecision::ignore) commit(cand, decision);
        return ended;
    };

    TraversalStats tlas_stats, blas_stats;
    std::uint32_t world_spheres = 0;  // world-sphere instances tested (each one BLAS node, one primitive)
    std::uint32_t world_leaves = 0;   // world-triangles instances tested (each one BLAS node)
    // The world ray's triangle set-up, shared by every world_triangles instance; made at the first one,
    // since most rays (a light ray rising from a particle) meet none.
    TriangleRay world_tri;
    bool world_tri_ready = false;
    const MeshBlas::Triangle* world_triangles = scene.world_triangles();
    const bool cull_back_facing = (flags & ray_flag_cull_back_facing_triangles) != 0;
    const bool cull_front_facing = (flags & ray_flag_cull_front_facing_triangles) != 0;

    // The general path (InstancePath::object_space): the ray taken into object space and the BLAS run
    // there (rule 4 applies to triangles only). Out of line, so that the instance loop below, the TLAS
    // walk's leaf callback, stays small enough to be inlined into it. What the loop also uses and never
    // changes is captured by value, `report` included, so that none of it escapes through this call
    // and the loop keeps it in registers. Returns true to end the search.
    auto visit_object_space = [&, report, tmin, world_origin, world_dir](std::uint32_t index,
                                                                        const InstanceRecord& inst,
                                                                        bool opaque) __attribute__((noinline)) {
        ++c.instances_entered;
        const BottomLevel& blas = *inst.blas;
        const bool triangles = blas.kind == GeometryKind::triangles;
        const bool facing_cull = triangles && !(inst.flags & instance_flag_triangle_cull_disable);
        const bool cull_back = facing_cull && (flags & ray_flag_cull_back_facing_triangles);
        const bool cull_front = facing_cull && (flags & ray_flag_cull_front_facing_triangles);
        const bool flip_facing = triangles && (inst.flags & instance_flag_triangle_front_clockwise);

        // The object-space ray keeps t: direction transformed without normalising.
        const glm::dvec3 o = inst.world_to_object_linear * (world_origin - inst.object_to_world_translation);
        const glm::dvec3 d = inst.world_to_object_linear * world_dir;
        // Triangles are intersected in float (watertight for the rounded ray: every triangle of the
        // instance sees the same one); spheres take the double ray as it is.
        const Ray obj_ray{glm::vec3(o), tmin, glm::vec3(d), ray.tmax};

        auto on_hit = [&](const BlasHit& h) {
            const bool front = h.front_face != flip_facing;
            if ((cull_back && !front) || (cull_front && front)) return false;  // rule 4
            TraceHit cand;
            cand.t = h.t;
            cand.barycentrics = h.barycentrics;
            if (!triangles) cand.object_point = glm::vec3(o + double(h.t) * d);
            cand.instance_index = index;
            cand.instance_id = inst.user_id;
            cand.primitive_index = h.primitive;
            cand.kind = front ? HitKind::front_face : HitKind::back_face;
            cand.geometry = blas.kind;
            return report(opaque, [&]() -> const TraceHit& { return cand; });
        };
        // A BLAS that is a single leaf (a billboard quad, a particle's unit sphere) needs no
        // traversal: the TLAS has already tested a box around it.
        auto run = [&](const Bvh& bvh, auto&& leaf) {
            if (bvh.nodes[0].is_leaf()) {
                ++blas_stats.nodes_visited;
                leaf(bvh.nodes[0].first, bvh.nodes[0].count);
            } else {
                traverse_bvh(bvh, BoxRay(obj_ray), tmax, leaf, blas_stats);
            }
        };
        if (triangles) {
            const BlasRay obj(obj_ray);
            run(blas.mesh.bvh(), [&](std::uint32_t f, std::uint32_t n) {
                return mesh_leaf_hits(blas.mesh, obj, tmax, f, n, blas_stats, on_hit);
            });
        } else {
            const SphereRay obj(o, d, tmin);
            run(blas.spheres.bvh(), [&](std::uint32_t f, std::uint32_t n) {
                return sphere_leaf_hits(blas.spheres, obj, tmax, f, n, blas_stats, on_hit);
            });
        }
        return ended;
    };

    auto visit_instances = [&](std::uint32_t first, std::uint32_t count) {
        for (std::uint32_t k = first; k < first + count; ++k) {
            const std::uint32_t index = tlas.prim_indices[k];
            const InstanceRecord& inst = scene.record(index);
            if ((inst.mask & inclusion_mask) == 0) continue;  // rule 1
            const bool opaque = (inst.opaque || ray_force_opaque) && ray_allows_opaque;  // rule 2
            if (opaque ? cull_opaque : cull_non_opaque) continue;                        // rule 3
            if (inst.path == InstancePath::world_triangles) {
                // A few triangles kept in world space: the world ray's watertight test on each, in leaf
                // order, with rule 4 on the object-space facing. Counted as the one-leaf BLAS it stands for.
                ++world_leaves;
                const std::uint32_t n = inst.world_triangle_count;
                c.primitives_tested += n;
                const bool cull_enabled = !(inst.flags & instance_flag_triangle_cull_disable);
                const MeshBlas::Triangle* tris = world_triangles + inst.first_world_triangle;
                if (!world_tri_ready) {
                    world_tri = TriangleRay(ray);
                    world_tri_ready = true;
                }
                for (std::uint32_t k = 0; k < n; ++k) {
                    TriangleHit th;
                    if (!intersect_triangle(world_tri, tris[k].v0, tris[k].v1, tris[k].v2, tmax, th)) continue;
                    const bool front = th.front_face != inst.world_facing_flipped;
                    if (cull_enabled && (front ? cull_front_facing : cull_back_facing)) continue;  // rule 4
                    const bool end = report(opaque, [&] {
                        TraceHit h;
                        h.t = th.t;
                        h.barycentrics = th.barycentrics;  // an affine map keeps them
                        h.instance_index = index;
                        h.instance_id = inst.user_id;
                        h.primitive_index = inst.blas->mesh.primitive_id(k);
                        h.kind = front ? HitKind::front_face : HitKind::back_face;
                        h.geometry = GeometryKind::triangles;
                        return h;
                    });
                    if (end) return true;
                }
                continue;
            }
            if (inst.path == InstancePath::object_space) {
                if (visit_object_space(index, inst, opaque)) return true;
                continue;
            }
            // A world sphere: the world ray against the instance's sphere in world space. A similarity
            // transform keeps t, so this is the object-space test of the general path (sphere_leaf_hits
            // on a single leaf) to double rounding, reported and counted the same way. The origin is
            // taken relative to the instance's translation first, as in object space.
            ++world_spheres;
            const glm::dvec3 rel_origin = world_origin - inst.object_to_world_translation;
            SphereRoots roots;
            if (!sphere_roots(rel_origin, world_dir, inst.sphere_offset, inst.sphere_radius, roots)) continue;
            // Entry (front), then exit (back), each if in [tmin, tmax] when it is reported, as in
            // sphere_leaf_hits. A loop, so that `report` has one call site here and is inlined; unrolled.
#pragma GCC unroll 2
            for (int side = 0; side < 2; ++side) {
                const float t = static_cast<float>(side == 0 ? roots.t_enter : roots.t_exit);
                if (!(t >= tmin && t <= tmax)) continue;
                const bool end = report(opaque, [&] {
                    TraceHit h;
                    h.t = t;
                    // In object space: W·(o − T + t·d), the general path's o + t·d.
                    const glm::dvec3 rel_point = rel_origin + double(t) * world_dir;
                    h.object_point = glm::vec3(inst.world_to_object_linear * rel_point);
                    h.instance_index = index;
                    h.instance_id = inst.user_id;
                    h.primitive_index = 0;  // the BLAS's only sphere
                    h.kind = side == 0 ? HitKind::front_face : HitKind::back_face;
                    h.geometry = GeometryKind::spheres;
                    return h;
                });
                if (end) return true;
            }
        }
        return false;
    };
    if constexpr (Walk == TlasWalk::all_hits) {
        traverse_wide_bvh(scene.wide_tlas(), world_ray, tmax, inclusion_mask, visit_instances, tlas_stats);
    } else {
        const std::uint8_t* node_masks = scene.tlas_node_masks().data();
        traverse_bvh(tlas, world_ray, tmax, visit_instances, tlas_stats,
                     [&](std::uint32_t node) { return (node_masks[node] & inclusion_mask) != 0; });
    }

    c.tlas_nodes = tlas_stats.nodes_visited;
    c.blas_nodes = blas_stats.nodes_visited + world_spheres + world_leaves;
    c.boxes_tested = tlas_stats.boxes_tested + blas_stats.boxes_tested;
    c.primitives_tested += blas_stats.primitives_tested + world_spheres;
    c.instances_entered += world_spheres + world_leaves;
    return result;
}

}  // namespace smoketrace
