#pragma once
// Contract: the candidates and the closest hit of textbook::trace for one instance of the BLAS under the
// identity, bit for bit (its leaf tests are these kernels); tests/test_textbook_trace.cpp.
// Ray queries against one bottom-level structure (a MeshBlas or a SphereBlas), in its own space:
// closest hit, and any-hit traversal with a callback that is a template parameter (inlined at the
// call site: no std::function, no virtual call, no allocation).
//
// The kernels mesh_leaf_hits / sphere_leaf_hits are also what trace() runs inside each instance.
#include <smoketrace/accel/any_hit.hpp>
#include <smoketrace/accel/blas_wide_traversal.hpp>
#include <smoketrace/accel/bvh_traversal.hpp>
#include <smoketrace/geometry/ray_sphere.hpp>
#include <smoketrace/geometry/ray_triangle.hpp>
#include <smoketrace/accel/sphere_set.hpp>
#include <smoketrace/accel/triangle_mesh.hpp>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <type_traits>

namespace smoketrace {

// A candidate or committed hit in a BLAS.
struct BlasHit {
    float t = 0.0f;
    glm::vec2 barycentrics{0.0f};  // triangles: weights of v1, v2; spheres: unused (0)
    std::uint32_t primitive = ~0u;  // input triangle / sphere index
    bool front_face = false;        // triangles: see ray_triangle.hpp; spheres: entry = front, exit = back
};

// Per-ray counters. Cheap enough to keep always on (a few increments per node).
struct BlasCounters {
    TraversalStats traversal;
    std::uint32_t any_hit_invocations = 0;
};

// What the triangle kernel needs of a ray, prepared once per ray (per instance in trace()). The box
// set-up (BoxRay) is separate: a single-leaf BLAS is tested without it.
struct BlasRay {
    Ray ray;
    TriangleRay tri;
    explicit BlasRay(const Ray& r) : ray(r), tri(r) {}
    BlasRay(const Ray& r, const TriangleRay& t) : ray(r), tri(t) {}  // t: TriangleRay(r), made elsewhere
};

// What the sphere kernel needs: the ray in double. trace() transforms the world ray into object space
// in double and hands it over unrounded, so an instanced sphere is as exact as a world-space one.
struct SphereRay {
    glm::dvec3 origin;
    glm::dvec3 direction;
    float tmin;
    explicit SphereRay(const Ray& r) : origin(r.origin), direction(r.direction), tmin(r.tmin) {}
    SphereRay(const glm::dvec3& o, const glm::dvec3& d, float t0) : origin(o), direction(d), tmin(t0) {}
};

// Runs `on_hit(const BlasHit&)` for every triangle of the leaf whose `count` triangles are in the blocks
// from `first_block` on (MeshBlas::blocks()) that the ray hits in [tmin, tmax], in leaf order. on_hit
// returns true to end the search (it may also lower tmax). Eight triangles at a time are sheared and
// tested for straddling (ray_triangle_block.hpp); the few that remain are finished one by one against the
// tmax of that moment, exactly as the scalar test would, with the triangle's normal formed from the block's
// own vertices (triangle_normal() is exact, so it is the scalar test's normal bit for bit).
template <class OnHit>
inline bool mesh_leaf_hits(const MeshBlas& blas, const BlasRay& r, const float& tmax, std::uint32_t first_block,
                           std::uint32_t count, TraversalStats& stats, OnHit&& on_hit) {
    stats.primitives_tested += count;
    for (const TriangleBlock* b = blas.blocks() + first_block;; ++b, count -= kTriangleBlockLanes) {
        ShearedBlock sheared;
        unsigned keep = shear_block(r.tri, *b, std::min(kTriangleBlockLanes, count), sheared);
        while (keep != 0) {
            const unsigned i = unsigned(std::countr_zero(keep));
            keep &= keep - 1;
            const glm::vec3 v0 = b->vertex(i, 0);
            TriangleHit th;
            if (!finish_triangle_hit(r.tri, sheared.lane(i), v0, triangle_normal(v0, b->vertex(i, 1), b->vertex(i, 2)),
                                     tmax, th))
                continue;
            if (on_hit(BlasHit{th.t, th.barycentrics, b->primitive[i], th.front_face})) return true;
        }
        if (count <= kTriangleBlockLanes) return false;
    }
}

// The wide walk's leaf prefetch for a mesh: all of a leaf's blocks (up to three), so that a leaf of more than
// eight triangles does not wait on its second block after the first.
struct MeshLeafPrefetch {
    const MeshBlas& blas;
    [[gnu::always_inline]] void operator()(std::uint32_t first_block, std::uint32_t count) const {
        const TriangleBlock* b = blas.blocks() + first_block;
        for (std::uint32_t k = 0; k < count; k += kTriangleBlockLanes, ++b)
            detail::prefetch_bytes<sizeof(TriangleBlock)>(b);
    }
};

// The same for spheres: each sphere reports its entry (front) and then its exit (back), each only if
// it lies in [tmin, tmax] at the moment it is reported. A ray starting inside reports only the exit.
template <class OnHit>
inline bool sphere_leaf_hits(const SphereBlas& blas, const SphereRay& r, const float& tmax, std::uint32_t first,
                             std::uint32_t count, TraversalStats& stats, OnHit&& on_hit) {
    const Sphere* spheres = blas.leaf_spheres().data();
    for (std::uint32_t k = first; k < first + count; ++k) {
        ++stats.primitives_tested;
        SphereRoots roots;
        if (!sphere_roots(r.origin, r.direction, glm::dvec3(spheres[k].center), double(spheres[k].radius), roots))
            continue;
        const float t_enter = static_cast<float>(roots.t_enter);
        if (t_enter >= r.tmin && t_enter <= tmax) {
            if (on_hit(BlasHit{t_enter, glm::vec2(0.0f), blas.primitive_id(k), true})) return true;
        }
        const float t_exit = static_cast<float>(roots.t_exit);
        if (t_exit >= r.tmin && t_exit <= tmax) {
            if (on_hit(BlasHit{t_exit, glm::vec2(0.0f), blas.primitive_id(k), false})) return true;
        }
    }
    return false;
}

namespace detail {
// mesh_leaf_hits() as a call of its own, for the per-ray walks below: the wide walk's loop runs faster without
// the leaf test's code inside it (bench bvh, the per-ray rows; docs/design.md).
template <class OnHit>
[[gnu::noinline]] bool mesh_leaf_hits_call(const MeshBlas& blas, const BlasRay& r, const float& tmax,
                                           std::uint32_t first_block, std::uint32_t count, TraversalStats& stats,
                                           OnHit& on_hit) {
    return mesh_leaf_hits(blas, r, tmax, first_block, count, stats, on_hit);
}

// One any-hit search over either BLAS kind: the callback decides every candidate. A mesh BLAS is walked
// through its wide tree in `Order` (blas_wide_traversal.hpp); a sphere BLAS through its binary tree.
template <BlasWalkOrder Order, class Blas, class AnyHit>
inline bool blas_any_hit_search(const Blas& blas, const Ray& ray, AnyHit&& any_hit, BlasHit& committed,
                                BlasCounters& counters) {
    using KernelRay = std::conditional_t<std::is_same_v<Blas, MeshBlas>, BlasRay, SphereRay>;
    const KernelRay r(ray);
    float tmax = ray.tmax;
    bool hit = false;
    auto on_hit = [&](const BlasHit& candidate) {
        ++counters.any_hit_invocations;
        const AnyHitDecision d = any_hit(candidate);
        if (d == AnyHitDecision::ignore) return false;
        committed = candidate;
        hit = true;
        tmax = candidate.t;
        return d == AnyHitDecision::accept_and_end;
    };
    if constexpr (std::is_same_v<Blas, MeshBlas>) {
        traverse_blas_wide<Order>(blas.wide(), BoxRay(ray), tmax, [&](std::uint32_t first, std::uint32_t count) {
            return mesh_leaf_hits_call(blas, r, tmax, first, count, counters.traversal, on_hit);
        }, counters.traversal, MeshLeafPrefetch{blas});
    } else {
        traverse_bvh(blas.bvh(), BoxRay(ray), tmax, [&](std::uint32_t first, std::uint32_t count) {
            return sphere_leaf_hits(blas, r, tmax, first, count, counters.traversal, on_hit);
        }, counters.traversal);
    }
    return hit;
}
}  // namespace detail

// Any-hit traversal: any_hit(const BlasHit&) -> AnyHitDecision is called for every candidate hit with
// t in [tmin, committed tmax], in no particular order of t (a mesh's wide tree is walked in slot order,
// the cheapest). Returns true with `committed` set when a candidate was accepted (the last one accepted
// is the closest accepted, since tmax shrinks).
template <class AnyHit>
inline bool any_hit_traversal(const MeshBlas& blas, const Ray& ray, AnyHit&& any_hit, BlasHit& committed,
                              BlasCounters& counters) {
    return detail::blas_any_hit_search<BlasWalkOrder::any_order>(blas, ray, any_hit, committed, counters);
}
template <class AnyHit>
inline bool any_hit_traversal(const SphereBlas& blas, const Ray& ray, AnyHit&& any_hit, BlasHit& committed,
                              BlasCounters& counters) {
    return detail::blas_any_hit_search<BlasWalkOrder::any_order>(blas, ray, any_hit, committed, counters);
}

// Closest hit: every candidate is accepted, so tmax shrinks to the nearest hit.
template <class Blas>
inline bool closest_hit(const Blas& blas, const Ray& ray, BlasHit& hit, BlasCounters& counters) {
    const std::uint32_t invocations = counters.any_hit_invocations;
    const bool found = detail::blas_any_hit_search<BlasWalkOrder::nearest_first>(
        blas, ray, [](const BlasHit&) { return AnyHitDecision::accept; }, hit, counters);
    counters.any_hit_invocations = invocations;  // closest hit runs no any-hit shader
    return found;
}

}  // namespace smoketrace
