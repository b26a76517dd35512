// Binned SAH BVH construction (see bvh_builder.hpp for the policy).
#include <smoketrace/accel/bvh_builder.hpp>
#include <smoketrace/core/simd/lanes.hpp>

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>
#include <tbb/blocked_range.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cassert>
#include <limits>
#include <memory>
#include <type_traits>
#include <stdexcept>
#include <utility>
#include <vector>

namespace smoketrace {

int detail::bin_of(float c, float lo, float scale) {
    const int b = static_cast<int>((c - lo) * scale);
    return std::clamp(b, 0, BvhBuildSettings::kBins - 1);
}

namespace {

constexpr int kBins = BvhBuildSettings::kBins;
constexpr std::uint32_t kCopyGrain = 8192;

// A primitive as the builder moves it: its box and its index, 32 bytes, so that a node's primitives are
// one contiguous run that partitioning reorders in place (sequential memory access at every level, where
// an index into the input boxes would be a cache miss per primitive on a large mesh). lo and hi are
// each followed by a fourth float so that either loads as one 4-wide vector. The index rides in lo's
// fourth lane, where the vector arithmetic sees it as a float: stored as is, an index below 2^23 is a
// subnormal float, and every addition with it took a microcode assist. Stored with bit 30 flipped, it
// is a normal number (up to 2^30 primitives; past that only slower).
struct alignas(32) PrimRef {
    glm::vec3 lo;
    std::uint32_t id_bits;
    glm::vec3 hi;
    float unused;

    static constexpr std::uint32_t kIdFlip = 1u << 30;
    // Left uninitialised by default, so that the array of them is allocated without being written (the
    // parallel fill is then the first touch of its pages).
    PrimRef() = default;
    PrimRef(const Aabb& b, std::uint32_t id) : lo(b.lo), id_bits(id ^ kIdFlip), hi(b.hi), unused(0.0f) {}
    [[nodiscard]] std::uint32_t id() const { return id_bits ^ kIdFlip; }

    // Exactly Aabb::center(): the split decisions are those of the boxes themselves. (Indexed through a
    // pointer: glm's operator[] is a switch.)
    [[nodiscard]] float centroid(int axis) const { return 0.5f * ((&lo.x)[axis] + (&hi.x)[axis]); }
};
static_assert(sizeof(PrimRef) == 32 && std::is_trivially_default_constructible_v<PrimRef>);

// A box's bin positions on the three axes (lane 3 unused), before truncation and clamping: its centroid
// (PrimRef::centroid) minus the centroid bounds' low corner, times the bins per unit; bin_of's arithmetic
// lane by lane, so the same bits (tested against it through detail::box_bins).
[[gnu::always_inline]] inline simd::Floats<4> bin_positions(simd::Floats<4> lo, simd::Floats<4> hi,
                                                            simd::Floats<4> cb_lo, simd::Floats<4> scale) {
    return (simd::Floats<4>::broadcast(0.5f) * (lo + hi) - cb_lo) * scale;
}
int clamp_bin(float position) { return std::clamp(static_cast<int>(position), 0, kBins - 1); }

// Box bounds of bins and ranges as two lanes of four floats (core/simd/lanes.hpp; the fourth lane is
// ignored): growing one is a min and a max instruction instead of six scalar ones, in the loop that
// dominates the build.
using Floats4 = simd::Floats<4>;
struct Bounds4 {
    Floats4 lo = Floats4::broadcast(std::numeric_limits<float>::infinity());
    Floats4 hi = Floats4::broadcast(-std::numeric_limits<float>::infinity());

    void grow(const PrimRef& r) {
        lo = min(lo, Floats4::load(&r.lo.x));
        hi = max(hi, Floats4::load(&r.hi.x));
    }
    void grow(const Bounds4& b) {
        lo = min(lo, b.lo);
        hi = max(hi, b.hi);
    }
    [[nodiscard]] Aabb aabb() const {
        alignas(16) float l[4], h[4];
        store(l, lo);
        store(h, hi);
        return Aabb{{l[0], l[1], l[2]}, {h[0], h[1], h[2]}};
    }
    // Aabb::area() of a box known to be non-empty, same operations in the same order.
    [[nodiscard]] float area() const {
        alignas(16) float e[4];
        store(e, hi - lo);
        return 2.0f * (e[0] * e[1] + e[1] * e[2] + e[2] * e[0]);
    }
};

// A scratch node: BvhNode's fields without its default member initialisers, so that the scratch array
// (two slots per primitive, most of them never used) is allocated without being written.
struct ScratchNode {
    float lo[3], hi[3];
    std::uint32_t first, count;
};
static_assert(std::is_trivially_default_constructible_v<ScratchNode>);

// Building happens in a scratch tree whose child pairs are taken from one counter in whatever order the
// threads reach them, so the scratch is dense (the pages it touches are those it uses; a node array of
// 2n slots, most never used, is only the bound); the scratch tree is then compacted depth-first into the
// final node array, which is why the result does not depend on that order.
struct Builder {
    std::unique_ptr<PrimRef[]> refs_storage;
    PrimRef* refs = nullptr;
    std::unique_ptr<ScratchNode[]> scratch;
    std::atomic<std::uint32_t> next_pair{2};  // slot 0 is the root, 1 padding
    BvhBuildSettings settings;

    struct Bin {
        Bounds4 bounds;
        std::uint32_t count = 0;
    };
    struct Binning {
        std::array<std::array<Bin, kBins>, 3> bins{};
        void add(const Binning& b) {
            for (int ax = 0; ax < 3; ++ax)
                for (int i = 0; i < kBins; ++i) {
                    bins[ax][i].bounds.grow(b.bins[ax][i].bounds);
                    bins[ax][i].count += b.bins[ax][i].count;
                }
        }
    };
    struct Split {
        int axis = -1;
        int bin = 0;  // primitives in bins [0, bin] go left
        float cost = std::numeric_limits<float>::infinity();
    };

    // Box and centroid bounds of refs[begin, end).
    void range_bounds_serial(std::uint32_t begin, std::uint32_t end, Bounds4& box, Bounds4& centroids) const {
        const Floats4 half = Floats4::broadcast(0.5f);
        for (std::uint32_t i = begin; i < end; ++i) {
            const Floats4 lo = Floats4::load(&refs[i].lo.x), hi = Floats4::load(&refs[i].hi.x);
            box.lo = min(box.lo, lo);
            box.hi = max(box.hi, hi);
            const Floats4 c = half * (lo + hi);  // PrimRef::centroid, all axes
            centroids.lo = min(centroids.lo, c);
            centroids.hi = max(centroids.hi, c);
        }
    }

    void range_bounds(std::uint32_t begin, std::uint32_t end, Bounds4& box, Bounds4& cent) const {
        if (end - begin >= settings.parallel_threshold * 4) {
            using Acc = std::pair<Bounds4, Bounds4>;
            const Acc r = tbb::parallel_reduce(
                tbb::blocked_range<std::uint32_t>(begin, end, 8192), Acc{},
                [&](const tbb::blocked_range<std::uint32_t>& range, Acc acc) {
                    range_bounds_serial(range.begin(), range.end(), acc.first, acc.second);
                    return acc;
                },
                [](Acc a, const Acc& b) {
                    a.first.grow(b.first);
                    a.second.grow(b.second);
                    return a;
                });
            box = r.first;
            cent = r.second;
        } else {
            range_bounds_serial(begin, end, box, cent);
        }
    }

    static int bin_of(float c, float lo, float scale) { return detail::bin_of(c, lo, scale); }

    // Bins per unit of a centroid extent e > 0. For e below kBins / FLT_MAX (~1e-37: particles of the
    // smallest radii a few subnormal steps apart) kBins / e overflows, and inf · (c − lo) made bin_of convert
    // inf or NaN to int; FLT_MAX instead keeps every (c − lo) · scale <= e · FLT_MAX below kBins. Any larger
    // extent gets exactly kBins / e, as before.
    static float bin_scale(float e) { return std::min(float(kBins) / e, std::numeric_limits<float>::max()); }

    // The binning transform of all three axes as lanes: a primitive's three bin positions are one
    // subtraction and one multiplication, the operations of bin_of() lane by lane (the same bits).
    struct BinScale {
        Floats4 lo, scale;
        explicit BinScale(const Aabb& cb) {
            alignas(16) float l[4] = {cb.lo.x, cb.lo.y, cb.lo.z, 0.0f}, s[4] = {0.0f, 0.0f, 0.0f, 0.0f};
            for (int a = 0; a < 3; ++a) {
                const float e = cb.hi[a] - cb.lo[a];
                s[a] = e > 0.0f ? bin_scale(e) : 0.0f;
            }
            lo = Floats4::load(l);
            scale = Floats4::load(s);
        }
    };

    void bin_serial(std::uint32_t begin, std::uint32_t end, const BinScale& s, Binning& acc) const {
        for (std::uint32_t i = begin; i < end; ++i) {
            const PrimRef& r = refs[i];
            const Floats4 lo = Floats4::load(&r.lo.x), hi = Floats4::load(&r.hi.x);
            alignas(16) float pos[4];
            store(pos, bin_positions(lo, hi, s.lo, s.scale));
            for (int a = 0; a < 3; ++a) {
                Bin& bin = acc.bins[a][clamp_bin(pos[a])];
                bin.bounds.lo = min(bin.bounds.lo, lo);
                bin.bounds.hi = max(bin.bounds.hi, hi);
                ++bin.count;
            }
        }
    }

    void bin_range(std::uint32_t begin, std::uint32_t end, const Aabb& cb, Binning& out) const {
        const BinScale s(cb);
        if (end - begin >= settings.parallel_threshold * 4) {
            out = tbb::parallel_reduce(
                tbb::blocked_range<std::uint32_t>(begin, end, 8192), Binning{},
                [&](const tbb::blocked_range<std::uint32_t>& r, Binning acc) {
                    bin_serial(r.begin(), r.end(), s, acc);
                    return acc;
                },
                [](Binning a, const Binning& b) {
                    a.add(b);
                    return a;
                });
        } else {
            bin_serial(begin, end, s, out);
        }
    }

    // Sweeps the bins of each axis: SAH cost of splitting after bin i, relative to the parent area.
    // An empty bin changes neither side, so only the occupied bins are visited (a bit mask of them, walked
    // bit by bit): the candidates, their order and every float operation are those of a sweep over all
    // kBins (the first of equal costs wins), at a fraction of the work in the many small nodes where most
    // bins are empty. A side without primitives costs 0, so no empty box's area is taken.
    Split best_split(const Binning& binning, float parent_area) const {
        Split best;
        for (int a = 0; a < 3; ++a) {
            const auto& bins = binning.bins[a];
            std::uint32_t occupied = 0;
            for (int i = 0; i < kBins; ++i) occupied |= std::uint32_t(bins[i].count != 0) << i;
            // left_cost[i]: the cost of the left side of a split after bin i, for each occupied bin i
            // (and for an empty one, that of the occupied bin below it: read only through that bin).
            std::array<float, kBins> left_cost;
            Bounds4 acc;
            std::uint32_t n = 0;
            for (std::uint32_t m = occupied; m != 0; m &= m - 1) {
                const int i = std::countr_zero(m);
                acc.grow(bins[i].bounds);
                n += bins[i].count;
                left_cost[i] = acc.area() * float(n);
            }
            // The left cost of a split just below bin i: that of the highest occupied bin under i, or 0.
            auto left_below = [&](int i) {
                const std::uint32_t below = occupied & ((1u << i) - 1u);
                return below != 0 ? left_cost[31 - std::countl_zero(below)] : 0.0f;
            };
            auto consider = [&](float left, float right, int split_bin) {
                const float cost =
                    settings.costs.traversal + settings.costs.intersection * (left + right) / parent_area;
                if (cost < best.cost) best = {a, split_bin, cost};
            };
            // The sweep from the top: first the split after bin kBins − 2 even when the last bin is empty
            // (everything left), then the split just below each occupied bin but bin 0.
            if (!(occupied >> (kBins - 1) & 1u)) consider(left_below(kBins - 1), 0.0f, kBins - 2);
            acc = Bounds4{};
            n = 0;
            for (std::uint32_t m = occupied & ~1u; m != 0;) {
                const int i = 31 - std::countl_zero(m);
                m &= ~(1u << i);
                acc.grow(bins[i].bounds);
                n += bins[i].count;
                consider(left_below(i), acc.area() * float(n), i - 1);
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
        std::nth_element(refs + begin, refs + mid, refs + end,
                         [&](const PrimRef& a, const PrimRef& b) {
                             const float ca = a.centroid(axis), cb2 = b.centroid(axis);
                             return ca < cb2 || (ca == cb2 && a.id() < b.id());
                         });
        return mid;
    }

    // Partitions refs[begin, end) in place, those for which goes_left() holds first, and accumulates the
    // box and centroid bounds of each side as it classifies each primitive (exactly once), so a child's
    // bounds need no pass of their own. Returns the first primitive of the right side.
    template <class GoesLeft>
    std::uint32_t partition(std::uint32_t begin, std::uint32_t end, const GoesLeft& goes_left, Bounds4 (&box)[2],
                            Bounds4 (&cent)[2]) {
        if (direct) return partition_without_branches(begin, end, goes_left, box, cent);
        const Floats4 half = Floats4::broadcast(0.5f);
        // Locals rather than the output arrays, so that the bounds stay in registers through the loop.
        Bounds4 box_l, box_r, cent_l, cent_r;
        auto grow = [&](Bounds4& b, Bounds4& c, const PrimRef& r) {
            const Floats4 lo = Floats4::load(&r.lo.x), hi = Floats4::load(&r.hi.x);
            b.lo = min(b.lo, lo);
            b.hi = max(b.hi, hi);
            const Floats4 centre = half * (lo + hi);
            c.lo = min(c.lo, centre);
            c.hi = max(c.hi, centre);
        };
        PrimRef* l = refs + begin;
        PrimRef* r = refs + end;
        while (true) {
            while (l < r && goes_left(*l)) grow(box_l, cent_l, *l++);
            while (l < r && !goes_left(*(r - 1))) grow(box_r, cent_r, *--r);
            if (l == r) break;
            // *l goes right and *(r − 1) left: swap them into place.
            --r;
            grow(box_r, cent_r, *l);
            grow(box_l, cent_l, *r);
            std::swap(*l, *r);
            ++l;
        }
        box[0] = box_l;
        box[1] = box_r;
        cent[0] = cent_l;
        cent[1] = cent_r;
        return static_cast<std::uint32_t>(l - refs);
    }

    // partition() with no branch on the side a primitive goes to, which is as good as random in most nodes
    // (a mispredicted branch per primitive per level): each primitive is swapped to the end of the left
    // side whichever side it takes, and the end moves only for a left-goer (Lomuto). The two sides hold the
    // same primitives as partition() gives, in another order within each side, so only for trees of one
    // primitive per leaf (direct), where a side's order decides nothing: binning and bounds are exact in any
    // order, and the object-median fallback orders by (centroid, index).
    template <class GoesLeft>
    std::uint32_t partition_without_branches(std::uint32_t begin, std::uint32_t end, const GoesLeft& goes_left,
                                             Bounds4 (&box)[2], Bounds4 (&cent)[2]) {
        const Floats4 half = Floats4::broadcast(0.5f);
        Bounds4 side_box[2], side_cent[2];  // [0] left, [1] right
        std::uint32_t store = begin;
        for (std::uint32_t i = begin; i < end; ++i) {
            const PrimRef r = refs[i];
            const bool left = goes_left(r);
            const Floats4 lo = Floats4::load(&r.lo.x), hi = Floats4::load(&r.hi.x);
            const Floats4 centre = half * (lo + hi);
            Bounds4& b = side_box[left ? 0 : 1];
            Bounds4& c = side_cent[left ? 0 : 1];
            b.lo = min(b.lo, lo);
            b.hi = max(b.hi, hi);
            c.lo = min(c.lo, centre);
            c.hi = max(c.hi, centre);
            refs[i] = refs[store];
            refs[store] = r;
            store += left ? 1u : 0u;
        }
        for (int side = 0; side < 2; ++side) {
            box[side] = side_box[side];
            cent[side] = side_cent[side];
        }
        return store;
    }

    // partition() of a large range on all threads, in place and with a result that does not depend on
    // the thread count: the range is cut into blocks of kPartitionBlock (a fixed size), each block is
    // partitioned on its own, and then the k-th right-going primitive left of the final split point is
    // swapped with the k-th left-going one right of it, for every k (ranks, not threads, pair them up).
    static constexpr std::uint32_t kPartitionBlock = 4096;
    template <class GoesLeft>
    std::uint32_t parallel_partition(std::uint32_t begin, std::uint32_t end, const GoesLeft& goes_left,
                                     Bounds4 (&box)[2], Bounds4 (&cent)[2]) {
        const std::uint32_t blocks = (end - begin + kPartitionBlock - 1) / kPartitionBlock;
        struct Block {
            std::uint32_t begin, mid, end;
            Bounds4 box[2], cent[2];
        };
        std::vector<Block> part(blocks);
        using Range = tbb::blocked_range<std::uint32_t>;
        tbb::parallel_for(Range(0, blocks), [&](const Range& r) {
            for (std::uint32_t k = r.begin(); k < r.end(); ++k) {
                Block& b = part[k];
                b.begin = begin + k * kPartitionBlock;
                b.end = std::min(end, b.begin + kPartitionBlock);
                b.mid = partition(b.begin, b.end, goes_left, b.box, b.cent);
            }
        });
        std::uint32_t mid = begin;
        for (const Block& b : part) {
            mid += b.mid - b.begin;
            for (int side = 0; side < 2; ++side) {
                box[side].grow(b.box[side]);
                cent[side].grow(b.cent[side]);
            }
        }
        // The misplaced runs, in memory order: right-goers before mid, left-goers from mid on.
        struct Run {
            std::uint32_t first, count;
        };
        std::vector<Run> wrong_left, wrong_right;
        for (const Block& b : part) {
            // No empty runs: the walk below steps from a run's end to the next run's start.
            const std::uint32_t hi = std::min(b.end, mid);
            if (b.mid < hi) wrong_left.push_back({b.mid, hi - b.mid});  // right-goers in [b.mid, b.end)
            const std::uint32_t lo = std::max(b.begin, mid);
            if (lo < b.mid) wrong_right.push_back({lo, b.mid - lo});  // left-goers in [b.begin, b.mid)
        }
        std::vector<std::uint32_t> rank_left{0}, rank_right{0};  // prefix sums of the runs' counts
        for (const Run& r : wrong_left) rank_left.push_back(rank_left.back() + r.count);
        for (const Run& r : wrong_right) rank_right.push_back(rank_right.back() + r.count);
        const std::uint32_t misplaced = rank_left.back();
        assert(misplaced == rank_right.back());
        // Ranks [r.begin(), r.end()) of both lists: each located once, then walked run by run.
        struct Cursor {
            const std::vector<Run>& runs;
            std::size_t run;
            std::uint32_t pos;
            Cursor(const std::vector<Run>& rs, const std::vector<std::uint32_t>& rank, std::uint32_t k)
                : runs(rs),
                  run(std::size_t(std::upper_bound(rank.begin(), rank.end(), k) - rank.begin()) - 1),
                  pos(rs[run].first + (k - rank[run])) {}
            void next() {
                if (++pos == runs[run].first + runs[run].count && run + 1 < runs.size()) pos = runs[++run].first;
            }
        };
        tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, misplaced, kPartitionBlock),
                          [&](const tbb::blocked_range<std::uint32_t>& r) {
                              Cursor l(wrong_left, rank_left, r.begin()), g(wrong_right, rank_right, r.begin());
                              for (std::uint32_t k = r.begin(); k < r.end(); ++k, l.next(), g.next())
                                  std::swap(refs[l.pos], refs[g.pos]);
                          });
        return mid;
    }

    // Where build() writes: the scratch tree, or (direct, one primitive per leaf) the final node array.
    BvhNode* direct = nullptr;
    std::uint32_t direct_prim_base = 0;

    void set_bounds(std::uint32_t node, const Aabb& bounds) {
        if (direct) {
            direct[node].bounds = bounds;
        } else {
            std::copy_n(&bounds.lo.x, 3, scratch[node].lo);
            std::copy_n(&bounds.hi.x, 3, scratch[node].hi);
        }
    }
    void set_range(std::uint32_t node, std::uint32_t first, std::uint32_t count) {
        if (direct) {
            direct[node].first = count != 0 ? direct_prim_base + first : first;
            direct[node].count = count;
        } else {
            scratch[node].first = first;
            scratch[node].count = count;
        }
    }
    void make_leaf(std::uint32_t node, std::uint32_t begin, std::uint32_t end) { set_range(node, begin, end - begin); }

    // Builds the subtree of node `node` over refs[begin, end), whose box and centroid bounds are given;
    // returns the depth of its deepest node. In the scratch tree the node's pair is taken from next_pair.
    // Directly into the final array it is `pair`: with one primitive per leaf a subtree of n primitives has
    // exactly 2n − 1 nodes, so the depth-first layout compact_into() would give is known as the tree is
    // built (the left child's pair right after the node's, the right child's after the left subtree's
    // 2·n_left − 2 nodes), and the subtrees write their disjoint stretches of it in parallel.
    int build(std::uint32_t node, std::uint32_t pair, std::uint32_t begin, std::uint32_t end, int depth,
              const Bounds4& box, const Bounds4& cent) {
        const std::uint32_t n = end - begin;
        const Aabb bounds = box.aabb(), cb = cent.aabb();
        set_bounds(node, bounds);
        const auto leaf = [&] {
            make_leaf(node, begin, end);
            return depth;
        };
        if (n == 1) return leaf();

        // Levels still needed if every later split halved the count exactly; past the budget, halve.
        const int levels_needed = std::bit_width(n - 1);
        const bool must_halve = depth + levels_needed >= kMaxBvhDepth - 1;

        std::uint32_t mid = begin;
        Bounds4 child_box[2], child_cent[2];
        if (!must_halve) {
            Binning binning;
            bin_range(begin, end, cb, binning);
            const float area = bounds.area();
            const Split split = area > 0.0f ? best_split(binning, area) : Split{};
            const float leaf_cost = settings.costs.intersection * float(n);
            if (n <= settings.max_leaf_size && !(split.cost < leaf_cost)) return leaf();
            if (split.axis >= 0 && cb.hi[split.axis] > cb.lo[split.axis]) {
                const int a = split.axis;
                const float lo = cb.lo[a];
                const float scale = bin_scale(cb.hi[a] - lo);
                const auto goes_left = [&](const PrimRef& r) { return bin_of(r.centroid(a), lo, scale) <= split.bin; };
                mid = n >= settings.parallel_threshold * 4
                          ? parallel_partition(begin, end, goes_left, child_box, child_cent)
                          : partition(begin, end, goes_left, child_box, child_cent);
            }
        }
        if (mid == begin || mid == end) {
            if (n <= settings.max_leaf_size && !must_halve) return leaf();
            mid = median_split(begin, end, cb);
            child_box[0] = child_box[1] = child_cent[0] = child_cent[1] = Bounds4{};
            range_bounds(begin, mid, child_box[0], child_cent[0]);
            range_bounds(mid, end, child_box[1], child_cent[1]);
        }

        const std::uint32_t left = direct ? pair : next_pair.fetch_add(2, std::memory_order_relaxed), right = left + 1;
        const std::uint32_t left_pair = left + 2, right_pair = left + 2 * (mid - begin);
        set_range(node, left, 0);
        int deepest_left = 0, deepest_right = 0;
        if (n >= settings.parallel_threshold) {
            tbb::parallel_invoke(
                [&] { deepest_left = build(left, left_pair, begin, mid, depth + 1, child_box[0], child_cent[0]); },
                [&] { deepest_right = build(right, right_pair, mid, end, depth + 1, child_box[1], child_cent[1]); });
        } else {
            deepest_left = build(left, left_pair, begin, mid, depth + 1, child_box[0], child_cent[0]);
            deepest_right = build(right, right_pair, mid, end, depth + 1, child_box[1], child_cent[1]);
        }
        return std::max(deepest_left, deepest_right);
    }
};

BvhNode to_node(const ScratchNode& s) {
    return BvhNode{Aabb{{s.lo[0], s.lo[1], s.lo[2]}, {s.hi[0], s.hi[1], s.hi[2]}}, s.first, s.count};
}

// Depth-first compaction of a scratch tree into `out`: its root into the slot dst_root, each node's pair
// appended when the node is reached (the root at 0, padding at 1, then the pairs, for a whole tree), leaf
// ranges moved up by prim_base. Returns the depth of the deepest node below dst_root, which sits at
// root_depth.
int compact_into(const ScratchNode* scratch, Bvh& out, std::uint32_t dst_root, std::uint32_t prim_base,
                 int root_depth) {
    auto node = [&](std::uint32_t src) {
        BvhNode n = to_node(scratch[src]);
        if (n.is_leaf()) n.first += prim_base;
        return n;
    };
    out.nodes[dst_root] = node(0);
    struct Item {
        std::uint32_t src, dst;
        int depth;
    };
    std::vector<Item> stack{{0u, dst_root, root_depth}};
    int deepest = root_depth;
    while (!stack.empty()) {
        const Item it = stack.back();
        stack.pop_back();
        deepest = std::max(deepest, it.depth);
        if (out.nodes[it.dst].is_leaf()) continue;
        const std::uint32_t src_left = scratch[it.src].first;
        const auto pair = static_cast<std::uint32_t>(out.nodes.size());
        out.nodes.push_back(node(src_left));
        out.nodes.push_back(node(src_left + 1));
        out.nodes[it.dst].first = pair;
        // Right first on the stack so the left subtree is laid out next (depth-first, left first).
        stack.push_back({src_left + 1, pair + 1, it.depth + 1});
        stack.push_back({src_left, pair, it.depth + 1});
    }
    return deepest;
}

// A builder over the primitives prim_boxes[ids[k]] (ids null: every primitive, k itself), each keeping its
// index in prim_boxes: the refs filled in parallel, their bounds taken, the scratch tree not yet built.
std::unique_ptr<Builder> make_builder(std::span<const Aabb> prim_boxes, const std::uint32_t* ids, std::uint32_t n,
                                      const BvhBuildSettings& settings) {
    auto b = std::make_unique<Builder>();
    b->settings = settings;
    b->settings.max_leaf_size = std::max(1u, settings.max_leaf_size);
    b->refs_storage.reset(new PrimRef[n]);  // trivially default-constructible: not written here
    b->refs = b->refs_storage.get();
    // The primitive copy (and the index copy after the build) run in parallel: large flat loops that
    // touch fresh memory, each slot written by one iteration.
    std::atomic<bool> has_empty{false};
    using Range = tbb::blocked_range<std::uint32_t>;
    tbb::parallel_for(Range(0, n, kCopyGrain), [&](const Range& r) {
        bool empty = false;
        for (std::uint32_t k = r.begin(); k < r.end(); ++k) {
            const std::uint32_t i = ids ? ids[k] : k;
            empty = empty || prim_boxes[i].empty();
            b->refs[k] = PrimRef(prim_boxes[i], i);
        }
        if (empty) has_empty.store(true, std::memory_order_relaxed);
    });
    if (has_empty.load()) throw std::invalid_argument("build_bvh: empty primitive box");
    // With more than one primitive per leaf the node count is known only once built: a scratch tree,
    // compacted afterwards (root, padding, at most n − 1 pairs). With one, build_into() builds in place.
    if (b->settings.max_leaf_size > 1) b->scratch.reset(new ScratchNode[2 * std::size_t(n)]);
    return b;
}

// Builds b's scratch tree over its n refs, compacts it into out at dst_root (see compact_into) and writes
// its primitives' indices to out.prim_indices[prim_base, prim_base + n). Returns the depth as compact_into.
int build_into(Builder& b, std::uint32_t n, Bvh& out, std::uint32_t dst_root, std::uint32_t prim_base,
               int root_depth) {
    Bounds4 box, cent;
    b.range_bounds(0, n, box, cent);
    int depth = 0;
    if (b.scratch) {
        b.build(0, 0, 0, n, 0, box, cent);
    } else {
        // In place: the root at dst_root, its 2n − 2 descendants appended (see Builder::build).
        const auto pair = static_cast<std::uint32_t>(out.nodes.size());
        out.nodes.resize(out.nodes.size() + 2 * std::size_t(n - 1));
        b.direct = out.nodes.data();
        b.direct_prim_base = prim_base;
        depth = root_depth + b.build(dst_root, pair, 0, n, 0, box, cent);
    }
    using Range = tbb::blocked_range<std::uint32_t>;
    tbb::parallel_for(Range(0, n, kCopyGrain), [&](const Range& r) {
        for (std::uint32_t k = r.begin(); k < r.end(); ++k) out.prim_indices[prim_base + k] = b.refs[k].id();
    });
    return b.scratch ? compact_into(b.scratch.get(), out, dst_root, prim_base, root_depth) : depth;
}

}  // namespace

namespace detail {

std::array<int, 3> box_bins(const Aabb& box, const glm::vec3& lo, const glm::vec3& scale) {
    alignas(16) const float l[4] = {box.lo.x, box.lo.y, box.lo.z, 0.0f}, h[4] = {box.hi.x, box.hi.y, box.hi.z, 0.0f};
    alignas(16) const float cl[4] = {lo.x, lo.y, lo.z, 0.0f}, sc[4] = {scale.x, scale.y, scale.z, 0.0f};
    alignas(16) float pos[4];
    store(pos, bin_positions(Floats4::load(l), Floats4::load(h), Floats4::load(cl), Floats4::load(sc)));
    return {clamp_bin(pos[0]), clamp_bin(pos[1]), clamp_bin(pos[2])};
}

}  // namespace detail

Bvh build_bvh(std::span<const Aabb> prim_boxes, const BvhBuildSettings& settings) {
    Bvh bvh;
    if (prim_boxes.empty()) return bvh;
    if (prim_boxes.size() >= std::numeric_limits<std::uint32_t>::max() / 2)
        throw std::length_error("build_bvh: too many primitives");
    const auto n = static_cast<std::uint32_t>(prim_boxes.size());
    const std::unique_ptr<Builder> b = make_builder(prim_boxes, nullptr, n, settings);
    bvh.prim_indices.resize(n);
    bvh.nodes.reserve(2 * std::size_t(n));
    bvh.nodes.resize(2);  // the root and the padding slot that puts pairs at even indices
    bvh.nodes[1] = BvhNode{Aabb{}, 0, 0};
    build_into(*b, n, bvh, 0, 0, 0);
    return bvh;
}

namespace {

// The grouped build's state: each group's members (global indices, in primitive order) and where its
// primitives start in the joined prim_indices.
struct Groups {
    std::vector<std::uint32_t, UnwrittenAllocator<std::uint32_t>> members;  // group by group
    std::vector<std::uint32_t> first;    // group g's members are members[first[g], first[g + 1])
    std::vector<std::uint32_t> prim_base;
};

// Copies the top tree into `joined` depth-first, building each group's tree where the top tree has that
// group's leaf: the group's primitives then come in the order the top tree's leaves are met. Returns the
// deepest depth reached.
int join_groups(const Bvh& top, std::uint32_t top_node, std::span<const Aabb> prim_boxes, const Groups& groups,
                const BvhBuildSettings& settings, Bvh& joined, std::uint32_t dst_node, int depth) {
    const BvhNode n = top.nodes[top_node];
    if (n.is_leaf()) {
        const std::uint32_t g = top.prim_indices[n.first];
        const std::uint32_t count = groups.first[g + 1] - groups.first[g];
        const std::unique_ptr<Builder> b =
            make_builder(prim_boxes, groups.members.data() + groups.first[g], count, settings);
        return build_into(*b, count, joined, dst_node, groups.prim_base[g], depth);
    }
    const auto pair = static_cast<std::uint32_t>(joined.nodes.size());
    joined.nodes.resize(joined.nodes.size() + 2);
    joined.nodes[dst_node].bounds = n.bounds;
    joined.nodes[dst_node].first = pair;
    joined.nodes[dst_node].count = 0;
    const int l = join_groups(top, n.first, prim_boxes, groups, settings, joined, pair, depth + 1);
    const int r = join_groups(top, n.first + 1, prim_boxes, groups, settings, joined, pair + 1, depth + 1);
    return std::max(l, r);
}

// The top tree's leaves (one group each) from left to right.
void leaf_order(const Bvh& top, std::uint32_t node, std::vector<std::uint32_t>& order) {
    const BvhNode& n = top.nodes[node];
    if (n.is_leaf()) {
        order.push_back(top.prim_indices[n.first]);
        return;
    }
    leaf_order(top, n.first, order);
    leaf_order(top, n.first + 1, order);
}

template <class Group>
Bvh build_grouped(std::span<const Aabb> prim_boxes, std::span<const Group> group_of, const BvhBuildSettings& settings) {
    if (group_of.size() != prim_boxes.size()) throw std::invalid_argument("build_grouped_bvh: one group per primitive");
    if (prim_boxes.size() >= std::numeric_limits<std::uint32_t>::max() / 2)
        throw std::length_error("build_bvh: too many primitives");
    // The distinct groups, ascending, and each group's members in primitive order (deterministic): a counting
    // sort by group over fixed chunks in parallel (two serial passes over every primitive were the build's
    // largest serial part at 10^7). Past kMaxBvhGroups groups the count is all that matters.
    const auto n = static_cast<std::uint32_t>(prim_boxes.size());
    constexpr std::uint32_t kChunk = 1u << 16;
    const std::uint32_t chunks = (n + kChunk - 1) / kChunk;
    constexpr std::size_t kMost = kMaxBvhGroups + 1;  // a chunk stops collecting keys past this many
    struct ChunkKeys {
        std::uint32_t key[kMost];
        std::uint32_t count[kMost];
        std::uint32_t distinct = 0;
    };
    std::vector<ChunkKeys> per_chunk(chunks);
    tbb::parallel_for(std::uint32_t{0}, chunks, [&](std::uint32_t c) {
        ChunkKeys& ck = per_chunk[c];
        const std::uint32_t end = std::min(n, c * kChunk + kChunk);
        for (std::uint32_t i = c * kChunk; i < end && ck.distinct <= kMaxBvhGroups; ++i) {
            const std::uint32_t g = group_of[i];
            std::uint32_t k = 0;
            while (k < ck.distinct && ck.key[k] != g) ++k;
            if (k == ck.distinct) {
                ck.key[k] = g;
                ck.count[k] = 0;
                ++ck.distinct;
            }
            ++ck.count[k];
        }
    });
    std::vector<std::uint32_t> keys;
    for (const ChunkKeys& ck : per_chunk)
        for (std::uint32_t k = 0; k < ck.distinct; ++k)
            if (std::find(keys.begin(), keys.end(), ck.key[k]) == keys.end()) {
                keys.push_back(ck.key[k]);
                if (keys.size() > kMaxBvhGroups) return build_bvh(prim_boxes, settings);
            }
    if (keys.size() <= 1) return build_bvh(prim_boxes, settings);
    std::sort(keys.begin(), keys.end());

    const std::size_t group_count = keys.size();
    auto group_index = [&](std::uint32_t key) {
        return static_cast<std::uint32_t>(std::lower_bound(keys.begin(), keys.end(), key) - keys.begin());
    };
    // Where each chunk's members of each group go: after the earlier groups' and the earlier chunks'.
    std::vector<std::uint32_t> start(std::size_t(chunks) * group_count, 0);
    for (std::uint32_t c = 0; c < chunks; ++c)
        for (std::uint32_t k = 0; k < per_chunk[c].distinct; ++k)
            start[std::size_t(c) * group_count + group_index(per_chunk[c].key[k])] = per_chunk[c].count[k];
    Groups groups;
    groups.first.assign(group_count + 1, 0);
    for (std::size_t g = 0; g < group_count; ++g) {
        std::uint32_t at = groups.first[g];
        for (std::uint32_t c = 0; c < chunks; ++c) {
            const std::uint32_t count = start[std::size_t(c) * group_count + g];
            start[std::size_t(c) * group_count + g] = at;
            at += count;
        }
        groups.first[g + 1] = at;
    }
    groups.members.resize(n);
    tbb::parallel_for(std::uint32_t{0}, chunks, [&](std::uint32_t c) {
        std::uint32_t* next = &start[std::size_t(c) * group_count];
        for (std::uint32_t i = c * kChunk, end = std::min(n, i + kChunk); i < end; ++i)
            groups.members[next[group_index(group_of[i])]++] = i;
    });
    // Each group's box, and the top tree over them.
    std::vector<Aabb> group_boxes(group_count);
    for (std::size_t g = 0; g < group_count; ++g) {
        const std::uint32_t first = groups.first[g], last = groups.first[g + 1];
        group_boxes[g] = tbb::parallel_reduce(
            tbb::blocked_range<std::uint32_t>(first, last, kCopyGrain), Aabb{},
            [&](const tbb::blocked_range<std::uint32_t>& r, Aabb acc) {
                for (std::uint32_t k = r.begin(); k < r.end(); ++k) acc.grow(prim_boxes[groups.members[k]]);
                return acc;
            },
            [](Aabb a, const Aabb& b) {
                a.grow(b);
                return a;
            });
        if (group_boxes[g].empty()) throw std::invalid_argument("build_bvh: empty primitive box");
    }
    const Bvh top = build_bvh(group_boxes, BvhBuildSettings{settings.costs, 1, settings.parallel_threshold});
    // A group's primitives start after those of the groups whose top leaves come before its own.
    std::vector<std::uint32_t> order;
    leaf_order(top, 0, order);
    groups.prim_base.assign(group_count, 0);
    std::uint32_t base = 0;
    for (const std::uint32_t g : order) {
        groups.prim_base[g] = base;
        base += groups.first[g + 1] - groups.first[g];
    }

    Bvh joined;
    joined.nodes.reserve(2 * std::size_t(n));
    joined.prim_indices.resize(n);
    joined.nodes.resize(2);  // the root and the padding slot that puts pairs at even indices
    joined.nodes[1] = BvhNode{Aabb{}, 0, 0};
    const int depth = join_groups(top, 0, prim_boxes, groups, settings, joined, 0, 0);
    if (depth > kMaxBvhDepth) return build_bvh(prim_boxes, settings);
    return joined;
}

}  // namespace

Bvh build_grouped_bvh(std::span<const Aabb> prim_boxes, std::span<const std::uint32_t> group_of,
                      const BvhBuildSettings& settings) {
    return build_grouped(prim_boxes, group_of, settings);
}

Bvh build_grouped_bvh(std::span<const Aabb> prim_boxes, std::span<const std::uint8_t> group_of,
                      const BvhBuildSettings& settings) {
    return build_grouped(prim_boxes, group_of, settings);
}

}  // namespace smoketrace
