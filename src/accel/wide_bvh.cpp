// Collapsing a binary BVH into a 4-wide one, and refitting it from the binary tree (see wide_bvh.hpp).
#include <smoketrace/accel/wide_bvh.hpp>
#include "wide_cut.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <stdexcept>

namespace smoketrace {

namespace {

constexpr std::uint32_t kUnused = ~0u;

void set_slot(WideBvhNode& w, unsigned i, const Aabb& b, std::uint8_t mask) {
    const float* p = planes(b);
    for (int k = 0; k < 6; ++k) w.bounds[k][i] = p[k];
    w.mask[i] = mask;
}

}  // namespace

void WideBvh::collapse(const Bvh& binary, const std::vector<std::uint8_t>& node_masks) {
    nodes_.clear();
    source_.clear();
    root_mask_ = 0;
    if (binary.nodes.empty()) return;
    root_mask_ = node_masks[0];
    const WideCut<kWideBvhWidth> cut(binary);
    lay_out_wide_tree(
        binary, cut,
        [&](std::size_t count) {
            nodes_.resize(count);
            source_.resize(count * kWideBvhWidth);
        },
        [&](std::uint32_t wide, const std::uint32_t* slot, unsigned n, int axis, const std::uint32_t* child) {
            WideBvhNode w{};
            w.axis = static_cast<std::uint8_t>(axis);
            for (unsigned i = 0; i < kWideBvhWidth; ++i) set_slot(w, i, Aabb{}, 0);  // empty: every ray misses
            std::uint32_t* source = &source_[std::size_t(wide) * kWideBvhWidth];
            for (unsigned i = 0; i < kWideBvhWidth; ++i) source[i] = kUnused;
            for (unsigned i = 0; i < n; ++i) {
                const BvhNode& c = binary.nodes[slot[i]];
                set_slot(w, i, c.bounds, node_masks[slot[i]]);
                source[i] = slot[i];
                if (c.is_leaf()) {
                    if (c.count > 255) throw std::length_error("WideBvh: a leaf of more than 255 primitives");
                    w.child[i] = c.first;
                    w.count[i] = static_cast<std::uint8_t>(c.count);
                    w.leaves |= std::uint8_t(1u << i);
                } else {
                    w.child[i] = child[i];
                    w.count[i] = 0;
                }
            }
            nodes_[wide] = w;
        });
}

void WideBvh::refit(const Bvh& binary, const std::vector<std::uint8_t>& node_masks) {
    if (binary.nodes.empty()) return;
    root_mask_ = node_masks[0];
    // Each wide node copies its own binary nodes: chunks of the array in parallel. The binary nodes a wide
    // node copies lie anywhere in the binary array: fetched kPrefetch wide nodes ahead, their misses overlap.
    constexpr std::size_t kPrefetch = 8;
    using Range = tbb::blocked_range<std::size_t>;
    tbb::parallel_for(Range(0, nodes_.size(), 4096), [&](const Range& r) {
        for (std::size_t k = r.begin(); k < r.end(); ++k) {
            if (k + kPrefetch < r.end())
                for (unsigned i = 0; i < kWideBvhWidth; ++i) {
                    const std::uint32_t s = source_[(k + kPrefetch) * kWideBvhWidth + i];
                    if (s != kUnused) __builtin_prefetch(&binary.nodes[s]);
                }
            for (unsigned i = 0; i < kWideBvhWidth; ++i) {
                const std::uint32_t s = source_[k * kWideBvhWidth + i];
                if (s != kUnused) set_slot(nodes_[k], i, binary.nodes[s].bounds, node_masks[s]);
            }
        }
    });
}

}  // namespace smoketrace
