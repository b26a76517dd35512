// Bvh queries and refit (see bvh.hpp).
#include <smoketrace/accel/bvh.hpp>
#include "bvh_bottom_up.hpp"

#include <algorithm>
#include <stdexcept>

namespace smoketrace {

std::size_t Bvh::node_count() const { return nodes.size() > 1 ? nodes.size() - 1 : nodes.size(); }

int Bvh::depth() const {
    if (nodes.empty()) return 0;
    // Depth-first layout: a child's index is always larger than its parent's, so one forward sweep
    // propagates depths.
    std::vector<int> d(nodes.size(), 0);
    int deepest = 0;
    for (std::size_t i = 0; i < nodes.size(); ++i) {
        if (i == 1) continue;
        deepest = std::max(deepest, d[i]);
        if (!nodes[i].is_leaf()) d[nodes[i].first] = d[nodes[i].first + 1] = d[i] + 1;
    }
    return deepest;
}

double Bvh::sah_cost(const SahCosts& costs) const {
    if (nodes.empty()) return 0.0;
    const double root_area = nodes[0].bounds.area();
    if (!(root_area > 0.0)) return costs.intersection * double(nodes[0].count);
    // Summed by sweep_bottom_up() and divided by the root's area once at the end: the order and the terms of
    // the fused refit sweep of the TLAS (AccelScene::refit_binary), so that both give the same bits.
    return sweep_bottom_up(*this, [&](std::uint32_t i) { return sah_term(nodes[i], costs); }) / root_area;
}

void Bvh::refit(std::span<const Aabb> prim_boxes) {
    sweep_bottom_up(*this, [&](std::uint32_t k) {
        BvhNode& n = nodes[k];
        Aabb b;
        if (n.is_leaf()) {
            for (std::uint32_t i = 0; i < n.count; ++i) b.grow(prim_boxes[prim_indices[n.first + i]]);
        } else {
            b = merge(nodes[n.first].bounds, nodes[n.first + 1].bounds);
        }
        n.bounds = b;
        return 0.0;
    });
}

int order_slots(const Bvh& binary, std::uint32_t* slot, unsigned n) {
    constexpr unsigned kMaxWidth = 16;
    if (n > kMaxWidth) throw std::invalid_argument("order_slots: more than 16 slots");
    Aabb centres;
    glm::vec3 centre[kMaxWidth];
    for (unsigned i = 0; i < n; ++i) {
        centre[i] = binary.nodes[slot[i]].bounds.center();
        centres.grow(centre[i]);
    }
    const glm::vec3 spread = centres.extent();
    const int axis = spread.x >= spread.y ? (spread.x >= spread.z ? 0 : 2) : (spread.y >= spread.z ? 1 : 2);
    float key[kMaxWidth];
    for (unsigned i = 0; i < n; ++i) key[i] = centre[i][axis];
    for (unsigned i = 1; i < n; ++i) {
        const std::uint32_t s = slot[i];
        const float k = key[i];
        unsigned j = i;
        for (; j > 0 && k < key[j - 1]; --j) {
            slot[j] = slot[j - 1];
            key[j] = key[j - 1];
        }
        slot[j] = s;
        key[j] = k;
    }
    return axis;
}

}  // namespace smoketrace
