// Collapsing a binary BVH into a 4-wide one, and refitting it from the binary tree (see wide_bvh.hpp).
#include <smoketrace/accel/wide_bvh.hpp>
#include <smoketrace/accel/wide_cut.hpp>

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

    // Depth first, with an explicit list of (binary node, wide node to fill) so that the recursion
    // depth of the binary tree (≤ kMaxBvhDepth) costs no native stack.
    struct Job {
        std::uint32_t binary;
        std::uint32_t wide;
    };
    std::vector<Job> jobs{{0u, 0u}};
    // Every wide node but a lone leaf root opens at least one binary inner node, and a binary tree of
    // m nodes has at most (m − 1) / 2 of them: room for all, so that the arrays never move while growing.
    const std::size_t most = (binary.node_count() - 1) / 2 + 1;
    nodes_.reserve(most);
    source_.reserve(most * kWideBvhWidth);
    nodes_.emplace_back();
    source_.resize(kWideBvhWidth, kUnused);
    while (!jobs.empty()) {
        const Job job = jobs.back();
        jobs.pop_back();
        std::uint32_t slot[kWideBvhWidth];
        const unsigned n = cut.slots(job.binary, slot);

        WideBvhNode w{};
        w.axis = static_cast<std::uint8_t>(order_slots(binary, slot, n));
        for (unsigned i = 0; i < kWideBvhWidth; ++i) set_slot(w, i, Aabb{}, 0);  // empty: every ray misses
        for (unsigned i = 0; i < n; ++i) {
            const BvhNode& c = binary.nodes[slot[i]];
            set_slot(w, i, c.bounds, node_masks[slot[i]]);
            source_[std::size_t(job.wide) * kWideBvhWidth + i] = slot[i];
            if (c.is_leaf()) {
                if (c.count > 255) throw std::length_error("WideBvh: a leaf of more than 255 primitives");
                w.child[i] = c.first;
                w.count[i] = static_cast<std::uint8_t>(c.count);
                w.leaves |= std::uint8_t(1u << i);
            } else {
                __builtin_prefetch(&binary.nodes[c.first]);  // its children: what cutting it reads first
                w.child[i] = static_cast<std::uint32_t>(nodes_.size());
                w.count[i] = 0;
                jobs.push_back({slot[i], w.child[i]});
                nodes_.emplace_back();
                source_.resize(source_.size() + kWideBvhWidth, kUnused);
            }
        }
        nodes_[job.wide] = w;
    }
}

void WideBvh::refit(const Bvh& binary, const std::vector<std::uint8_t>& node_masks) {
    if (binary.nodes.empty()) return;
    root_mask_ = node_masks[0];
    // The binary nodes a wide node copies lie anywhere in the binary array: fetched kPrefetch wide nodes
    // ahead, their misses overlap.
    constexpr std::size_t kPrefetch = 8;
    for (std::size_t k = 0; k < nodes_.size(); ++k) {
        if (k + kPrefetch < nodes_.size())
            for (unsigned i = 0; i < kWideBvhWidth; ++i) {
                const std::uint32_t s = source_[(k + kPrefetch) * kWideBvhWidth + i];
                if (s != kUnused) __builtin_prefetch(&binary.nodes[s]);
            }
        for (unsigned i = 0; i < kWideBvhWidth; ++i) {
            const std::uint32_t s = source_[k * kWideBvhWidth + i];
            if (s != kUnused) set_slot(nodes_[k], i, binary.nodes[s].bounds, node_masks[s]);
        }
    }
}

}  // namespace smoketrace
