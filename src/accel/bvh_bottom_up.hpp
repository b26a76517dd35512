#pragma once
// Children before parents over a binary BVH, in parallel, with a sum whose bits do not depend on the thread
// count: the refit of the TLAS, its masks and SAH cost (accel_scene.cpp), Bvh::sah_cost() and the wide cut's
// costs (wide_cut.hpp) all run on it.
//
// The layout makes it cheap (bvh.hpp): a node's descendants are one stretch of the array, from its pair to
// the end of its subtree. A subtree of at most kSerialSweepNodes nodes is one backward pass over its stretch
// (sequential memory, the children of each node already done); a larger one's two subtrees are swept by two
// tasks, then its root. The values are added in that fixed shape, so a tree of at most kSerialSweepNodes
// nodes sums in plain backward array order.
#include <smoketrace/accel/bvh.hpp>

#include <tbb/parallel_invoke.h>

#include <cstdint>

namespace smoketrace {

// Large enough that a task's work dwarfs its scheduling, small enough that a 10^6-node tree makes dozens.
inline constexpr std::uint32_t kSerialSweepNodes = 1u << 14;

namespace detail {

// One past the last descendant of inner node `node`: the end of the stretch of its last inner descendant
// on the right.
inline std::uint32_t descendants_end(const Bvh& bvh, std::uint32_t node) {
    for (;;) {
        const std::uint32_t pair = bvh.nodes[node].first;
        if (!bvh.nodes[pair + 1].is_leaf()) {
            node = pair + 1;
        } else if (!bvh.nodes[pair].is_leaf()) {
            node = pair;
        } else {
            return pair + 2;
        }
    }
}

template <class Visit>
double sweep_subtree(const Bvh& bvh, std::uint32_t node, Visit& visit) {
    if (bvh.nodes[node].is_leaf()) return visit(node);
    const std::uint32_t pair = bvh.nodes[node].first;
    const std::uint32_t end = descendants_end(bvh, node);
    if (end - pair <= kSerialSweepNodes) {
        double sum = 0.0;
        for (std::uint32_t k = end; k-- > pair;) sum += visit(k);
        return sum + visit(node);
    }
    double left = 0.0, right = 0.0;
    tbb::parallel_invoke([&] { left = sweep_subtree(bvh, pair, visit); },
                         [&] { right = sweep_subtree(bvh, pair + 1, visit); });
    return (right + left) + visit(node);
}

}  // namespace detail

// visit(k) -> double for every node k but the padding slot, each after both its children (from several
// threads at once: visit may write node k and whatever is k's own, and read k's descendants); returns the
// sum of the values.
template <class Visit>
double sweep_bottom_up(const Bvh& bvh, Visit&& visit) {
    if (bvh.nodes.empty()) return 0.0;
    return detail::sweep_subtree(bvh, 0, visit);
}

}  // namespace smoketrace
