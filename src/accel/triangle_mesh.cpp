// Mesh BLAS construction and refit (see triangle_mesh.hpp): a kernel source, compiled once per kernel level
// (core/simd/dispatch.hpp) for the refit; update_vertices() is in triangle_mesh_dispatch.cpp.
#include <smoketrace/accel/triangle_mesh.hpp>
#include <smoketrace/geometry/ray_triangle.hpp>
#include "bvh_bottom_up.hpp"

#include <glm/geometric.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <type_traits>
#include <stdexcept>
#include <string>

namespace smoketrace {

bool is_degenerate(const glm::vec3& v0, const glm::vec3& v1, const glm::vec3& v2) {
    const glm::dvec3 n = triangle_normal(v0, v1, v2);
    return n.x == 0.0 && n.y == 0.0 && n.z == 0.0;
}

const char* to_string(BlasUpdate u) {
    switch (u) {
        case BlasUpdate::refit: return "refit";
        case BlasUpdate::rebuild: return "rebuild";
    }
    return "?";
}

// The per-triangle loops run in parallel (TBB) in blocks of this many: each iteration is independent and
// writes its own slots, so the result is the same for any thread count.
constexpr std::size_t kParallelGrain = 4096;
using Range = tbb::blocked_range<std::size_t>;

// Storage for n boxes from std::allocator, each constructed by the parallel pass that computes it: the
// pass is then the first touch of the pages (a vector would first write every box once, serially).
class BoxStorage {
public:
    explicit BoxStorage(std::size_t n) : data_(alloc_.allocate(n)), n_(n) {}
    BoxStorage(const BoxStorage&) = delete;
    BoxStorage& operator=(const BoxStorage&) = delete;
    ~BoxStorage() { alloc_.deallocate(data_, n_); }  // Aabb is trivially destructible
    [[nodiscard]] Aabb* data() const { return data_; }

private:
    std::allocator<Aabb> alloc_;
    Aabb* data_;
    std::size_t n_;
};
static_assert(std::is_trivially_destructible_v<Aabb>);

MeshBlas::MeshBlas(const TriangleMesh& mesh, const BvhBuildSettings& settings)
    : settings_(settings), vertex_count_(mesh.vertices.size()), input_count_(mesh.triangles.size()) {
    // Per triangle: its box, and 0 to build over, 1 degenerate, 2 indexing a missing vertex (the exact test
    // in double is the costly part, so it runs in parallel; the first bad triangle is then reported in
    // input order).
    const std::size_t n_in = mesh.triangles.size();
    std::vector<std::uint8_t, UnwrittenAllocator<std::uint8_t>> kind(n_in);  // every entry written below
    const BoxStorage box_storage(n_in);
    Aabb* const boxes = box_storage.data();
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n_in, kParallelGrain),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          const std::size_t nv = mesh.vertices.size();
                          for (std::size_t i = r.begin(); i < r.end(); ++i) {
                              const glm::uvec3 t = mesh.triangles[i];
                              Aabb& box = *std::construct_at(boxes + i);
                              if (t.x >= nv || t.y >= nv || t.z >= nv) {
                                  kind[i] = 2;
                                  continue;
                              }
                              const glm::vec3 &a = mesh.vertices[t.x], &b = mesh.vertices[t.y], &c = mesh.vertices[t.z];
                              kind[i] = is_degenerate(a, b, c) ? 1 : 0;
                              box.grow(a);
                              box.grow(b);
                              box.grow(c);
                          }
                      });
    // Triangle i of the tree is input triangle kept[i]; without degenerate triangles (the usual case) that
    // is i itself and the boxes need no compaction.
    std::vector<std::uint32_t> kept;
    std::size_t box_count = n_in;
    for (std::size_t i = 0; i < n_in; ++i) {
        if (kind[i] == 2)
            throw std::out_of_range("MeshBlas: triangle " + std::to_string(i) + " indexes a missing vertex");
        if (kind[i] == 1) degenerate_.emplace_back(static_cast<std::uint32_t>(i), mesh.triangles[i]);
    }
    if (!degenerate_.empty()) {
        kept.reserve(n_in - degenerate_.size());
        for (std::size_t i = 0; i < n_in; ++i)
            if (kind[i] == 0) {
                boxes[kept.size()] = boxes[i];
                kept.push_back(static_cast<std::uint32_t>(i));
            }
        box_count = kept.size();
    }
    bvh_ = build_bvh(std::span<const Aabb>(boxes, box_count), settings);
    const std::size_t n = bvh_.prim_indices.size();
    triangles_.resize(n);
    leaf_indices_.resize(n);
    tbb::parallel_for(Range(0, n, kParallelGrain), [&](const Range& r) {
        for (std::size_t k = r.begin(); k < r.end(); ++k) {
            const std::uint32_t id = kept.empty() ? bvh_.prim_indices[k] : kept[bvh_.prim_indices[k]];
            const glm::uvec3 t = mesh.triangles[id];
            leaf_indices_[k] = t;
            triangles_[k] = {mesh.vertices[t.x], mesh.vertices[t.y], mesh.vertices[t.z]};
            bvh_.prim_indices[k] = id;  // leaf slot k now names the input triangle directly
        }
    });
    assign_blocks();
    refresh_blocks();
    wide_.collapse(bvh_, leaf_blocks_);
    sah_at_build_ = sah_current_ = bvh_.sah_cost(settings_.costs);
}

void MeshBlas::assign_blocks() {
    const auto& nodes = bvh_.nodes;
    leaf_blocks_.clear();
    leaf_blocks_.resize(nodes.size());  // unwritten: the loop writes every entry once
    leaf_starts_.clear();
    std::size_t count = 0;
    for (std::size_t i = 0; i < nodes.size(); ++i) {
        leaf_blocks_[i] = static_cast<std::uint32_t>(count);  // an inner node's is unused
        if (i == 1 || !nodes[i].is_leaf()) continue;  // node 1: the layout's padding slot (bvh.hpp)
        leaf_starts_.emplace_back(nodes[i].first, static_cast<std::uint32_t>(count));
        count += (nodes[i].count + kTriangleBlockLanes - 1) / kTriangleBlockLanes;
    }
    if (count > std::numeric_limits<std::uint32_t>::max())
        throw std::length_error("MeshBlas: too many triangle blocks");
    std::sort(leaf_starts_.begin(), leaf_starts_.end());
    blocks_.clear();
    blocks_.resize(count);  // unwritten: refresh_blocks() writes every block whole
}

std::uint32_t MeshBlas::leaf_block(std::uint32_t first) const {
    const auto it = std::lower_bound(leaf_starts_.begin(), leaf_starts_.end(), std::pair(first, 0u));
    if (it == leaf_starts_.end() || it->first != first)
        throw std::out_of_range("MeshBlas::leaf_block: no leaf starts at slot " + std::to_string(first));
    return it->second;
}

void MeshBlas::refresh_blocks() {
    const auto& nodes = bvh_.nodes;
    tbb::parallel_for(Range(0, nodes.size(), 1024), [&](const Range& r) {
        for (std::size_t i = r.begin(); i < r.end(); ++i) {
            const BvhNode& n = nodes[i];
            if (i == 1 || !n.is_leaf()) continue;
            // Each block made whole, then stored: its spare lanes zero, its memory written once.
            TriangleBlock* out = blocks_.data() + leaf_blocks_[i];
            for (std::uint32_t k0 = 0; k0 < n.count; k0 += kTriangleBlockLanes, ++out) {
                TriangleBlock b{};
                for (std::uint32_t k = k0; k < n.count && k < k0 + kTriangleBlockLanes; ++k) {
                    const Triangle& t = triangles_[n.first + k];
                    b.set(k - k0, t.v0, t.v1, t.v2, bvh_.prim_indices[n.first + k]);
                }
                *out = b;
            }
        }
    });
}

// Leaf boxes first, in parallel and in memory order (leaf ranges ascend with the depth-first node order,
// so the triangles stream in), as the build's boxes were made; then one backward sweep over the inner
// nodes (children before parents, subtrees in parallel: bvh_bottom_up.hpp), which reads nothing but nodes.
void MeshBlas::refit_boxes() {
    auto& nodes = bvh_.nodes;
    tbb::parallel_for(Range(0, nodes.size(), 1024), [&](const Range& r) {
        for (std::size_t i = r.begin(); i < r.end(); ++i) {
            BvhNode& n = nodes[i];
            if (i == 1 || !n.is_leaf()) continue;
            // Each triangle's box, then one min and one max into the leaf's: a third of the dependency
            // chain through the leaf box (min and max are exact, so the same box as growing by vertices).
            Aabb b;
            for (std::uint32_t k = n.first; k < n.first + n.count; ++k) {
                const Triangle& t = triangles_[k];
                b.grow(Aabb{glm::min(glm::min(t.v0, t.v1), t.v2), glm::max(glm::max(t.v0, t.v1), t.v2)});
            }
            n.bounds = b;
        }
    });
    sweep_bottom_up(bvh_, [&](std::uint32_t i) {
        BvhNode& n = nodes[i];
        if (!n.is_leaf()) n.bounds = merge(nodes[n.first].bounds, nodes[n.first + 1].bounds);
        return 0.0;
    });
    sah_current_ = bvh_.sah_cost(settings_.costs);
}

// The refit (update_vertices(), in triangle_mesh_dispatch.cpp, has checked the vertices): the leaf-ordered
// triangles from the new vertices, the boxes, the blocks and the walked tree; false, and the rest left
// unwritten, where the mesh must be rebuilt instead.
template <simd::Level L>
bool MeshBlas::refit_at_level(std::span<const glm::vec3> vertices, double rebuild_ratio) {
    static_assert(L == simd::kCompiledLevel);
    std::atomic<bool> became_degenerate{false};
    tbb::parallel_for(Range(0, leaf_indices_.size(), kParallelGrain), [&](const Range& r) {
        bool any = false;
        for (std::size_t k = r.begin(); k < r.end(); ++k) {
            const glm::uvec3 t = leaf_indices_[k];
            const Triangle& tri = triangles_[k] = {vertices[t.x], vertices[t.y], vertices[t.z]};
            any = any || is_degenerate(tri.v0, tri.v1, tri.v2);
        }
        if (any) became_degenerate.store(true, std::memory_order_relaxed);
    });
    if (became_degenerate.load()) return false;
    refit_boxes();
    if (sah_current_ > rebuild_ratio * sah_at_build_) return false;
    refresh_blocks();
    wide_.collapse(bvh_, leaf_blocks_);  // the walked tree from the refit one: the same topology, O(nodes)
    return true;
}

// This copy's refit (core/simd/dispatch.hpp).
template bool MeshBlas::refit_at_level<simd::kCompiledLevel>(std::span<const glm::vec3>, double);

}  // namespace smoketrace
