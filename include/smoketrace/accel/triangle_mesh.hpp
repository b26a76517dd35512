#pragma once
// Triangle meshes and their bottom-level acceleration structure (BLAS).
#include <smoketrace/accel/blas_wide_bvh.hpp>
#include <smoketrace/accel/bvh.hpp>
#include <smoketrace/accel/bvh_builder.hpp>
#include <smoketrace/core/aligned_allocator.hpp>
#include <smoketrace/core/huge_page_allocator.hpp>
#include <smoketrace/core/simd/level.hpp>
#include <smoketrace/geometry/ray_triangle_block.hpp>

#include <glm/vec3.hpp>
#include <cstdint>
#include <span>
#include <utility>
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

// How mesh BLASes are built unless told otherwise: a triangle test priced at an eighth of a node step,
// since the block test (ray_triangle_block.hpp) shears and rejects eight triangles for about the
// instructions of one scalar test, and leaves of up to three blocks (a 20-triangle icosahedron stand-in
// becomes one leaf, no traversal). Two-triangle billboards never reach it: they take trace()'s
// world-triangles path (accel_scene.hpp).
inline constexpr BvhBuildSettings kMeshBuildSettings{SahCosts{1.0f, 1.0f / 8.0f}, 24};

// Children per node of a mesh BLAS's wide tree (blas_wide_bvh.hpp), the one its rays walk.
inline constexpr unsigned kMeshBlasWidth = 8;

// What MeshBlas::update_vertices() did to the tree.
enum class BlasUpdate : std::uint8_t { refit, rebuild };
[[nodiscard]] const char* to_string(BlasUpdate u);

// A BVH over a mesh's triangles. Triangles are copied into leaf order, once as records (three vertices
// each, 36 bytes: what a refit and the scene's world-space copies read) and once in blocks of eight for the
// 8-wide test (ray_triangle_block.hpp), each leaf owning whole blocks, so that a leaf's test reads a few
// consecutive cache lines instead of chasing indices. Degenerate triangles are left out of the tree: they
// can never be hit.
class MeshBlas {
public:
    struct Triangle {
        glm::vec3 v0, v1, v2;
    };

    MeshBlas() = default;
    explicit MeshBlas(const TriangleMesh& mesh, const BvhBuildSettings& settings = kMeshBuildSettings);

    // The binary SAH tree: the master copy (SAH cost, single-leaf check, refit).
    [[nodiscard]] const Bvh& bvh() const { return bvh_; }
    // The wide tree collapsed from it, which the queries walk (blas_wide_traversal.hpp). Its leaves name
    // their first block (blocks()), not a leaf range.
    [[nodiscard]] const BlasWideBvh<kMeshBlasWidth>& wide() const { return wide_; }
    [[nodiscard]] Aabb bounds() const { return bvh_.empty() ? Aabb{} : bvh_.bounds(); }
    // Leaf order: triangle k of a leaf range is leaf_triangles()[k], input triangle primitive_id(k).
    [[nodiscard]] std::span<const Triangle> leaf_triangles() const { return triangles_; }
    // The same triangles in blocks of eight: the binary tree's leaf node i (first, count) holds its
    // triangles in blocks leaf_blocks()[i] …, lane by lane in leaf order, the last block's spare lanes zero.
    // Walks of the binary tree map a leaf to its blocks with leaf_block().
    [[nodiscard]] const TriangleBlock* blocks() const { return blocks_.data(); }
    [[nodiscard]] std::size_t block_count() const { return blocks_.size(); }
    [[nodiscard]] std::span<const std::uint32_t> leaf_blocks() const { return leaf_blocks_; }
    // The first block of the binary tree's leaf whose range starts at leaf slot `first` (a binary search:
    // for walks of the binary tree, whose leaf callback is given the range).
    [[nodiscard]] std::uint32_t leaf_block(std::uint32_t first) const;
    [[nodiscard]] std::uint32_t primitive_id(std::uint32_t k) const { return bvh_.prim_indices[k]; }
    // The triangles given, and those of them left out of the tree as degenerate (zero area: no ray hits them).
    [[nodiscard]] std::size_t input_triangle_count() const { return input_count_; }
    [[nodiscard]] std::size_t degenerate_count() const { return input_count_ - triangles_.size(); }

    // Moves the vertices of a deforming mesh: the same triangles (by index) over `vertices`, which must be
    // as many as the mesh had. The tree is refit bottom-up and the leaf-ordered copies refreshed, unless
    // the refit tree's SAH cost exceeds rebuild_ratio × its cost at the last build, or a triangle became
    // degenerate or stopped being so (the tree holds the non-degenerate ones exactly): then it is rebuilt
    // with the settings of the first build. Says which. Throws std::invalid_argument on a wrong vertex
    // count, leaving the BLAS as it was.
    BlasUpdate update_vertices(std::span<const glm::vec3> vertices, double rebuild_ratio = kRebuildSahRatio);
    // SAH cost (with the build's cost constants) of the tree as last refit or built, and right after the
    // last build: the two the rebuild policy compares.
    [[nodiscard]] double sah_cost() const { return sah_current_; }
    [[nodiscard]] double sah_cost_at_build() const { return sah_at_build_; }

private:
    // Lays out the blocks (one run per leaf, in node order) after a build; the tree's shape is then fixed
    // until the next build.
    void assign_blocks();
    // Refreshes the blocks from the leaf-ordered triangles after a build or a refit (which first moves
    // triangles_ and the node boxes).
    void refresh_blocks();
    void refit_boxes();
    // update_vertices()'s refit at one kernel level (core/simd/dispatch.hpp): triangle_mesh.cpp, compiled
    // once per level, instantiates it for the level it is compiled for. False where a rebuild is due.
    template <simd::Level L>
    bool refit_at_level(std::span<const glm::vec3> vertices, double rebuild_ratio);

    BvhBuildSettings settings_{};
    std::size_t vertex_count_ = 0;
    // Leaf order: each triangle's vertex indices, for a refit to find its new vertices. This array,
    // triangles_ and blocks_ grow unwritten: the build's parallel passes write every element whole, the
    // first touch of their pages (fresh memory is what a build mostly pays for where page faults are dear).
    std::vector<glm::uvec3, UnwrittenAllocator<glm::uvec3>> leaf_indices_;
    // The degenerate triangles, left out of the tree: input index and vertex indices, in input order.
    std::vector<std::pair<std::uint32_t, glm::uvec3>> degenerate_;
    double sah_at_build_ = 0.0;
    double sah_current_ = 0.0;
    Bvh bvh_;
    BlasWideBvh<kMeshBlasWidth> wide_;
    std::vector<Triangle, UnwrittenAllocator<Triangle>> triangles_;
    // In huge pages, as the wide nodes: a walk reads both at random (huge_page_allocator.hpp).
    std::vector<TriangleBlock, HugePageAllocator<TriangleBlock, alignof(TriangleBlock), true>> blocks_;
    // Per binary node: a leaf's first block (inner nodes: unused).
    std::vector<std::uint32_t, UnwrittenAllocator<std::uint32_t>> leaf_blocks_;
    // The binary leaves' (first slot, first block), in slot order: leaf_block()'s table.
    std::vector<std::pair<std::uint32_t, std::uint32_t>> leaf_starts_;
    std::size_t input_count_ = 0;
};

}  // namespace smoketrace
