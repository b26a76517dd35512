#pragma once
// The two-level scene: bottom-level structures (BLAS) placed by instances, and the top-level BVH
// (TLAS) over the instances' world boxes.
//
// Per frame the application changes transforms and masks, then calls commit(), which brings the TLAS
// up to date with the least work that keeps it good:
//   * nothing changed                         → none    (no TLAS work at all)
//   * transforms or masks changed             → refit   (boxes and masks recomputed bottom-up, O(n))
//   * instances added or removed, or the refit tree's SAH cost has grown past
//     kTlasRebuildSahRatio × its cost right after the last full build → rebuild (binned SAH).
#include <smoketrace/bvh.hpp>
#include <smoketrace/instance.hpp>
#include <smoketrace/sphere_set.hpp>
#include <smoketrace/triangle_mesh.hpp>

#include <cstdint>
#include <memory>
#include <vector>

namespace smoketrace {

enum class GeometryKind : std::uint8_t { triangles, spheres };

// One bottom-level structure: a triangle mesh or a set of exact spheres, with DXR's geometry opacity.
struct BottomLevel {
    GeometryKind kind = GeometryKind::triangles;
    MeshBlas mesh;        // kind == triangles
    SphereBlas spheres;   // kind == spheres
    bool opaque = true;   // D3D12_RAYTRACING_GEOMETRY_FLAG_OPAQUE

    static BottomLevel from_mesh(const TriangleMesh& m, bool opaque);
    static BottomLevel from_spheres(const std::vector<Sphere>& s, bool opaque);
    [[nodiscard]] Aabb bounds() const { return kind == GeometryKind::triangles ? mesh.bounds() : spheres.bounds(); }
};

// A refit tree whose SAH cost exceeds this multiple of its cost when last built is rebuilt. 1.2 keeps
// traversal within about 20 % of a fresh tree (SAH cost tracks nodes visited per ray closely for the
// TLAS) while letting small per-frame motion through with a refit alone; see bench "tlas".
inline constexpr double kTlasRebuildSahRatio = 1.2;

enum class TlasUpdate : std::uint8_t { none, refit, rebuild };
[[nodiscard]] const char* to_string(TlasUpdate u);

// What trace() reads per instance, kept together in instance order. The fields up to and including
// sphere_radius (the first 72 bytes) are all that a visit to a world sphere reads until it reports a
// hit; world_to_object_linear comes last, needed by the general path and for a sphere hit's object_point.
struct InstanceRecord {
    std::uint8_t mask;
    std::uint8_t flags;
    // Rule 2 as far as the instance decides it: the geometry's opacity after the instance's FORCE_OPAQUE /
    // FORCE_NON_OPAQUE, so that trace() need not chase `blas` to decide it.
    bool opaque;
    // The BLAS is one sphere and the transform a similarity (uniform scale · orthogonal): the instance is
    // that sphere in world space, sphere_offset and sphere_radius below, and trace() intersects the world
    // ray with it directly instead of taking the ray into object space (t is the same in both).
    bool world_sphere;
    std::uint32_t user_id;
    const BottomLevel* blas;
    glm::dvec3 object_to_world_translation;  // subtracted first, then the linear inverse applied
    // world_sphere only. The centre relative to the translation (linear · centre), not the world centre:
    // trace() subtracts the translation from the ray origin first, exactly as the general path does, so
    // a small sphere far from the world origin is as precise as there.
    glm::dvec3 sphere_offset;
    double sphere_radius;  // scale · radius
    glm::dmat3 world_to_object_linear;
};

class Scene {
public:
    Scene() = default;
    Scene(const Scene&) = delete;
    Scene& operator=(const Scene&) = delete;
    Scene(Scene&&) = default;
    Scene& operator=(Scene&&) = default;

    std::uint32_t add_bottom_level(BottomLevel blas);
    std::uint32_t add_instance(const Instance& instance);  // returns its index
    void remove_instance(std::uint32_t index);              // later indices move down by one
    void set_transform(std::uint32_t index, const AffineTransform& object_to_world);
    void set_mask(std::uint32_t index, std::uint8_t mask);

    // Brings the TLAS up to date (see the table above) and says what it did.
    TlasUpdate commit();

    [[nodiscard]] std::size_t instance_count() const { return instances_.size(); }
    [[nodiscard]] const Instance& instance(std::uint32_t i) const { return instances_[i]; }
    [[nodiscard]] const BottomLevel& bottom_level(std::uint32_t i) const { return *blases_[i]; }
    [[nodiscard]] const Aabb& instance_bounds(std::uint32_t i) const { return world_boxes_[i]; }

    // For trace(): the committed top level. Valid after commit().
    [[nodiscard]] const Bvh& tlas() const { return tlas_; }
    [[nodiscard]] const std::vector<std::uint8_t>& tlas_node_masks() const { return node_masks_; }
    [[nodiscard]] const InstanceRecord& record(std::uint32_t i) const { return records_[i]; }
    [[nodiscard]] bool committed() const { return !structure_dirty_ && !transforms_dirty_; }

    [[nodiscard]] double tlas_sah_cost() const { return sah_current_; }
    [[nodiscard]] double tlas_sah_cost_at_build() const { return sah_at_build_; }
    void set_rebuild_ratio(double r) { rebuild_ratio_ = r; }

private:
    void update_instance(std::uint32_t i);
    void rebuild();
    void refit();

    std::vector<std::unique_ptr<BottomLevel>> blases_;  // stable addresses for InstanceRecord::blas
    std::vector<Instance> instances_;
    std::vector<InstanceRecord> records_;
    std::vector<Aabb> world_boxes_;
    // Each instance's mask again, one byte apiece: the refit sweep reads it at random (TLAS leaf order),
    // and from the 100-byte Instance records that was a cache miss per leaf.
    std::vector<std::uint8_t> instance_masks_;
    Bvh tlas_;
    std::vector<std::uint8_t> node_masks_;  // OR of the instance masks below each TLAS node
    double sah_at_build_ = 0.0;
    double sah_current_ = 0.0;  // of the tree as last refit or built
    double rebuild_ratio_ = kTlasRebuildSahRatio;
    bool structure_dirty_ = true;
    bool transforms_dirty_ = false;
};

}  // namespace smoketrace
