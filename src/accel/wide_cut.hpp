#pragma once
// The least-area cut of a binary BVH into wide nodes: which binary inner nodes a W-wide tree is made from
// and which binary nodes fill each wide node's slots. Both wide trees use it: the mesh BLAS's
// (blas_wide_bvh.hpp) and the top level's (wide_bvh.hpp).
#include <smoketrace/accel/bvh.hpp>
#include "bvh_bottom_up.hpp"

#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

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
    // The costs are left unwritten by the allocation: the sweep's own (parallel) writes touch their pages first.
    explicit WideCut(const Bvh& binary) : binary_(binary), cost_(new Costs[binary.nodes.size()]) {
        sweep_bottom_up(binary, [&](std::uint32_t i) {
            const BvhNode& b = binary.nodes[i];
            if (b.is_leaf()) return 0.0;
            float shared[W];
            share(b, shared);
            // Ties go to sharing: a wide node fewer for the same cost.
            const float own = b.bounds.area() + shared[W - 1];
            Costs& c = cost_[i];
            c[0] = own;
            for (unsigned q = 1; q < W; ++q) c[q] = shared[q] <= own ? shared[q] : own;
            return 0.0;
        });
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

// Lays out the wide tree of `cut` as one depth-first work list would (a node's inner children side by side,
// appended when it is made; the last child's subtree first), the large subtrees' stretches filled in
// parallel: the same array at any thread count. allocate(count) sizes the array for `count` wide nodes (on
// one thread: first for at most one per binary inner node, and to the count at the end, a shrink); then
// make(wide, slot, n, axis, child) once for every wide node (from several threads at once): the
// wide node `wide` has n slots, the binary nodes slot[0 … n) in the order of order_slots() (bvh.hpp) along
// `axis`, and child[i] is the wide node of slot i where that is an inner node.
template <unsigned W, class Allocate, class Make>
void lay_out_wide_tree(const Bvh& binary, const WideCut<W>& cut, Allocate&& allocate, Make&& make) {
    struct Job {
        std::uint32_t binary, wide;
    };
    // A subtree whose binary stretch fits one sweep task is laid out by one task, the rest by the list below.
    auto one_task = [&](std::uint32_t b) {
        const BvhNode& n = binary.nodes[b];
        return n.is_leaf() || detail::descendants_end(binary, b) - n.first <= kSerialSweepNodes;
    };
    // A wide node's slots, ordered (its children are numbered in that order); returns its inner children.
    // Counting needs no order.
    auto children = [&](std::uint32_t b, std::uint32_t* slot, unsigned& n, int& axis, bool order = true) {
        n = cut.slots(b, slot);
        axis = order ? order_slots(binary, slot, n) : 0;
        unsigned inner = 0;
        for (unsigned i = 0; i < n; ++i) inner += binary.nodes[slot[i]].is_leaf() ? 0u : 1u;
        return inner;
    };
    // The work list over one task's subtree, its nodes' children from `next` on; returns past the last.
    auto lay_out_subtree = [&](Job root, std::uint32_t next, bool write) {
        std::vector<Job> jobs{root};
        while (!jobs.empty()) {
            const Job job = jobs.back();
            jobs.pop_back();
            std::uint32_t slot[W], child[W];
            unsigned n;
            int axis;
            children(job.binary, slot, n, axis, write);
            for (unsigned i = 0; i < n; ++i)
                if (!binary.nodes[slot[i]].is_leaf()) {
                    child[i] = next++;
                    jobs.push_back({slot[i], child[i]});
                }
            if (write) make(job.wide, slot, n, axis, child);
        }
        return next;
    };

    // One thread, or a tree one task lays out: the work list alone, with no sizing pass (its work would be
    // spent for nothing).
    const std::size_t threads = std::min<std::size_t>(
        std::size_t(tbb::this_task_arena::max_concurrency()),
        tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
    if (threads == 1 || one_task(0)) {
        allocate((binary.node_count() - 1) / 2 + 1);
        allocate(std::size_t{lay_out_subtree({0u, 0u}, 1, true)});
        return;
    }

    // The top of the tree, serially, in the work list's order: its own nodes, and the subtrees left to tasks,
    // each with where its nodes' children start (after sizing them all in parallel).
    struct Top {
        Job job;
        std::uint32_t first_child;  // subtrees: where its nodes' children start
        bool subtree;
    };
    std::vector<Top> top;
    std::vector<std::uint32_t> sizes;  // per subtree in `top`'s order: its wide nodes below its root
    {
        std::vector<Job> jobs{{0u, 0u}};
        while (!jobs.empty()) {
            const Job job = jobs.back();
            jobs.pop_back();
            if (one_task(job.binary)) {
                top.push_back({job, 0, true});
                continue;
            }
            std::uint32_t slot[W];
            unsigned n;
            int axis;
            children(job.binary, slot, n, axis);
            top.push_back({job, 0, false});
            for (unsigned i = 0; i < n; ++i)
                if (!binary.nodes[slot[i]].is_leaf()) jobs.push_back({slot[i], 0});
        }
    }
    std::vector<std::uint32_t> subtree_at;  // indices into `top` of the subtrees
    for (std::uint32_t t = 0; t < top.size(); ++t)
        if (top[t].subtree) subtree_at.push_back(t);
    sizes.resize(subtree_at.size());
    tbb::parallel_for(std::size_t{0}, subtree_at.size(), [&](std::size_t s) {
        sizes[s] = lay_out_subtree(top[subtree_at[s]].job, 0, false);
    });
    // Numbered as the work list numbers them: a node's inner children when it is made; a subtree's nodes
    // after its root, in one stretch. The top nodes are met in the same order as above.
    std::uint32_t next = 1;
    {
        std::size_t t = 0, s = 0;
        std::vector<std::uint32_t> wide_of{0u};  // the list's pending wide indices, as a stack
        while (!wide_of.empty()) {
            const std::uint32_t wide = wide_of.back();
            wide_of.pop_back();
            Top& item = top[t++];
            item.job.wide = wide;
            item.first_child = next;
            if (item.subtree) {
                next += sizes[s++];
                continue;
            }
            std::uint32_t slot[W];
            unsigned n;
            int axis;
            next += children(item.job.binary, slot, n, axis);
            for (std::uint32_t c = item.first_child; c < next; ++c) wide_of.push_back(c);
        }
    }
    allocate(std::size_t{next});
    tbb::parallel_for(std::size_t{0}, top.size(), [&](std::size_t t) {
        const Top& item = top[t];
        if (item.subtree) {
            lay_out_subtree(item.job, item.first_child, true);
            return;
        }
        std::uint32_t slot[W], child[W];
        unsigned n;
        int axis;
        children(item.job.binary, slot, n, axis);
        std::uint32_t c = item.first_child;
        for (unsigned i = 0; i < n; ++i)
            if (!binary.nodes[slot[i]].is_leaf()) child[i] = c++;
        make(item.job.wide, slot, n, axis, child);
    });
}

}  // namespace smoketrace
