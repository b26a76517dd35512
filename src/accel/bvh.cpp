// Bvh queries and refit (see bvh.hpp).
#include <smoketrace/accel/bvh.hpp>

#include <algorithm>

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
    // Backward, and divided by the root's area once at the end: the order and the terms of the fused
    // refit sweep of the TLAS (AccelScene::refit), so that both give the same bits.
    double weighted = 0.0;
    for (std::size_t i = nodes.size(); i-- > 0;)
        if (i != 1) weighted += sah_term(nodes[i], costs);
    return weighted / root_area;
}

void Bvh::refit(std::span<const Aabb> prim_boxes) {
    for (std::size_t k = nodes.size(); k-- > 0;) {
        if (k == 1) continue;
        BvhNode& n = nodes[k];
        Aabb b;
        if (n.is_leaf()) {
            for (std::uint32_t i = 0; i < n.count; ++i) b.grow(prim_boxes[prim_indices[n.first + i]]);
        } else {
            b = merge(nodes[n.first].bounds, nodes[n.first + 1].bounds);
        }
        n.bounds = b;
    }
}

WideSlots collapse_slots(const Bvh& binary, std::uint32_t node, unsigned width, std::uint32_t* slot) {
    unsigned n = 0;
    const BvhNode& top = binary.nodes[node];
    if (top.is_leaf()) {
        slot[n++] = node;
    } else {
        slot[n++] = top.first;
        slot[n++] = top.first + 1;
    }
    while (n < width) {
        int best = -1;
        float best_area = -1.0f;
        for (unsigned i = 0; i < n; ++i) {
            const BvhNode& c = binary.nodes[slot[i]];
            if (!c.is_leaf() && c.bounds.area() > best_area) {
                best = int(i);
                best_area = c.bounds.area();
            }
        }
        if (best < 0) break;
        const std::uint32_t opened = slot[best];
        slot[best] = binary.nodes[opened].first;
        slot[n++] = binary.nodes[opened].first + 1;
    }
    Aabb centres;
    for (unsigned i = 0; i < n; ++i) centres.grow(binary.nodes[slot[i]].bounds.center());
    const glm::vec3 spread = centres.extent();
    const int axis = spread.x >= spread.y ? (spread.x >= spread.z ? 0 : 2) : (spread.y >= spread.z ? 1 : 2);
    std::stable_sort(slot, slot + n, [&](std::uint32_t a, std::uint32_t b) {
        return binary.nodes[a].bounds.center()[axis] < binary.nodes[b].bounds.center()[axis];
    });
    return {n, axis};
}

}  // namespace smoketrace
