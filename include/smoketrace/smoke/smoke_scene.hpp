#pragma once
// The smoke scene as the ray tracer sees it (thesis 4.1): every particle twice — a stand-in (sphere,
// icosahedron or icosphere) for optical-depth and shadow rays, and a camera-facing billboard quad for
// view rays — plus the opaque ground quad. Instance masks keep the representations apart.
#include <smoketrace/smoke/particle_system.hpp>
#include <smoketrace/accel/accel_scene.hpp>
#include <smoketrace/smoke/stand_in_shapes.hpp>

#include <array>
#include <optional>
#include <span>

namespace smoketrace {

// Instance masks (thesis 4.1: stand-ins 1, quads 2, ground 3). The ground gets a bit of its own (4)
// instead of 3 = 1|2, so that a ray can also ask for the ground alone; the ray masks keep the thesis's
// meaning: light rays (optical depth, shadows) see everything but billboards (~2), view rays see
// everything but stand-ins (~1).
inline constexpr std::uint8_t kStandInMask = 0x1;
inline constexpr std::uint8_t kBillboardMask = 0x2;
inline constexpr std::uint8_t kGroundMask = 0x4;
inline constexpr std::uint8_t kLightRayMask = static_cast<std::uint8_t>(~kBillboardMask);
inline constexpr std::uint8_t kViewRayMask = static_cast<std::uint8_t>(~kStandInMask);

// The ground: an opaque quad, counter-clockwise seen from the side its normal points to.
struct GroundQuad {
    std::array<glm::vec3, 4> corners;
    [[nodiscard]] glm::vec3 normal() const;  // unit, from the winding
};

class SmokeScene {
public:
    // `billboards`: build the view-ray quads too (the optical-depth pass alone does not need them).
    SmokeScene(std::span<const Particle> particles, StandInShape shape, const std::optional<GroundQuad>& ground,
               bool billboards);

    // Moves the instances to this frame's particles and turns the billboards toward `eye`; only
    // instances whose transform really changed are touched, so a frame where nothing moved does no TLAS
    // work (TlasUpdate::none).
    TlasUpdate update(std::span<const Particle> particles, const glm::vec3& eye);

    [[nodiscard]] const AccelScene& scene() const { return scene_; }
    [[nodiscard]] std::size_t particle_count() const { return count_; }
    [[nodiscard]] StandInShape shape() const { return shape_; }
    [[nodiscard]] bool has_billboards() const { return billboards_; }
    [[nodiscard]] bool has_ground() const { return ground_instance_ != kNoInstance; }
    [[nodiscard]] glm::vec3 ground_normal() const { return ground_normal_; }

    // Instance layout: stand-ins are instances [0, n), billboards [n, 2n), the ground last. An
    // instance's user id is its particle index (the ground's is kGroundUserId).
    [[nodiscard]] bool is_billboard(std::uint32_t instance) const {
        return billboards_ && instance >= count_ && instance < 2 * count_;
    }
    static constexpr std::uint32_t kGroundUserId = 0xFFFFFFFFu;

    // Billboard orientation: the unit quad [−1, 1]² in its object xy plane, facing +z, mapped so that
    // object z points at the eye. Exposed for the view compositor's tangent space.
    static AffineTransform billboard_transform(const Particle& p, const glm::vec3& eye);

private:
    static constexpr std::uint32_t kNoInstance = ~0u;
    AccelScene scene_;
    std::size_t count_ = 0;
    StandInShape shape_;
    bool billboards_ = false;
    std::uint32_t ground_instance_ = kNoInstance;
    glm::vec3 ground_normal_{0.0f, 1.0f, 0.0f};
};

}  // namespace smoketrace
