#pragma once
// Contract: lane by lane traverse_wide_bvh() (wide_bvh_traversal.hpp), so each lane reaches the leaves
// textbook::walk_bvh would; tests/test_textbook_trace.cpp, through trace_bundle().
// The walk of a 4-wide BVH (wide_bvh.hpp) for a ray bundle (ray_bundle.hpp): the top level's walk in
// trace_bundle(). A node is visited once for every lane that entered it; each of its children (masks
// first, as in wide_bvh_traversal.hpp) is box-tested for those lanes at once, and a child is entered
// with the lanes whose rays meet its box.
//
// Lane by lane the same walk as traverse_wide_bvh(): the same box test with the same roundings (so a
// lane enters exactly the nodes its ray alone would enter, given the same tmax), children in the ray's
// order along each node's axis, leaves first. The per-lane counters therefore equal a single ray's when
// nothing is committed.
#include <smoketrace/geometry/aabb.hpp>
#include <smoketrace/accel/bvh_traversal.hpp>
#include <smoketrace/geometry/ray_bundle.hpp>
#include <smoketrace/core/simd/lanes.hpp>
#include <smoketrace/accel/wide_bvh.hpp>
#include <smoketrace/accel/wide_bvh_traversal.hpp>

#include <bit>
#include <cstdint>

namespace smoketrace {

// Per-lane walk counters (TraversalStats for each ray of the bundle).
struct BundleStats {
    alignas(64) std::uint32_t nodes_visited[kBundleWidth] = {};
    alignas(64) std::uint32_t boxes_tested[kBundleWidth] = {};
};

// One child box of a wide node against every ray of a bundle: bit i of the result set when lane i's ray
// meets the box in [tmin_i, tmax_i]. Lane by lane exactly intersect() of aabb.hpp: the shared direction
// gives every lane the same reciprocal and near / far planes, and max / min keep the accumulator (their
// second operand) where a slab distance is NaN, as the scalar test does. Written over lanes of floats
// (core/simd/lanes.hpp): sixteen per AVX-512 operation, eight per AVX2 one, one at a time without.
class BundleBoxTest {
    using Floats = simd::Floats<simd::kFloatLanes>;

public:
    static constexpr unsigned kBlocks = kBundleWidth / simd::kFloatLanes;  // one register of lanes each

    explicit BundleBoxTest(const RayBundle& b) : shared_(Ray{glm::vec3(0.0f), 0.0f, b.direction, 0.0f}) {
        for (unsigned k = 0; k < kBlocks; ++k) {
            origin_[0][k] = Floats::load(b.x + simd::kFloatLanes * k);
            origin_[1][k] = Floats::load(b.y + simd::kFloatLanes * k);
            origin_[2][k] = Floats::load(b.z + simd::kFloatLanes * k);
            tmin_[k] = Floats::load(b.tmin + simd::kFloatLanes * k);
        }
        for (int a = 0; a < 3; ++a) {
            inv_dir_[a] = Floats::broadcast(shared_.inv_dir[a]);
            inv_far_[a] = Floats::broadcast(shared_.inv_far[a]);
        }
    }

    // The plane index entered first on axis a, shared by every lane (BoxRay::near).
    [[nodiscard]] int near_plane(int a) const { return shared_.near[a]; }

    struct FarLimits {
        Floats block[kBlocks];
    };
    // `far`: each lane's tmax · kSlabFarScale (far_limits()).
    [[gnu::always_inline]] unsigned test(const WideBvhNode& n, unsigned slot, const FarLimits& far) const {
        Floats near_plane[3], far_plane[3];
        for (int a = 0; a < 3; ++a) {
            near_plane[a] = Floats::broadcast(n.bounds[shared_.near[a]][slot]);
            far_plane[a] = Floats::broadcast(n.bounds[shared_.far[a]][slot]);
        }
        unsigned hits = 0;
#pragma GCC unroll 4
        for (unsigned k = 0; k < kBlocks; ++k) {
            Floats t0 = tmin_[k], t1 = far.block[k];
#pragma GCC unroll 3
            for (int a = 0; a < 3; ++a) {
                t0 = max((near_plane[a] - origin_[a][k]) * inv_dir_[a], t0);
                t1 = min((far_plane[a] - origin_[a][k]) * inv_far_[a], t1);
            }
            hits |= bits(t0 <= t1) << (simd::kFloatLanes * k);
        }
        return hits;
    }
    [[gnu::always_inline]] static FarLimits far_limits(const float* tmax) {
        FarLimits f;
        for (unsigned k = 0; k < kBlocks; ++k)
            f.block[k] = Floats::load(tmax + simd::kFloatLanes * k) * Floats::broadcast(kSlabFarScale);
        return f;
    }

private:
    BoxRay shared_;  // the direction's part of the slab test
    Floats origin_[3][kBlocks], inv_dir_[3], inv_far_[3], tmin_[kBlocks];
};

// Adds `times` to the counter of every lane in `lanes` (kBundleWidth counters, 64-byte aligned).
[[gnu::always_inline]] inline void count_lanes(std::uint32_t* counters, unsigned lanes, unsigned times = 1) {
    using UInts = simd::UInts<simd::kUIntLanes>;
    using Mask = simd::Mask<std::uint32_t, simd::kUIntLanes>;
    for (unsigned k = 0; k < kBundleWidth / simd::kUIntLanes; ++k) {
        std::uint32_t* at = counters + simd::kUIntLanes * k;
        const Mask in = Mask::from_bits(lanes >> (simd::kUIntLanes * k));
        store(at, masked_add(UInts::load(at), in, UInts::broadcast(times)));
    }
}

// Calls leaf(first, count, lanes) for every leaf whose mask meets `inclusion_mask` and whose box the
// rays of `lanes` (a nonzero subset of `live`) enter before their tmax. `tmax` (kBundleWidth floats,
// 64-byte aligned) and `live` (the lanes still searching) are read at every step, so a leaf callback
// that commits a hit or ends a lane's search narrows the walk at once. The walk ends when no lane is
// live or every node has been visited.
template <class LeafFn>
inline void traverse_wide_bvh_bundle(const WideBvh& bvh, const BundleBoxTest& box_test, const float* tmax,
                                     const unsigned& live, std::uint8_t inclusion_mask, LeafFn&& leaf,
                                     BundleStats& stats) {
    if (bvh.empty() || (bvh.root_mask() & inclusion_mask) == 0 || live == 0) return;
    const WideBvhNode* nodes = bvh.nodes();
    unsigned flip_of_axis[3];
    for (int a = 0; a < 3; ++a) flip_of_axis[a] = box_test.near_plane(a) == a + 3 ? 3u : 0u;

    struct Entry {
        std::uint32_t node;
        unsigned lanes;
    };
    // Each node pushes at most its width and pops one before the next push; one more slot takes the
    // write of a child that is not kept (see below).
    Entry stack[kWideBvhWidth * kMaxBvhDepth + 1];
    int sp = 0;
    Entry e{0, live};
    for (;;) {
        const WideBvhNode& n = nodes[e.node];
        count_lanes(stats.nodes_visited, e.lanes);
        const unsigned admitted = admitted_children(n, inclusion_mask);
        count_lanes(stats.boxes_tested, e.lanes, unsigned(std::popcount(admitted)));
        const auto far = BundleBoxTest::far_limits(tmax);
        // Every child slot is tested and masked, without a branch on which ones are admitted or entered:
        // those are data, different from node to node and bundle to bundle, and as branches they were
        // the walk's main mispredictions. (An unused slot's empty box is never entered.)
        unsigned enter[kWideBvhWidth];
        unsigned entered = 0;  // bit per slot
#pragma GCC unroll 4
        for (unsigned slot = 0; slot < kWideBvhWidth; ++slot) {
            enter[slot] = box_test.test(n, slot, far) & e.lanes & (0u - ((admitted >> slot) & 1u));
            entered |= unsigned(enter[slot] != 0) << slot;
        }
        // The children in the ray's order along the node's axis (as in traverse_wide_bvh): the j-th along
        // the ray is slot j ^ flip. Leaves first, each visited with the lanes still live.
        const unsigned flip = flip_of_axis[n.axis];
        auto in_ray_order = [&](unsigned set) { return flip != 0 ? unsigned(kReversedSlots[set]) : set; };
        for (unsigned m = in_ray_order(entered & n.leaves); m != 0; m &= m - 1) {
            const unsigned slot = unsigned(std::countr_zero(m)) ^ flip;
            const unsigned lanes = enter[slot] & live;  // a leaf before may have ended lanes
            if (lanes == 0) continue;
            count_lanes(stats.nodes_visited, lanes);
            leaf(n.child[slot], n.count[slot], lanes);
        }
        // Inner children pushed last along the ray first, so that the first pops next. Each is written
        // and kept by advancing the stack pointer only if lanes enter it: no branch.
        const unsigned inner = entered & ~unsigned(n.leaves);
#pragma GCC unroll 4
        for (int j = int(kWideBvhWidth) - 1; j >= 0; --j) {
            const unsigned slot = unsigned(j) ^ flip;
            const unsigned lanes = enter[slot] & live & (0u - ((inner >> slot) & 1u));
            stack[sp] = Entry{n.child[slot], lanes};
            sp += lanes != 0;
        }
        // The next entry with a live lane.
        for (;;) {
            if (sp == 0) return;
            e = stack[--sp];
            e.lanes &= live;
            if (e.lanes != 0) break;
        }
    }
}

}  // namespace smoketrace
