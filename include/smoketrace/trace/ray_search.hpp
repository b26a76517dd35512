#pragma once
// One ray's search through a two-level scene: the state a top-level walk carries for the ray, and what
// happens at each instance the walk reaches (trace.hpp's rules 1-8 and the cutoff). trace() runs one
// RaySearch under its TLAS walk; trace_bundle() runs one per ray under a walk its rays share. Either way
// a ray meets the same candidates and commits the same hit: the rules live here, once.
#include <smoketrace/accel/any_hit.hpp>
#include <smoketrace/trace/blas_traversal.hpp>
#include <smoketrace/geometry/ray_sphere.hpp>
#include <smoketrace/accel/accel_scene.hpp>
#include <smoketrace/accel/trace_types.hpp>

#include <cstdint>
#include <type_traits>

namespace smoketrace {

// One ray's view of a callback shared by many rays (trace_bundle(), trace_tile(): any_hit(lane, hit)): what
// that ray's RaySearch calls.
template <class AnyHit>
struct LaneAnyHit {
    AnyHit* any_hit;
    unsigned lane;
    AnyHitDecision operator()(const TraceHit& h) const { return (*any_hit)(lane, h); }
};

// Rules 1-3: whether an instance takes part in a ray's search at all, and whether its primitives are
// opaque. They depend on the instance and on the ray's flags and inclusion mask only, so rays that share
// those (a bundle) share the decision.
class InstanceFilter {
public:
    InstanceFilter(std::uint32_t flags, std::uint8_t inclusion_mask)
        : inclusion_mask_(inclusion_mask),
          ray_force_opaque_((flags & ray_flag_force_opaque) != 0),
          ray_allows_opaque_((flags & ray_flag_force_non_opaque) == 0),
          cull_opaque_((flags & ray_flag_cull_opaque) != 0),
          cull_non_opaque_((flags & ray_flag_cull_non_opaque) != 0) {}

    // True when the instance is searched; `opaque` then holds its final opacity.
    [[gnu::always_inline]] bool admits(const InstanceRecord& inst, bool& opaque) const {
        if ((inst.mask & inclusion_mask_) == 0) return false;  // rule 1
        // Rule 2: the instance's opacity (InstanceRecord::opaque, the geometry's after the instance
        // flags) is overridden by the ray's FORCE_OPAQUE, and both by its FORCE_NON_OPAQUE.
        opaque = (inst.opaque || ray_force_opaque_) && ray_allows_opaque_;
        return !(opaque ? cull_opaque_ : cull_non_opaque_);  // rule 3
    }

    [[nodiscard]] std::uint8_t inclusion_mask() const { return inclusion_mask_; }

private:
    std::uint8_t inclusion_mask_;
    bool ray_force_opaque_, ray_allows_opaque_, cull_opaque_, cull_non_opaque_;
};

// The search state of one ray. `tmax` is the caller's: the top-level walk reads it at every step, so a
// commit here narrows the walk at once. AnyHit: any_hit(const TraceHit&) -> AnyHitDecision.
template <class AnyHit>
class RaySearch {
public:
    RaySearch(const AccelScene& scene, const Ray& ray, std::uint32_t flags, AnyHit& any_hit, const TraceLimits& limits,
              float& tmax)
        : scene_(scene), any_hit_(any_hit), tmax_(tmax), max_any_hit_(limits.max_any_hit_invocations),
          skip_closest_((flags & ray_flag_skip_closest_hit_shader) != 0),
          end_on_first_((flags & ray_flag_accept_first_hit_and_end_search) != 0),
          cull_back_facing_((flags & ray_flag_cull_back_facing_triangles) != 0),
          cull_front_facing_((flags & ray_flag_cull_front_facing_triangles) != 0), world_origin_(ray.origin),
          world_dir_(ray.direction), ray_(ray) {
        tmax_ = ray.tmax;
    }
    RaySearch(const RaySearch&) = delete;
    RaySearch& operator=(const RaySearch&) = delete;

    [[nodiscard]] bool ended() const { return ended_; }

    // The geometry of an instance that rules 1-3 admitted (`opaque`: its final opacity), by the path
    // AccelScene chose for it. Returns true when the search has ended.
    [[gnu::always_inline]] bool visit(std::uint32_t index, const InstanceRecord& inst, bool opaque) {
        switch (inst.path) {
            case InstancePath::world_triangles:
                return visit_world_triangles(index, inst, opaque);
            case InstancePath::object_space:
                return visit_object_space(index, inst, opaque);
            case InstancePath::world_sphere:
                break;
        }
        // A world sphere: the world ray against the instance's sphere in world space. A similarity
        // transform keeps t, so this is the object-space test of the general path (sphere_leaf_hits on a
        // single leaf) to double rounding, reported and counted the same way. The origin is taken
        // relative to the instance's translation first, as in object space.
        ++world_spheres_;
        SphereRoots roots;
        if (!sphere_roots(world_origin_ - inst.object_to_world_translation, world_dir_, inst.sphere.offset,
                          inst.sphere.radius, roots))
            return false;
        return report_sphere_crossings(index, inst, opaque, static_cast<float>(roots.t_enter),
                                       static_cast<float>(roots.t_exit));
    }

    // The crossings of a world sphere's surface by this ray, its entry (front face) at t_enter and then its
    // exit (back face) at t_exit, each reported if it lies in [tmin, tmax] when its turn comes, as in
    // sphere_leaf_hits. Returns true when the search has ended.
    [[gnu::always_inline]] bool report_sphere_crossings(std::uint32_t index, const InstanceRecord& inst, bool opaque,
                                                        float t_enter, float t_exit) {
        // A loop, so that the report has one call site here and is inlined once; unrolled.
#pragma GCC unroll 2
        for (unsigned side = 0; side < 2; ++side) {
            const float t = side == 0 ? t_enter : t_exit;
            if (!(t >= ray_.tmin && t <= tmax_)) continue;
            if (report_sphere_side(index, inst, opaque, t, side)) return true;
        }
        return false;
    }

    // The same for a bundle, which tests a sphere for all its rays at once (ray_sphere_bundle.hpp) and hands
    // each ray the entries found in [tmin, tmax] first, then the exits: one crossing, known to be in range
    // when the sphere was tested. An exit is checked again against tmax, which its entry may have lowered
    // by a commit (the ray's only change between the test and the exit). Returns true when the search has
    // ended. Two passes over the lanes, rather than both sides lane by lane, leave no branch on which
    // sides a lane crosses: a branch on that data mispredicts more than any in the pass but the walk's.
    [[gnu::always_inline]] bool report_sphere_entry(std::uint32_t index, const InstanceRecord& inst, bool opaque,
                                                    float t_enter) {
        return report_sphere_side(index, inst, opaque, t_enter, 0);
    }
    [[gnu::always_inline]] bool report_sphere_exit(std::uint32_t index, const InstanceRecord& inst, bool opaque,
                                                   float t_exit) {
        return t_exit <= tmax_ && report_sphere_side(index, inst, opaque, t_exit, 1);
    }

    // World spheres tested for this ray outside visit(), by a bundle: counted as visit() counts its own.
    void count_world_spheres(std::uint32_t n) { world_spheres_ += n; }

    // The result, with the walk's counters (`tlas`: the top-level nodes and boxes it spent on this ray).
    [[nodiscard]] TraceResult finish(const TraversalStats& tlas) {
        TraceCounters& c = result_.counters;
        c.tlas_nodes = tlas.nodes_visited;
        c.blas_nodes = blas_stats_.nodes_visited + world_spheres_ + world_leaves_;
        c.boxes_tested = tlas.boxes_tested + blas_stats_.boxes_tested;
        c.primitives_tested += blas_stats_.primitives_tested + world_spheres_;
        c.instances_entered += world_spheres_ + world_leaves_;
        return result_;
    }

private:
    // A world sphere's entry (side 0, front face) or exit (side 1, back face) at t, in range: rules 5-8.
    [[gnu::always_inline]] bool report_sphere_side(std::uint32_t index, const InstanceRecord& inst, bool opaque, float t,
                                                   unsigned side) {
        // Inlined at both of report()'s calls: left out of line (it is large, for the commit path), it
        // makes the compiler build the closure, pointers to t, index and side, in memory for every
        // crossing, in the optical-depth pass's innermost loop.
        return report(opaque, [&]() __attribute__((always_inline)) {
            TraceHit h;
            h.t = t;
            // In object space: W·(o − T + t·d), the general path's o + t·d.
            const glm::dvec3 rel_point = (world_origin_ - inst.object_to_world_translation) + double(t) * world_dir_;
            h.object_point = glm::vec3(scene_.detail(index, inst).world_to_object_linear * rel_point);
            h.instance_index = index;
            h.instance_id = inst.user_id;
            h.primitive_index = 0;  // the BLAS's only sphere
            h.kind = side == 0 ? HitKind::front_face : HitKind::back_face;
            h.geometry = GeometryKind::spheres;
            return h;
        });
    }

    // Rules 5-8 and the cutoff, for a candidate that passed rules 1-4. make_hit() supplies its TraceHit
    // and is called only where the hit is used, so that what nobody reads is never computed: inlined,
    // a world-sphere candidate that the any-hit callback only counts costs no object_point. Returns
    // true to end the search.
    template <class MakeHit>
    [[gnu::always_inline]] bool report(bool opaque, MakeHit&& make_hit) {
        TraceCounters& c = result_.counters;
        auto commit = [&](const TraceHit& cand, AnyHitDecision decision) {
            ++c.hits_accepted;
            result_.hit = true;
            if (!skip_closest_) result_.committed = cand;  // rule 8
            tmax_ = cand.t;
            if (decision == AnyHitDecision::accept_and_end || end_on_first_) ended_ = true;  // rule 7
        };
        if (opaque) {  // rule 5
            commit(make_hit(), AnyHitDecision::accept);
            return ended_;
        }
        // Rule 6, with the cutoff: a candidate beyond the K allowed any-hit calls ends the search
        // without a call, so exactly K candidates are never reported as cut off.
        if (max_any_hit_ != 0 && c.any_hit_invocations >= max_any_hit_) {
            result_.cut_off = true;
            ended_ = true;
            return true;
        }
        ++c.any_hit_invocations;
        const TraceHit& cand = make_hit();
        const AnyHitDecision decision = any_hit_(cand);
        if (decision != AnyHitDecision::ignore) commit(cand, decision);
        return ended_;
    }

    // A few triangles kept in world space: the world ray's watertight test on each, in leaf order, with
    // rule 4 on the object-space facing. Counted as the one-leaf BLAS it stands for.
    [[gnu::always_inline]] bool visit_world_triangles(std::uint32_t index, const InstanceRecord& inst, bool opaque) {
        count_world_triangles(inst);
        const MeshBlas::Triangle* tris = scene_.world_triangles() + inst.other.first_world_triangle;
        // The world ray's triangle set-up, shared by every world_triangles instance; made at the first
        // one, since most rays (a light ray rising from a particle) meet none.
        if (!world_tri_ready_) {
            world_tri_ = TriangleRay(ray_);
            world_tri_ready_ = true;
        }
        for (std::uint32_t k = 0; k < inst.other.world_triangle_count; ++k) {
            TriangleHit th;
            if (!intersect_triangle(world_tri_, tris[k].v0, tris[k].v1, tris[k].v2, tmax_, th)) continue;
            if (report_world_triangle(index, inst, opaque, k, th)) return true;
        }
        return false;
    }

    [[gnu::always_inline]] void count_world_triangles(const InstanceRecord& inst) {
        ++world_leaves_;
        result_.counters.primitives_tested += inst.other.world_triangle_count;
    }

public:

    // Triangle k of a world_triangles instance, met by this ray at `th` (t within [tmin, tmax]): rule 4 on the
    // object-space facing, then rules 5-8. Returns true when the search has ended.
    [[gnu::always_inline]] bool report_world_triangle(std::uint32_t index, const InstanceRecord& inst, bool opaque,
                                                      std::uint32_t k, const TriangleHit& th) {
        const bool front = th.front_face != inst.other.world_facing_flipped;
        const bool cull_enabled = !(inst.flags & instance_flag_triangle_cull_disable);
        if (cull_enabled && (front ? cull_front_facing_ : cull_back_facing_)) return false;  // rule 4
        return report(opaque, [&] {
            TraceHit h;
            h.t = th.t;
            h.barycentrics = th.barycentrics;  // an affine map keeps them
            h.instance_index = index;
            h.instance_id = inst.user_id;
            h.primitive_index = inst.other.blas->mesh.primitive_id(k);
            h.kind = front ? HitKind::front_face : HitKind::back_face;
            h.geometry = GeometryKind::triangles;
            return h;
        });
    }

    // The search's current tmax (a commit lowers it).
    [[nodiscard]] float tmax() const { return tmax_; }

private:
    // The general path (InstancePath::object_space): the ray taken into object space and the BLAS run
    // there (rule 4 applies to triangles only). Out of line, so that the instance visit, the TLAS walk's
    // leaf callback, stays small enough to be inlined into the walk.
    __attribute__((noinline)) bool visit_object_space(std::uint32_t index, const InstanceRecord& inst, bool opaque) {
        return visit_in_object_space(index, inst, opaque, object_direction(scene_.detail(index, inst), world_dir_));
    }

public:
    // The part of an instance's object-space ray that depends on the ray's direction alone: the same for
    // every ray of a bundle, which makes it once per instance (trace_bundle.hpp). The object-space ray
    // keeps t: the direction is transformed without normalising.
    struct ObjectDirection {
        InstanceDetail detail;  // the instance's (AccelScene::detail())
        glm::dvec3 d;
        TriangleRay tri;  // triangles: the watertight test's set-up for glm::vec3(d) (origin and tmin: the ray's)
    };
    [[nodiscard]] static ObjectDirection object_direction(const InstanceDetail& detail,
                                                          const glm::dvec3& world_dir) {
        ObjectDirection od{detail, detail.world_to_object_linear * world_dir, TriangleRay{}};
        if (detail.blas->kind == GeometryKind::triangles)
            od.tri = TriangleRay(Ray{glm::vec3(0.0f), 0.0f, glm::vec3(od.d), 0.0f});
        return od;
    }

    // The general path with the direction's part made by the caller (object_direction() of this ray's
    // direction). Returns true when the search has ended.
    __attribute__((noinline)) bool visit_object_space(std::uint32_t index, const InstanceRecord& inst, bool opaque,
                                                      const ObjectDirection& od) {
        return visit_in_object_space(index, inst, opaque, od);
    }

private:
    [[gnu::always_inline]] bool visit_in_object_space(std::uint32_t index, const InstanceRecord& inst, bool opaque,
                                                      const ObjectDirection& od) {
        ++result_.counters.instances_entered;
        const BottomLevel& blas = *od.detail.blas;
        const bool triangles = blas.kind == GeometryKind::triangles;
        const bool facing_cull = triangles && !(inst.flags & instance_flag_triangle_cull_disable);
        const bool cull_back = facing_cull && cull_back_facing_;
        const bool cull_front = facing_cull && cull_front_facing_;
        const bool flip_facing = triangles && (inst.flags & instance_flag_triangle_front_clockwise);

        const glm::dvec3 o = od.detail.world_to_object_linear * (world_origin_ - inst.object_to_world_translation);
        const glm::dvec3& d = od.d;
        // Triangles are intersected in float (watertight for the rounded ray: every triangle of the
        // instance sees the same one); spheres take the double ray as it is.
        const Ray obj_ray{glm::vec3(o), ray_.tmin, glm::vec3(d), ray_.tmax};

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
        // traversal: the TLAS has already tested a box around it. Otherwise a mesh's wide tree is walked
        // nearest first (blas_wide_traversal.hpp), a sphere set's binary tree.
        auto run = [&](const Bvh& bvh, auto is_mesh, auto&& leaf) {
            if (bvh.nodes[0].is_leaf()) {
                ++blas_stats_.nodes_visited;
                // A mesh leaf is named by its first triangle block, a sphere leaf by its range.
                if constexpr (decltype(is_mesh)::value) leaf(blas.mesh.leaf_blocks()[0], bvh.nodes[0].count);
                else leaf(bvh.nodes[0].first, bvh.nodes[0].count);
            } else if constexpr (decltype(is_mesh)::value) {
                traverse_blas_wide<BlasWalkOrder::nearest_first>(blas.mesh.wide(), BoxRay(obj_ray), tmax_, leaf,
                                                                 blas_stats_, MeshLeafPrefetch{blas.mesh});
            } else {
                traverse_bvh(bvh, BoxRay(obj_ray), tmax_, leaf, blas_stats_);
            }
        };
        if (triangles) {
            TriangleRay tri = od.tri;  // = TriangleRay(obj_ray): the set-up depends on the direction only
            tri.origin = obj_ray.origin;
            tri.tmin = obj_ray.tmin;
            const BlasRay obj(obj_ray, tri);
            run(blas.mesh.bvh(), std::true_type{}, [&](std::uint32_t f, std::uint32_t n) {
                return mesh_leaf_hits(blas.mesh, obj, tmax_, f, n, blas_stats_, on_hit);
            });
        } else {
            const SphereRay obj(o, d, ray_.tmin);
            run(blas.spheres.bvh(), std::false_type{}, [&](std::uint32_t f, std::uint32_t n) {
                return sphere_leaf_hits(blas.spheres, obj, tmax_, f, n, blas_stats_, on_hit);
            });
        }
        return ended_;
    }

    // What every report reads comes first, with the counters, so that a report touches the object's first
    // two cache lines: a tile keeps 256 searches, more than L1 holds.
    const AccelScene& scene_;
    AnyHit& any_hit_;
    float& tmax_;
    const std::uint32_t max_any_hit_;
    bool ended_ = false;
    const bool skip_closest_, end_on_first_, cull_back_facing_, cull_front_facing_;
    bool world_tri_ready_ = false;
    TraceResult result_;
    TraversalStats blas_stats_;
    std::uint32_t world_spheres_ = 0;  // world-sphere instances tested (each one BLAS node, one primitive)
    std::uint32_t world_leaves_ = 0;   // world-triangles instances tested (each one BLAS node)
    const glm::dvec3 world_origin_, world_dir_;
    const Ray ray_;
    TriangleRay world_tri_;
};

}  // namespace smoketrace
