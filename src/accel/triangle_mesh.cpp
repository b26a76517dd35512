// Mesh BLAS construction (see triangle_mesh.hpp).
#include <smoketrace/accel/triangle_mesh.hpp>
#include <smoketrace/geometry/ray_triangle.hpp>

#include <glm/geometric.hpp>
#include <stdexcept>
#include <string>

namespace smoketrace {

bool is_degenerate(const glm::vec3& v0, const glm::vec3& v1, const glm::vec3& v2) {
    const glm::dvec3 n = triangle_normal(v0, v1, v2);
    return n.x == 0.0 && n.y == 0.0 && n.z == 0.0;
}

MeshBlas::MeshBlas(const TriangleMesh& mesh, const BvhBuildSettings& settings) : input_count_(mesh.triangles.size()) {
    std::vector<Aabb> boxes;
    std::vector<std::uint32_t> kept;
    boxes.reserve(mesh.triangles.size());
    kept.reserve(mesh.triangles.size());
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
        const glm::uvec3 t = mesh.triangles[i];
        if (t.x >= mesh.vertices.size() || t.y >= mesh.vertices.size() || t.z >= mesh.vertices.size())
            throw std::out_of_range("MeshBlas: triangle " + std::to_string(i) + " indexes a missing vertex");
        const glm::vec3 &a = mesh.vertices[t.x], &b = mesh.vertices[t.y], &c = mesh.vertices[t.z];
        if (is_degenerate(a, b, c)) continue;
        Aabb box;
        box.grow(a);
        box.grow(b);
        box.grow(c);
        boxes.push_back(box);
        kept.push_back(static_cast<std::uint32_t>(i));
    }
    bvh_ = build_bvh(boxes, settings);
    triangles_.resize(bvh_.prim_indices.size());
    normals_.resize(bvh_.prim_indices.size());
    for (std::size_t k = 0; k < bvh_.prim_indices.size(); ++k) {
        const std::uint32_t id = kept[bvh_.prim_indices[k]];
        const glm::uvec3 t = mesh.triangles[id];
        triangles_[k] = {mesh.vertices[t.x], mesh.vertices[t.y], mesh.vertices[t.z]};
        normals_[k] = triangle_normal(triangles_[k].v0, triangles_[k].v1, triangles_[k].v2);
        bvh_.prim_indices[k] = id;  // leaf slot k now names the input triangle directly
    }
    wide_.collapse(bvh_);
    // Planes padded to whole blocks plus one, so that a block read starting at any triangle stays inside
    // (the padding is zeros: lanes past a leaf's end are masked off, never used).
    const std::size_t n = triangles_.size();
    plane_stride_ = (n + 2 * kTriangleBlockLanes - 1) / kTriangleBlockLanes * kTriangleBlockLanes;
    planes_.assign(9 * plane_stride_, 0.0f);
    for (std::size_t k = 0; k < n; ++k) {
        const glm::vec3* v = &triangles_[k].v0;
        for (int j = 0; j < 3; ++j)
            for (int a = 0; a < 3; ++a) planes_[std::size_t(3 * j + a) * plane_stride_ + k] = (&v[j].x)[a];
    }
}

}  // namespace smoketrace
