#pragma once
// Triangle meshes and their bottom-level acceleration structure (BLAS).
#include <smoketrace/bvh.hpp>
#include <smoketrace/bvh_builder.hpp>

#include <glm/vec3.hpp>
#include <cstdint>
#include <vector>

namespace smoketrace {

// An indexed triangle mesh. Winding convention: see ray_triangle.hpp (counter-clockwise = front).
struct TriangleMesh {
    std::vector<glm::vec3> vertices;
    std::vector<glm::uvec3> triangles;
};

// True when the triangle has zero area (repeated or collinear vertices), decided exactly: the
// differences and the cross product are formed in double, where they are exact for float input of
// similar magnitude, and compared with 0.
[[nodiscard]] bool is_degenerate(const glm::vec3& v0, const glm::vec3& v1, const glm::vec3& v2);

// A BVH over a mesh's triangles. Triangles are copied into leaf order (three vertices each, 36 bytes)
// so that a leaf's tests read consecutive memory instead of chasing indices. Degenerate triangles are
// left out of the tree: they can never be hit.
class MeshBlas {
public:
    struct Triangle {
        glm::vec3 v0, v1, v2;
    };

    MeshBlas() = default;
    explicit MeshBlas(const TriangleMesh& mesh, const BvhBuildSettings& settings = {});

    [[nodiscard]] const Bvh& bvh() const { return bvh_; }
    [[nodiscard]] Aabb bounds() const { return bvh_.empty() ? Aabb{} : bvh_.bounds(); }
    // Leaf order: triangle k of a leaf range is leaf_triangles()[k], input triangle primitive_id(k).
    [[nodiscard]] const std::vector<Triangle>& leaf_triangles() const { return triangles_; }
    [[nodiscard]] std::uint32_t primitive_id(std::uint32_t k) const { return bvh_.prim_indices[k]; }
    [[nodiscard]] std::size_t input_triangle_count() const { return input_count_; }
    [[nodiscard]] std::size_t degenerate_count() const { return input_count_ - triangles_.size(); }

private:
    Bvh bvh_;
    std::vector<Triangle> triangles_;
    std::size_t input_count_ = 0;
};

}  // namespace smoketrace
