#pragma once
// Binned SAH builder (Wald, "On fast Construction of SAH-based Bounding Volume Hierarchies", 2007).
//
// Input: one box per primitive. Each node's primitives are binned by centroid into kBins slabs along
// each axis; the split plane between two bins with the lowest SAH cost wins, or the node becomes a
// leaf when that is cheaper (and it holds at most max_leaf_size primitives). Nodes with many
// primitives bin and partition in parallel, and the two subtrees of a large node are built in parallel
// (TBB); the result does not depend on the number of threads (min/max and counts are exact in any order,
// the parallel partition pairs misplaced primitives by rank, and the node array is laid out depth-first
// afterwards). docs/design.md, "BVH layout and builder", lists what keeps it fast.
#include <smoketrace/accel/bvh.hpp>

#include <array>
#include <span>

namespace smoketrace {

struct BvhBuildSettings {
    // 16 bins per axis: Wald (2007) found 16–32 bins within a few percent of a full SAH sweep;
    // 16 keeps the bin sweep cheap next to the partition.
    static constexpr int kBins = 16;
    SahCosts costs{};
    // A leaf never holds more than this; 4 suits triangles (a leaf's tests stay within one or two cache
    // lines of triangle data) and instances alike. 1 forces one primitive per leaf.
    unsigned max_leaf_size = 4;
    // Nodes with fewer primitives than this are built on the calling thread.
    unsigned parallel_threshold = 4096;
};

// Builds a BVH over primitive boxes. Empty boxes (degenerate primitives the caller wants skipped
// should simply not be passed) are not allowed. The depth never exceeds kMaxBvhDepth: where SAH
// splits could go deeper, the builder falls back to splitting at the object median, which halves the
// primitive count per level.
[[nodiscard]] Bvh build_bvh(std::span<const Aabb> prim_boxes, const BvhBuildSettings& settings = {});

// Builds one SAH tree per group of primitives (primitive i belongs to group_of[i]) and joins them under
// an SAH tree over the groups' boxes, so that no node below that small top tree mixes two groups. The
// TLAS groups instances by mask: a ray whose inclusion mask excludes a group then skips the group's whole
// subtree with one box test. Grouping pays for a few classes of primitives that rays exclude together
// (the smoke scene has three); with many small groups (arbitrary 8-bit masks) it would only cost SAH
// quality, so more than kMaxBvhGroups groups fall back to build_bvh, as do one group and a joined tree
// deeper than kMaxBvhDepth.
inline constexpr std::size_t kMaxBvhGroups = 4;
[[nodiscard]] Bvh build_grouped_bvh(std::span<const Aabb> prim_boxes, std::span<const std::uint32_t> group_of,
                                    const BvhBuildSettings& settings = {});
// The same with byte-sized groups (the TLAS's instance masks), read where they lie.
[[nodiscard]] Bvh build_grouped_bvh(std::span<const Aabb> prim_boxes, std::span<const std::uint8_t> group_of,
                                    const BvhBuildSettings& settings = {});

namespace detail {
// The builder's binning arithmetic, for its test (docs/simd.md). bin_of: the bin of centroid coordinate c
// on an axis whose centroid bounds start at lo, `scale` bins per unit, clamped to [0, kBins) (the
// definition, scalar). box_bins: the bins of a box's centroid on the three axes at once, in lanes, as the
// builder's binning loop computes them; the same as bin_of on each axis.
[[nodiscard]] int bin_of(float c, float lo, float scale);
[[nodiscard]] std::array<int, 3> box_bins(const Aabb& box, const glm::vec3& lo, const glm::vec3& scale);
}  // namespace detail

}  // namespace smoketrace
