#pragma once
// The least-area cut of a binary BVH into wide nodes: which binary inner nodes a W-wide tree is made from
// and which binary nodes fill each wide node's slots. Both wide trees use it: the mesh BLAS's
// (blas_wide_bvh.hpp) and the top level's (wide_bvh.hpp).
#include <smoketrace/accel/bvh.hpp>

#include <cstdint>
#include <limits>
#include <memory>
#include <utility>

namespace smoketrace {

// The cut of the binary tree into wide nodes of least total box area: the SAH cost of the wide tree, whose
// leaves are the binary leaves whatever the cut (so their cost is the same for every cut) and whose inner
// nodes each cost one visit to a ray that enters their box. Bottom-up dynamic programming over the binary
// tree (after Ylitie, Karras and Laine, "Efficient incoherent ray traversal on GPUs through compressed wide
// BVHs", 2017): for each binary inner node i and k = 1 … W, the least area of the wide nodes needed to hang
// i's subtree in at most k slots of its parent, either i as one slot (a wide node of its own, whose W slots
// are shared out between its two children) or i's two children sharing the k slots.
template <unsigned W>
class WideCut {
public:
    explicit WideCut(const Bvh& binary) : binary_(binary), cost_(new Costs[binary.nodes.size()]) {
        // Depth-first layout: children after their parent, so one backward sweep sees them first.
        for (std::size_t i = binary.nodes.size(); i-- > 0;) {
            const BvhNode& b = binary.nodes[i];
            if ((i == 1 && binary.nodes.size() > 1) || b.is_leaf()) continue;
            float shared[W];
            share(b, shared);
            // Ties go to sharing: a wide node fewer for the same cost.
            const float own = b.bounds.area() + shared[W - 1];
            Costs& c = cost_[i];
            c[0] = own;
            for (unsigned q = 1; q < W; ++q) c[q] = shared[q] <= own ? shared[q] : own;
        }
    }

    // The slots of the wide node made from binary node `node`, in the binary tree's left-right order; returns
    // their count. A leaf (a lone leaf root) is its own one slot.
    unsigned slots(std::uint32_t node, std::uint32_t* out) const {
        const BvhNode& b = binary_.nodes[node];
        if (b.is_leaf()) {
            out[0] = node;
            return 1;
        }
        unsigned n = 0;
        const unsigned j = left_share(b, W).second;
        emit(b.first, j, out, n);
        emit(b.first + 1, W - j, out, n);
        return n;
    }

private:
    using Costs = float[W];  // [k − 1]: the least cost of a subtree in at most k slots

    // A node's costs in 1 … W slots; a leaf is one slot and costs nothing.
    void costs(std::uint32_t node, float* c) const {
        const bool leaf = binary_.nodes[node].is_leaf();
        for (unsigned q = 0; q < W; ++q) c[q] = leaf ? 0.0f : cost_[node][q];
    }

    // shared[q]: the least cost of inner node b's two children sharing q + 1 slots (+∞ for one slot). Lane
    // by lane over q, for each split j (the left child's slots) in turn, the right child's costs read
    // shifted by j with +∞ where it would get no slot: a loop the compiler vectorises.
    void share(const BvhNode& b, float* shared) const {
        constexpr float inf = std::numeric_limits<float>::infinity();
        float left[W], right[2 * W];
        costs(b.first, left);
        for (unsigned q = 0; q < W; ++q) right[q] = inf;
        costs(b.first + 1, right + W);
        for (unsigned q = 0; q < W; ++q) shared[q] = inf;
        for (unsigned j = 1; j < W; ++j)
            for (unsigned q = 0; q < W; ++q) {
                const float c = left[j - 1] + right[W + q - j];
                shared[q] = c < shared[q] ? c : shared[q];
            }
    }

    // The least cost of b's children sharing k ≥ 2 slots and the first split j that reaches it, the same sums
    // as share(): the choices are found again for the few (node, k) a cut uses rather than kept for all.
    std::pair<float, unsigned> left_share(const BvhNode& b, unsigned k) const {
        float left[W], right[W];
        costs(b.first, left);
        costs(b.first + 1, right);
        std::pair<float, unsigned> best{std::numeric_limits<float>::infinity(), 1};
        for (unsigned j = 1; j < k; ++j)
            if (const float c = left[j - 1] + right[k - j - 1]; c < best.first) best = {c, j};
        return best;
    }

    // Appends the slots of `node`'s subtree in at most k slots (recursion no deeper than k).
    void emit(std::uint32_t node, unsigned k, std::uint32_t* out, unsigned& n) const {
        const BvhNode& b = binary_.nodes[node];
        if (k > 1 && !b.is_leaf()) {
            const auto [c, j] = left_share(b, k);
            if (c <= cost_[node][0]) {
                emit(b.first, j, out, n);
                emit(b.first + 1, k - j, out, n);
                return;
            }
        }
        out[n++] = node;
    }

    const Bvh& binary_;
    std::unique_ptr<Costs[]> cost_;  // per binary node; a leaf's entry is unused
};

}  // namespace smoketrace
