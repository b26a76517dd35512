#pragma once
// Exact spheres as a bottom-level geometry kind: the procedural primitive of smoketrace.
#include <smoketrace/accel/bvh.hpp>
#include <smoketrace/accel/bvh_builder.hpp>

#include <glm/vec3.hpp>
#include <cstdint>
#include <vector>

namespace smoketrace {

struct Sphere {
    glm::vec3 center{0.0f};
    float radius = 1.0f;
};

// A BVH over spheres, copied into leaf order like MeshBlas. A set of one sphere (the unit sphere of a
// particle stand-in) has a single leaf node and costs one box test and one sphere test per ray.
class SphereBlas {
public:
    SphereBlas() = default;
    explicit SphereBlas(const std::vector<Sphere>& spheres, const BvhBuildSettings& settings = {});

    [[nodiscard]] const Bvh& bvh() const { return bvh_; }
    [[nodiscard]] Aabb bounds() const { return bvh_.empty() ? Aabb{} : bvh_.bounds(); }
    [[nodiscard]] const std::vector<Sphere>& leaf_spheres() const { return spheres_; }
    [[nodiscard]] std::uint32_t primitive_id(std::uint32_t k) const { return bvh_.prim_indices[k]; }

private:
    Bvh bvh_;
    std::vector<Sphere> spheres_;
};

}  // namespace smoketrace
