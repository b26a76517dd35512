// The mesh BLAS's update (triangle_mesh.hpp): the checks and the rebuild here, the refit, compiled in
// triangle_mesh.cpp, at the process's kernel level (core/simd/dispatch.hpp).
#include <smoketrace/accel/triangle_mesh.hpp>
#include <smoketrace/core/simd/dispatch.hpp>

#include <cmath>
#include <stdexcept>
#include <string>

namespace smoketrace {

BlasUpdate MeshBlas::update_vertices(std::span<const glm::vec3> vertices, double rebuild_ratio) {
    if (vertices.size() != vertex_count_)
        throw std::invalid_argument("MeshBlas::update_vertices: " + std::to_string(vertices.size()) +
                                    " vertices given, but the mesh has " + std::to_string(vertex_count_) +
                                    " (its triangles index them, so the count must stay the same)");
    for (std::size_t i = 0; i < vertices.size(); ++i)
        if (!std::isfinite(vertices[i].x) || !std::isfinite(vertices[i].y) || !std::isfinite(vertices[i].z))
            throw std::invalid_argument("MeshBlas::update_vertices: vertex " + std::to_string(i) + " is not finite");

    // The rebuild: the input mesh put back together from the leaf order and the degenerate list.
    auto rebuild = [&] {
        TriangleMesh m;
        m.vertices.assign(vertices.begin(), vertices.end());
        m.triangles.resize(input_count_);
        for (std::size_t k = 0; k < leaf_indices_.size(); ++k) m.triangles[bvh_.prim_indices[k]] = leaf_indices_[k];
        for (const auto& [id, t] : degenerate_) m.triangles[id] = t;
        *this = MeshBlas(m, settings_);
        return BlasUpdate::rebuild;
    };

    // The tree must hold exactly the non-degenerate triangles, as a fresh build's would.
    for (const auto& [id, t] : degenerate_)
        if (!is_degenerate(vertices[t.x], vertices[t.y], vertices[t.z])) return rebuild();
    const bool refit = simd::at_active_level([&]<simd::Level L> { return refit_at_level<L>(vertices, rebuild_ratio); });
    return refit ? BlasUpdate::refit : rebuild();
}

}  // namespace smoketrace
