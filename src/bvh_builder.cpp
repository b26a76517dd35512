// Binned SAH BVH construction (see bvh_builder.hpp for the policy).
#include <smoketrace/bvh_builder.hpp>

#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>
#include <tbb/blocked_range.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <limits>
#include <stdexcept>

namespace smoketrace {
namespace {

constexpr int kBins = BvhBuildSettings::kBins;

// Building happens in a scratch tree whose slots are reserved per subtree (a node over n primitives
// owns 2n − 2 descendant slots), so parallel subtrees never share a counter; the scratch tree is then
// compacted depth-first into the final node array.
struct Builder {
    std::span<const Aabb> boxes;
    std::vector<glm::vec3> centroids;
    std::vector<std::uint32_t>& prims;
    std::vector<BvhNode> scratch;
    BvhBuildSettings settings;

    struct Bin {
        Aabb bounds;
        std::uint32_t count = 0;
    };
    struct Binning {
        std::array<std::array<Bin, kBins>, 3> bins{};
    };
    struct Split {
        int axis = -1;
        int bin = 0;  // primitives in bins [0, bin] go left
        float cost = std::numeric_limits<float>::infinity();
    };

    Aabb range_bounds(std::uint32_t begin, std::uint32_t end, Aabb& centroid_bounds) const {
        auto body = [&](const tbb::blocked_range<std::uint32_t>& r, std::pair<Aabb, Aabb> acc) {
            for (std::uint32_t i = r.begin(); i < r.end(); ++i) {
                acc.first.grow(boxes[prims[i]]);
                acc.second.grow(centroids[prims[i]]);
            }
            return acc;
        };
        auto join = [](std::pair<Aabb, Aabb> a, const std::pair<Aabb, Aabb>& b) {
            a.first.grow(b.first);
            a.second.grow(b.second);
            return a;
        };
        std::pair<Aabb, Aabb> result;
        if (end - begin >= settings.parallel_threshold * 4) {
            result = tbb::parallel_reduce(tbb::blocked_range<std::uint32_t>(begin, end, 8192), result, body, join);
        } else {
            result = body(tbb::blocked_range<std::uint32_t>(begin, end), result);
        }
        centroid_bounds = result.second;
        return result.first;
    }

    static int bin_of(float c, float lo, float scale) {
        const int b = static_cast<int>((c - lo) * scale);
        return std::clamp(b, 0, kBins - 1);
    }

    Binning bin_range(std::uint32_t begin, std::uint32_t end, const Aabb& cb) const {
        glm::vec3 scale;
        for (int a = 0; a < 3; ++a) {
            const float e = cb.hi[a] - cb.lo[a];
            scale[a] = e > 0.0f ? float(kBins) / e : 0.0f;
        }
        auto body = [&](const tbb::blocked_range<std::uint32_t>& r, Binning acc) {
            for (std::uint32_t i = r.begin(); i < r.end(); ++i) {
                const std::uint32_t p = prims[i];
                for (int a = 0; a < 3; ++a) {
                    Bin& bin = acc.bins[a][bin_of(centroids[p][a], cb.lo[a], scale[a])];
                    bin.bounds.grow(boxes[p]);
                    ++bin.count;
                }
            }
            return acc;
        };
        auto join = [](Binning a, const Binning& b) {
            for (int ax = 0; ax < 3; ++ax)
                for (int i = 0; i < kBins; ++i) {
                    a.bins[ax][i].bounds.grow(b.bins[ax][i].bounds);
                    a.bins[ax][i].count += b.bins[ax][i].count;
                }
            return a;
        };
        if (end - begin >= settings.parallel_threshold * 4)
            return tbb::parallel_reduce(tbb::blocked_range<std::uint32_t>(begin, end, 8192), Binning{}, body, join);
        return body(tbb::blocked_range<std::uint32_t>(begin, end), Binning{});
    }

    // Sweeps the bins of each axis: SAH cost of splitting after bin i, relative to the parent area.
    Split best_split(const Binning& binning, float parent_area) const {
        Split best;
        for (int a = 0; a < 3; ++a) {
            const auto& bins = binning.bins[a];
            std::array<float, kBins - 1> left_cost{};
            Aabb acc;
            std::uint32_t n = 0;
            for (int i = 0; i < kBins - 1; ++i) {
                acc.grow(bins[i].bounds);
                n += bins[i].count;
                left_cost[i] = acc.area() * float(n);
            }
            acc = Aabb{};
            n = 0;
            for (int i = kBins - 1; i > 0; --i) {
                acc.grow(bins[i].bounds);
                n += bins[i].count;
                const float cost = settings.costs.traversal +
                                   settings.costs.intersection * (left_cost[i - 1] + acc.area() * float(n)) / parent_area;
                if (cost < best.cost) best = {a, i - 1, cost};
            }
        }
        return best;
    }

    // Object-median split along the widest centroid axis (ties broken by primitive index, so the
    // result is the same on every platform). Used when no SAH split exists or depth would overflow.
    std::uint32_t median_split(std::uint32_t begin, std::uint32_t end, const Aabb& cb) {
        const glm::vec3 e = cb.extent();
        const int axis = (e.x >= e.y && e.x >= e.z) ? 0 : (e.y >= e.z ? 1 : 2);
        const std::uint32_t mid = begin + (end - begin) / 2;
        std::nth_element(prims.begin() + begin, prims.begin() + mid, prims.begin() + end,
                         [&](std::uint32_t a, std::uint32_t b) {
                             const float ca = centroids[a][axis], cb2 = centroids[b][axis];
                             return ca < cb2 || (ca == cb2 && a < b);
                         });
        return mid;
    }

    void make_leaf(std::uint32_t node, std::uint32_t begin, std::uint32_t end) {
        scratch[node].first = begin;
        scratch[node].count = end - begin;
    }

    // Builds the subtree of scratch[node] over prims[begin, end); its descendants go to the slots
    // starting at `slots` (2·(end − begin) − 2 of them, an even offset so pairs stay aligned).
    void build(std::uint32_t node, std::uint32_t begin, std::uint32_t end, std::uint32_t slots, int depth) {
        const std::uint32_t n = end - begin;
        Aabb cb;
        scratch[node].bounds = range_bounds(begin, end, cb);
        if (n == 1) return make_leaf(node, begin, end);

        // Levels still needed if every later split halved the count exactly; past the budget, halve.
        const int levels_needed = std::bit_width(n - 1);
        const bool must_halve = depth + levels_needed >= kMaxBvhDepth - 1;

        std::uint32_t mid = begin;
        if (!must_halve) {
            const Binning binning = bin_range(begin, end, cb);
            const float area = scratch[node].bounds.area();
            const Split split = area > 0.0f ? best_split(binning, area) : Split{};
            const float leaf_cost = settings.costs.intersection * float(n);
            if (n <= settings.max_leaf_size && !(split.cost < leaf_cost)) return make_leaf(node, begin, end);
            if (split.axis >= 0 && cb.hi[split.axis] > cb.lo[split.axis]) {
                const int a = split.axis;
                const float lo = cb.lo[a];
                const float scale = float(kBins) / (cb.hi[a] - lo);
                mid = static_cast<std::uint32_t>(
                    std::partition(prims.begin() + begin, prims.begin() + end,
                                   [&](std::uint32_t p) { return bin_of(centroids[p][a], lo, scale) <= split.bin; }) -
                    prims.begin());
            }
        }
        if (mid == begin || mid == end) {
            if (n <= settings.max_leaf_size && !must_halve) return make_leaf(node, begin, end);
            mid = median_split(begin, end, cb);
        }

        const std::uint32_t left = slots, right = slots + 1;
        scratch[node].first = left;
        scratch[node].count = 0;
        const std::uint32_t left_slots = slots + 2;
        const std::uint32_t right_slots = left_slots + 2 * (mid - begin) - 2;
        if (n >= settings.parallel_threshold) {
            tbb::parallel_invoke([&] { build(left, begin, mid, left_slots, depth + 1); },
                                 [&] { build(right, mid, end, right_slots, depth + 1); });
        } else {
            build(left, begin, mid, left_slots, depth + 1);
            build(right, mid, end, right_slots, depth + 1);
        }
    }
};

// Depth-first compaction of the scratch tree: the root at 0, padding at 1, then each node's pair.
void compact(const std::vector<BvhNode>& scratch, Bvh& out) {
    out.nodes.clear();
    out.nodes.reserve(scratch.size());
    out.nodes.push_back(scratch[0]);
    out.nodes.push_back(BvhNode{});  // padding: pairs start at an even index
    struct Item {
        std::uint32_t src, dst;
    };
    std::vector<Item> stack{{0u, 0u}};
    while (!stack.empty()) {
        const Item it = stack.back();
        stack.pop_back();
        BvhNode& dst = out.nodes[it.dst];
        if (dst.is_leaf()) continue;
        const std::uint32_t src_left = scratch[it.src].first;
        const auto pair = static_cast<std::uint32_t>(out.nodes.size());
        out.nodes.push_back(scratch[src_left]);
        out.nodes.push_back(scratch[src_left + 1]);
        out.nodes[it.dst].first = pair;
        // Right first on the stack so the left subtree is laid out next (depth-first, left first).
        stack.push_back({src_left + 1, pair + 1});
        stack.push_back({src_left, pair});
    }
}

}  // namespace

Bvh build_bvh(std::span<const Aabb> prim_boxes, const BvhBuildSettings& settings) {
    Bvh bvh;
    if (prim_boxes.empty()) return bvh;
    if (prim_boxes.size() >= std::numeric_limits<std::uint32_t>::max() / 2)
        throw std::length_error("build_bvh: too many primitives");
    const auto n = static_cast<std::uint32_t>(prim_boxes.size());
    bvh.prim_indices.resize(n);
    for (std::uint32_t i = 0; i < n; ++i) bvh.prim_indices[i] = i;

    Builder b{prim_boxes, {}, bvh.prim_indices, {}, settings};
    b.settings.max_leaf_size = std::max(1u, settings.max_leaf_size);
    b.centroids.resize(n);
    for (std::uint32_t i = 0; i < n; ++i) {
        if (prim_boxes[i].empty()) throw std::invalid_argument("build_bvh: empty primitive box");
        b.centroids[i] = prim_boxes[i].center();
    }
    b.scratch.resize(2 * std::size_t(n));  // root + 2n − 2 descendants (+1 spare)
    b.build(0, 0, n, 2, 0);
    compact(b.scratch, bvh);
    return bvh;
}

}  // namespace smoketrace
