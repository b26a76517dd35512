#pragma once
// What a trace call takes and gives (textbook/trace.hpp, trace/trace.hpp, trace_bundle.hpp): DXR's ray flags
// and hit kinds, the hit an any-hit callback sees, the per-ray counters, the cutoff and the result. Plain
// data beside the acceleration structures, so that the textbook trace and the fast ones share them.
#include <smoketrace/accel/any_hit.hpp>
#include <smoketrace/accel/accel_scene.hpp>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

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

}  // namespace smoketrace
