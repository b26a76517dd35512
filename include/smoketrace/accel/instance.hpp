#pragma once
// Instances: a bottom-level structure placed in the world by an affine transform (DXR's
// D3D12_RAYTRACING_INSTANCE_DESC), with a mask, a user id and flags.
#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>
#include <cstdint>

namespace smoketrace {

// x ↦ linear·x + translation, in double. Double matters far from the origin: a ray origin at 1e5 is
// taken into object space as linear⁻¹·(o − translation), and the subtraction of two nearby large
// coordinates is exact in double where float would already have lost the particle's scale.
struct AffineTransform {
    glm::dmat3 linear{1.0};
    glm::dvec3 translation{0.0};

    [[nodiscard]] glm::dvec3 point(const glm::dvec3& p) const { return linear * p + translation; }
    [[nodiscard]] glm::dvec3 vector(const glm::dvec3& v) const { return linear * v; }
    [[nodiscard]] double determinant() const;
    [[nodiscard]] AffineTransform inverse() const;  // throws std::domain_error if singular
    void check_invertible() const;                   // throws as inverse() does, without inverting

    static AffineTransform translate_scale(const glm::dvec3& t, double uniform_scale);

    friend bool operator==(const AffineTransform& a, const AffineTransform& b) {
        return a.linear == b.linear && a.translation == b.translation;
    }
};

// Instance flags (DXR's D3D12_RAYTRACING_INSTANCE_FLAGS, bit for bit the same meaning except for the
// winding flag, see below).
enum InstanceFlags : std::uint8_t {
    instance_flag_none = 0,
    // Facing culls of the ray (CULL_BACK/FRONT_FACING_TRIANGLES) do not apply to this instance.
    instance_flag_triangle_cull_disable = 0x1,
    // Reverses which side of its triangles is the front. DXR's default is clockwise-front and its flag
    // is TRIANGLE_FRONT_COUNTERCLOCKWISE; smoketrace's default is counter-clockwise-front (see
    // ray_triangle.hpp), so the same reversal is spelled the other way round.
    instance_flag_triangle_front_clockwise = 0x2,
    instance_flag_force_opaque = 0x4,      // every primitive of the instance is opaque
    instance_flag_force_non_opaque = 0x8,  // every primitive of the instance is non-opaque
};

struct Instance {
    std::uint32_t blas = 0;  // index of a bottom level added to the scene
    AffineTransform object_to_world{};
    std::uint8_t mask = 0xFF;  // 8-bit instance mask (InstanceMask)
    std::uint32_t user_id = 0;  // InstanceID(), free for the application
    std::uint8_t flags = instance_flag_none;
};

}  // namespace smoketrace
