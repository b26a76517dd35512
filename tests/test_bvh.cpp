// The BVH (bvh.hpp, bvh_builder.hpp), its traversal (bvh_traversal.hpp, blas_traversal.hpp), the mesh
// BLAS (triangle_mesh.hpp) and the stand-in meshes (stand_in_shapes.hpp), each against brute force.
#include <smoketrace/trace/blas_traversal.hpp>
#include <smoketrace/accel/bvh.hpp>
#include <smoketrace/accel/bvh_builder.hpp>
#include <smoketrace/accel/bvh_traversal.hpp>
#include <smoketrace/accel/blas_wide_traversal.hpp>
#include <smoketrace/accel/wide_bvh_traversal.hpp>
#include <smoketrace/core/prng.hpp>
#include <smoketrace/smoke/stand_in_shapes.hpp>
#include <smoketrace/accel/triangle_mesh.hpp>
// The library's own headers (src/): the parallel sweep and the wide layout, not part of the installed API.
#include "accel/bvh_bottom_up.hpp"
#include "accel/wide_cut.hpp"

#include <catch2/catch.hpp>
#include <glm/geometric.hpp>
#include <tbb/global_control.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <limits>
#include <map>
#include <set>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

using namespace smoketrace;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// ---------------------------------------------------------------------------------------------------
// Inputs

std::vector<Aabb> random_boxes(std::size_t n, std::uint64_t seed) {
    Pcg32 rng(seed);
    std::vector<Aabb> boxes(n);
    for (auto& b : boxes) {
        const glm::vec3 c(rng.uniform(-10, 10), rng.uniform(-10, 10), rng.uniform(-10, 10));
        const glm::vec3 e(rng.uniform(0, 0.5f), rng.uniform(0, 0.5f), rng.uniform(0, 0.5f));
        b = Aabb{c - e, c + e};
    }
    return boxes;
}

// A soup of n triangles in [-1, 1]^3 with sizes up to `size`; every 97th triangle is degenerate
// (a repeated vertex) so that the BLAS has something to leave out.
TriangleMesh random_soup(std::size_t n, float size, std::uint64_t seed) {
    Pcg32 rng(seed);
    TriangleMesh m;
    for (std::size_t i = 0; i < n; ++i) {
        const glm::vec3 c(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        const auto base = static_cast<unsigned>(m.vertices.size());
        for (int k = 0; k < 3; ++k)
            m.vertices.push_back(c + size * glm::vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)));
        m.triangles.push_back(i % 97 == 96 ? glm::uvec3(base, base, base + 2) : glm::uvec3(base, base + 1, base + 2));
    }
    return m;
}

// Rays from random origins in [-2, 2]^3 (some inside the soup) towards random points of [-1, 1]^3,
// with unnormalised directions.
std::vector<Ray> random_rays(std::size_t n, std::uint64_t seed) {
    Pcg32 rng(seed);
    std::vector<Ray> rays(n);
    for (auto& r : rays) {
        r.origin = glm::vec3(rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(-2, 2));
        const glm::vec3 target(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        r.direction = (target - r.origin) * rng.uniform(0.5f, 2.0f);
    }
    return rays;
}

Aabb triangle_box(const TriangleMesh& m, std::size_t i) {
    Aabb b;
    for (int k = 0; k < 3; ++k) b.grow(m.vertices[m.triangles[i][k]]);
    return b;
}

// ---------------------------------------------------------------------------------------------------
// Brute force

struct RefHit {
    std::uint32_t prim;
    float t;
    glm::vec2 barycentrics;
    bool front;
};

// Every triangle of the mesh the ray hits in [tmin, tmax], by the same triangle function as the BLAS.
std::vector<RefHit> brute_force_hits(const TriangleMesh& m, const Ray& r) {
    std::vector<RefHit> hits;
    const TriangleRay tr(r);
    for (std::size_t i = 0; i < m.triangles.size(); ++i) {
        const glm::uvec3 t = m.triangles[i];
        TriangleHit h;
        if (intersect_triangle(tr, m.vertices[t.x], m.vertices[t.y], m.vertices[t.z], r.tmax, h))
            hits.push_back({std::uint32_t(i), h.t, h.barycentrics, h.front_face});
    }
    return hits;
}

float min_t(const std::vector<RefHit>& hits) {
    float t = kInf;
    for (const auto& h : hits) t = std::min(t, h.t);
    return t;
}

// ---------------------------------------------------------------------------------------------------
// Structure checks

struct TreeFacts {
    std::size_t nodes_reached = 0;
    int depth = 0;
    double sah = 0.0;  // recomputed from brute-force boxes, in double
};

// Walks the tree from the root and checks every structural promise of bvh.hpp and bvh_builder.hpp.
// Node boxes are required to be EXACTLY the union of their primitives' boxes (tight), which also
// implies that each child box lies inside its parent's.
TreeFacts check_structure(const Bvh& bvh, const std::vector<Aabb>& boxes, unsigned max_leaf_size,
                          const SahCosts& costs = {}) {
    TreeFacts facts;
    const std::size_t n = boxes.size();
    REQUIRE(bvh.prim_indices.size() == n);
    REQUIRE(bvh.nodes.size() >= 1);
    REQUIRE(reinterpret_cast<std::uintptr_t>(bvh.nodes.data()) % 64 == 0);
    std::vector<int> slot_owner(n, 0);   // leaf slots covered
    std::vector<int> node_seen(bvh.nodes.size(), 0);
    Aabb root_box;
    for (const auto& b : boxes) root_box.grow(b);
    const double root_area = root_box.area();

    struct Item {
        std::uint32_t node;
        int depth;
    };
    std::vector<Item> stack{{0u, 0}};
    while (!stack.empty()) {
        const Item it = stack.back();
        stack.pop_back();
        REQUIRE(it.node < bvh.nodes.size());
        REQUIRE(it.node != 1);  // the padding slot is never referenced
        REQUIRE(++node_seen[it.node] == 1);
        ++facts.nodes_reached;
        facts.depth = std::max(facts.depth, it.depth);
        const BvhNode& node = bvh.nodes[it.node];
        Aabb expected;
        if (node.is_leaf()) {
            REQUIRE(node.count <= max_leaf_size);
            REQUIRE(std::size_t(node.first) + node.count <= n);
            for (std::uint32_t k = node.first; k < node.first + node.count; ++k) {
                ++slot_owner[k];
                expected.grow(boxes[bvh.prim_indices[k]]);
            }
            facts.sah += costs.intersection * node.count * (double(expected.area()) / root_area);
        } else {
            REQUIRE(node.first % 2 == 0);          // pairs start at even indices (one cache line)
            REQUIRE(node.first > it.node);         // depth-first: children after their parent
            REQUIRE(node.first + 1 < bvh.nodes.size());
            const Aabb& l = bvh.nodes[node.first].bounds;
            const Aabb& r = bvh.nodes[node.first + 1].bounds;
            for (int a = 0; a < 3; ++a) {
                REQUIRE(l.lo[a] >= node.bounds.lo[a]);
                REQUIRE(l.hi[a] <= node.bounds.hi[a]);
                REQUIRE(r.lo[a] >= node.bounds.lo[a]);
                REQUIRE(r.hi[a] <= node.bounds.hi[a]);
            }
            expected = merge(l, r);
            facts.sah += costs.traversal * (double(expected.area()) / root_area);
            stack.push_back({node.first, it.depth + 1});
            stack.push_back({node.first + 1, it.depth + 1});
        }
        REQUIRE(node.bounds.lo == expected.lo);
        REQUIRE(node.bounds.hi == expected.hi);
    }
    // Every leaf slot in exactly one leaf, and the slots name every primitive exactly once.
    for (std::size_t k = 0; k < n; ++k) REQUIRE(slot_owner[k] == 1);
    std::vector<std::uint32_t> sorted = bvh.prim_indices;
    std::sort(sorted.begin(), sorted.end());
    for (std::size_t k = 0; k < n; ++k) REQUIRE(sorted[k] == k);
    // Every node but the padding slot is reachable.
    REQUIRE(facts.nodes_reached == bvh.node_count());
    REQUIRE(facts.depth == bvh.depth());
    REQUIRE(facts.depth <= kMaxBvhDepth);
    return facts;
}

// SAH agreement: sah_cost() sums float box areas; the recomputation uses the same float areas divided in
// double, so the two sums differ only by the order and precision of the additions.
constexpr double kSahRelTol = 1e-9;

TEST_CASE("BVH builder: structure invariants on random boxes", "[bvh]") {
    for (std::size_t n : {1u, 2u, 3u, 5u, 17u, 1000u, 50000u})
        for (unsigned leaf : {1u, 2u, 4u, 8u}) {
            const auto boxes = random_boxes(n, 1000 + n);
            BvhBuildSettings settings;
            settings.max_leaf_size = leaf;
            const Bvh bvh = build_bvh(boxes, settings);
            INFO("n " << n << " max leaf " << leaf);
            const TreeFacts facts = check_structure(bvh, boxes, leaf);
            const double sah = bvh.sah_cost();
            REQUIRE(sah > 0.0);
            REQUIRE(std::abs(sah - facts.sah) <= kSahRelTol * facts.sah);
            if (n == 1) REQUIRE(bvh.node_count() == 1);
        }
}

TEST_CASE("BVH builder: SAH cost follows the cost constants", "[bvh]") {
    const auto boxes = random_boxes(5000, 7);
    BvhBuildSettings settings;
    settings.costs = {2.0f, 0.5f};
    const Bvh bvh = build_bvh(boxes, settings);
    const TreeFacts facts = check_structure(bvh, boxes, settings.max_leaf_size, settings.costs);
    REQUIRE(std::abs(bvh.sah_cost(settings.costs) - facts.sah) <= kSahRelTol * facts.sah);
    // Root alone costs traversal·1: the sum can never be below it.
    REQUIRE(bvh.sah_cost(settings.costs) > settings.costs.traversal);
}

// Adversarial input for binned SAH: six chains of boxes along ±x, ±y, ±z at distances 8^-i from the
// origin, each box a quarter of its distance wide. Sixteen uniform bins put all but the outermost box of
// a chain into one bin, so every SAH split peels off about one box: an unbounded builder would go about
// as deep as a chain is long, times the number of chains it interleaves.
struct ChainItem {
    glm::vec3 centre;
    float size;
};
std::vector<ChainItem> six_chain_items() {
    std::vector<ChainItem> items;
    for (int chain = 0; chain < 6; ++chain)
        for (int i = 0; i < 41; ++i) {  // 8^-40 = 2^-120: the smallest box is still a normal float
            const float x = std::ldexp(1.0f, -3 * i);
            glm::vec3 c(0.0f);
            c[chain % 3] = chain < 3 ? x : -x;
            items.push_back({c, 0.25f * x});
        }
    return items;
}
std::vector<Aabb> six_chains() {
    std::vector<Aabb> boxes;
    for (const auto& it : six_chain_items()) boxes.push_back(Aabb{it.centre - it.size, it.centre + it.size});
    return boxes;
}

TEST_CASE("BVH builder: empty input, empty boxes and the depth bound on adversarial inputs", "[bvh]") {
    REQUIRE(build_bvh(std::vector<Aabb>{}).empty());
    std::vector<Aabb> with_empty = random_boxes(10, 3);
    with_empty[4] = Aabb{};
    REQUIRE_THROWS(build_bvh(with_empty));

    SECTION("six exponentially spaced chains") {
        const auto boxes = six_chains();
        const Bvh bvh = build_bvh(boxes);
        check_structure(bvh, boxes, 4);
        // The input is adversarial: ~250 primitives (a balanced tree: depth 8) drive binned SAH to the
        // depth budget, where the builder's forced halving takes over.
        REQUIRE(bvh.depth() >= kMaxBvhDepth - 8);
    }
    SECTION("six chains mixed with random boxes") {
        std::vector<Aabb> boxes = six_chains();
        const auto noise = random_boxes(20000, 5);
        boxes.insert(boxes.end(), noise.begin(), noise.end());
        const Bvh bvh = build_bvh(boxes);
        check_structure(bvh, boxes, 4);
    }
    SECTION("many identical boxes: no split plane separates them") {
        const std::vector<Aabb> boxes(3000, Aabb{glm::vec3(1.0f), glm::vec3(2.0f)});
        const Bvh bvh = build_bvh(boxes);
        check_structure(bvh, boxes, 4);
    }
    SECTION("nested boxes of doubling size around one centre") {
        std::vector<Aabb> boxes;
        for (int i = 0; i < 120; ++i) {
            const glm::vec3 e(std::ldexp(1.0f, i - 60));
            boxes.push_back(Aabb{-e, e});
        }
        const Bvh bvh = build_bvh(boxes, BvhBuildSettings{{}, 1});
        check_structure(bvh, boxes, 1);
    }
}

TEST_CASE("BVH builder: the same node array with 1, 2 and 8 threads", "[bvh]") {
    const auto boxes = random_boxes(200000, 77);
    auto build_with = [&](int threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
        return build_bvh(boxes);
    };
    const Bvh one = build_with(1);
    check_structure(one, boxes, 4);
    for (int threads : {2, 8}) {
        const Bvh many = build_with(threads);
        INFO("threads " << threads);
        REQUIRE(many.nodes.size() == one.nodes.size());
        REQUIRE(many.prim_indices == one.prim_indices);
        for (std::size_t i = 0; i < one.nodes.size(); ++i) {
            REQUIRE(many.nodes[i].bounds.lo == one.nodes[i].bounds.lo);
            REQUIRE(many.nodes[i].bounds.hi == one.nodes[i].bounds.hi);
            REQUIRE(many.nodes[i].first == one.nodes[i].first);
            REQUIRE(many.nodes[i].count == one.nodes[i].count);
        }
    }
}

TEST_CASE("BVH builder: exact boxes on a large mesh, whose top levels partition in parallel", "[bvh]") {
    // Structured input reaches the parallel partition's fix-up in ways random boxes do not: an icosphere
    // followed by a height field under it in row order (the bench's kind of mesh), where whole blocks of
    // primitives go to one side of a split while earlier blocks are mixed.
    TriangleMesh m = make_icosphere(6, 1.0f);
    const auto base = static_cast<std::uint32_t>(m.vertices.size());
    constexpr std::uint32_t kGrid = 112;
    for (std::uint32_t j = 0; j <= kGrid; ++j)
        for (std::uint32_t i = 0; i <= kGrid; ++i) {
            const float x = -3.0f + 6.0f * float(i) / float(kGrid), y = -3.0f + 6.0f * float(j) / float(kGrid);
            m.vertices.emplace_back(x, y, -1.5f + 0.15f * std::sin(2.1f * x) * std::cos(1.7f * y));
        }
    for (std::uint32_t j = 0; j < kGrid; ++j)
        for (std::uint32_t i = 0; i < kGrid; ++i) {
            const std::uint32_t a = base + j * (kGrid + 1) + i;
            m.triangles.emplace_back(a, a + 1, a + kGrid + 2);
            m.triangles.emplace_back(a, a + kGrid + 2, a + kGrid + 1);
        }
    std::vector<Aabb> boxes(m.triangles.size());
    for (std::size_t i = 0; i < boxes.size(); ++i) boxes[i] = triangle_box(m, i);
    REQUIRE(boxes.size() >= 4 * BvhBuildSettings{}.parallel_threshold);
    check_structure(build_bvh(boxes, kMeshBuildSettings), boxes, kMeshBuildSettings.max_leaf_size,
                    kMeshBuildSettings.costs);
    check_structure(build_bvh(boxes), boxes, 4);
}

// Closest hit through traverse_bvh over a mesh stored in input order (used where no MeshBlas exists).
bool closest_hit_by_index(const Bvh& bvh, const TriangleMesh& m, const Ray& ray, RefHit& best) {
    const TriangleRay tr(ray);
    float tmax = ray.tmax;
    bool found = false;
    TraversalStats stats;
    traverse_bvh(bvh, BoxRay(ray), tmax, [&](std::uint32_t first, std::uint32_t count) {
        for (std::uint32_t k = first; k < first + count; ++k) {
            const std::uint32_t prim = bvh.prim_indices[k];
            const glm::uvec3 t = m.triangles[prim];
            TriangleHit h;
            if (intersect_triangle(tr, m.vertices[t.x], m.vertices[t.y], m.vertices[t.z], tmax, h)) {
                best = {prim, h.t, h.barycentrics, h.front_face};
                tmax = h.t;
                found = true;
            }
        }
        return false;
    }, stats);
    return found;
}

TEST_CASE("BVH refit: boxes stay tight after the primitives move, and traversal stays exact", "[bvh]") {
    TriangleMesh m = random_soup(3000, 0.1f, 31);
    m.triangles.erase(std::remove_if(m.triangles.begin(), m.triangles.end(),
                                     [](const glm::uvec3& t) { return t.x == t.y; }),
                      m.triangles.end());
    std::vector<Aabb> boxes(m.triangles.size());
    for (std::size_t i = 0; i < boxes.size(); ++i) boxes[i] = triangle_box(m, i);
    Bvh bvh = build_bvh(boxes);
    const auto topology = bvh.nodes;

    // Move every vertex (a swirl plus noise): triangles change size and place.
    Pcg32 rng(32);
    for (auto& v : m.vertices)
        v = glm::vec3(v.y * 0.8f + 0.3f, -v.x * 1.2f, v.z + 0.5f * v.x) +
            0.05f * glm::vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    for (std::size_t i = 0; i < boxes.size(); ++i) boxes[i] = triangle_box(m, i);
    bvh.refit(boxes);

    for (std::size_t i = 0; i < topology.size(); ++i) {
        REQUIRE(bvh.nodes[i].first == topology[i].first);
        REQUIRE(bvh.nodes[i].count == topology[i].count);
    }
    check_structure(bvh, boxes, 4);  // tight: every box is exactly the union of its primitives' boxes

    for (const Ray& r : random_rays(3000, 33)) {
        const auto hits = brute_force_hits(m, r);
        RefHit got{};
        const bool found = closest_hit_by_index(bvh, m, r, got);
        REQUIRE(found == !hits.empty());
        if (found) REQUIRE(got.t == min_t(hits));
    }
}

// ---------------------------------------------------------------------------------------------------
// The mesh BLAS and its queries

// The blocks hold each binary leaf's triangles, lane by lane in leaf order with their input indices, each
// leaf in blocks of its own (no two leaves share one), and zeros in the spare lanes.
void require_blocks_hold_leaves(const MeshBlas& blas) {
    const auto& nodes = blas.bvh().nodes;
    std::vector<int> owner(blas.block_count(), -1);
    std::vector<unsigned> lanes_used(blas.block_count(), 0);
    for (std::size_t i = 0; i < nodes.size(); ++i) {
        if (i == 1 || !nodes[i].is_leaf()) continue;
        const std::uint32_t b0 = blas.leaf_blocks()[i];
        REQUIRE(blas.leaf_block(nodes[i].first) == b0);
        for (std::uint32_t k = 0; k < nodes[i].count; ++k) {
            const std::uint32_t b = b0 + k / kTriangleBlockLanes, lane = k % kTriangleBlockLanes;
            REQUIRE(b < blas.block_count());
            REQUIRE((owner[b] == -1 || owner[b] == int(i)));
            owner[b] = int(i);
            lanes_used[b] = std::max(lanes_used[b], lane + 1);
            const MeshBlas::Triangle& t = blas.leaf_triangles()[nodes[i].first + k];
            const TriangleBlock& block = blas.blocks()[b];
            REQUIRE(block.vertex(lane, 0) == t.v0);
            REQUIRE(block.vertex(lane, 1) == t.v1);
            REQUIRE(block.vertex(lane, 2) == t.v2);
            REQUIRE(block.primitive[lane] == blas.primitive_id(nodes[i].first + k));
        }
    }
    for (std::size_t b = 0; b < blas.block_count(); ++b) {
        REQUIRE(owner[b] != -1);  // no block left unused
        for (unsigned lane = lanes_used[b]; lane < kTriangleBlockLanes; ++lane)
            for (int j = 0; j < 3; ++j) REQUIRE(blas.blocks()[b].vertex(lane, j) == glm::vec3(0.0f));
    }
}

TEST_CASE("MeshBlas: leaf triangles are the input triangles, degenerate ones left out", "[bvh]") {
    const TriangleMesh m = random_soup(2000, 0.2f, 41);
    const MeshBlas blas(m);
    std::size_t degenerate = 0;
    for (const auto& t : m.triangles) degenerate += is_degenerate(m.vertices[t.x], m.vertices[t.y], m.vertices[t.z]);
    REQUIRE(degenerate == 2000 / 97);
    REQUIRE(blas.input_triangle_count() == 2000);
    REQUIRE(blas.degenerate_count() == degenerate);
    REQUIRE(blas.leaf_triangles().size() == 2000 - degenerate);
    std::set<std::uint32_t> ids;
    std::vector<Aabb> boxes;
    for (std::uint32_t k = 0; k < blas.leaf_triangles().size(); ++k) {
        const std::uint32_t id = blas.primitive_id(k);
        REQUIRE(id < 2000);
        REQUIRE(ids.insert(id).second);
        const glm::uvec3 t = m.triangles[id];
        REQUIRE_FALSE(is_degenerate(m.vertices[t.x], m.vertices[t.y], m.vertices[t.z]));
        REQUIRE(blas.leaf_triangles()[k].v0 == m.vertices[t.x]);
        REQUIRE(blas.leaf_triangles()[k].v1 == m.vertices[t.y]);
        REQUIRE(blas.leaf_triangles()[k].v2 == m.vertices[t.z]);
    }
    require_blocks_hold_leaves(blas);
    // The tree's leaf ranges cover exactly the kept triangles.
    std::vector<Aabb> leaf_order_boxes;
    for (const auto& t : blas.leaf_triangles()) {
        Aabb b;
        b.grow(t.v0);
        b.grow(t.v1);
        b.grow(t.v2);
        leaf_order_boxes.push_back(b);
    }
    Bvh identity = blas.bvh();
    for (std::uint32_t k = 0; k < identity.prim_indices.size(); ++k) identity.prim_indices[k] = k;
    check_structure(identity, leaf_order_boxes, kMeshBuildSettings.max_leaf_size);

    TriangleMesh bad = m;
    bad.triangles[5].y = std::uint32_t(bad.vertices.size());
    REQUIRE_THROWS_AS(MeshBlas(bad), std::out_of_range);
    REQUIRE(MeshBlas(TriangleMesh{}).bvh().empty());
}

// Why closest hit must equal brute force EXACTLY (t bit for bit): the BLAS tests each triangle with
// intersect_triangle on bit-identical vertex copies and the same per-ray set-up, so a triangle's t is
// the same float in both; the traversal can only differ by not testing a triangle, and the conservative
// slab test (test_geometry.cpp) never culls the box of the nearest one. Ties (two triangles at the same
// float t) may be resolved either way: the primitive must be one of the tied ones.
TEST_CASE("Closest hit equals brute force over all triangles on random soups", "[bvh]") {
    for (float size : {0.02f, 0.1f, 0.4f}) {
        const TriangleMesh m = random_soup(2000, size, 51 + std::uint64_t(size * 100));
        for (unsigned leaf : {1u, 4u, 8u}) {
            BvhBuildSettings settings;
            settings.max_leaf_size = leaf;
            const MeshBlas blas(m, settings);
            int hit_rays = 0;
            for (const Ray& r : random_rays(4000, 52)) {
                const auto hits = brute_force_hits(m, r);
                BlasHit got;
                BlasCounters counters;
                const bool found = closest_hit(blas, r, got, counters);
                INFO("size " << size << " leaf " << leaf);
                REQUIRE(found == !hits.empty());
                REQUIRE(counters.any_hit_invocations == 0);
                if (!found) continue;
                ++hit_rays;
                REQUIRE(got.t == min_t(hits));
                const auto same = std::find_if(hits.begin(), hits.end(),
                                               [&](const RefHit& h) { return h.prim == got.primitive; });
                REQUIRE(same != hits.end());
                REQUIRE(same->t == got.t);
                REQUIRE(same->barycentrics == got.barycentrics);
                REQUIRE(same->front == got.front_face);
            }
            CHECK(hit_rays > 200);
        }
    }
}

TEST_CASE("Any-hit traversal that ignores every candidate reports exactly the brute-force hits", "[bvh]") {
    const TriangleMesh m = random_soup(3000, 0.15f, 61);
    const MeshBlas blas(m);
    Pcg32 rng(62);
    long total = 0;
    for (Ray r : random_rays(4000, 63)) {
        // Half the rays get a finite window [tmin, tmax].
        if (rng.next_u32() & 1) {
            r.tmin = rng.uniform(0.0f, 0.5f);
            r.tmax = r.tmin + rng.uniform(0.0f, 1.0f);
        }
        auto expected = brute_force_hits(m, r);
        std::vector<std::pair<std::uint32_t, float>> seen;
        BlasHit committed;
        committed.primitive = 12345;
        BlasCounters counters;
        const bool accepted = any_hit_traversal(blas, r, [&](const BlasHit& h) {
            seen.emplace_back(h.primitive, h.t);
            return AnyHitDecision::ignore;
        }, committed, counters);
        REQUIRE_FALSE(accepted);
        REQUIRE(committed.primitive == 12345);  // nothing committed
        REQUIRE(counters.any_hit_invocations == seen.size());
        std::vector<std::pair<std::uint32_t, float>> want;
        for (const auto& h : expected) {
            REQUIRE(h.t >= r.tmin);
            want.emplace_back(h.prim, h.t);
        }
        std::sort(seen.begin(), seen.end());
        std::sort(want.begin(), want.end());
        REQUIRE(seen == want);
        total += long(seen.size());
    }
    CHECK(total > 10000);
}

TEST_CASE("Any-hit decisions: ignore, accept and accept_and_end", "[bvh]") {
    const TriangleMesh m = random_soup(2000, 0.2f, 71);
    const MeshBlas blas(m);
    const auto rays = random_rays(3000, 72);
    int multi_hit_rays = 0;
    for (const Ray& r : rays) {
        const auto hits = brute_force_hits(m, r);
        if (hits.size() < 2) continue;
        ++multi_hit_rays;

        {  // accept everything: the closest hit, and no candidate beyond the committed t
            float committed_t = r.tmax;
            BlasHit committed;
            BlasCounters counters;
            const bool found = any_hit_traversal(blas, r, [&](const BlasHit& h) {
                REQUIRE(h.t <= committed_t);  // tmax shrank to the last accepted hit
                REQUIRE(h.t >= r.tmin);
                committed_t = h.t;
                return AnyHitDecision::accept;
            }, committed, counters);
            REQUIRE(found);
            REQUIRE(committed.t == min_t(hits));
            REQUIRE(counters.any_hit_invocations >= 1);
            REQUIRE(counters.any_hit_invocations <= hits.size());
        }
        {  // accept only even primitives (an alpha test): ignored candidates do not shrink tmax
            float committed_t = r.tmax;
            std::map<std::uint32_t, int> offered;
            BlasHit committed;
            BlasCounters counters;
            const bool found = any_hit_traversal(blas, r, [&](const BlasHit& h) {
                REQUIRE(h.t <= committed_t);
                ++offered[h.primitive];
                if (h.primitive % 2) return AnyHitDecision::ignore;
                committed_t = h.t;
                return AnyHitDecision::accept;
            }, committed, counters);
            float best_even = kInf;
            for (const auto& h : hits)
                if (h.prim % 2 == 0) best_even = std::min(best_even, h.t);
            REQUIRE(found == (best_even < kInf));
            if (found) {
                REQUIRE(committed.t == best_even);
                REQUIRE(committed.primitive % 2 == 0);
            }
            // Every hit not beyond the final committed t must have been offered, exactly once.
            for (const auto& h : hits)
                if (h.t <= committed_t) REQUIRE(offered[h.prim] == 1);
            for (const auto& [prim, times] : offered) REQUIRE(times == 1);
        }
        {  // accept_and_end on the first candidate ends the search
            BlasHit committed;
            BlasCounters counters;
            int calls = 0;
            const bool found = any_hit_traversal(blas, r, [&](const BlasHit&) {
                ++calls;
                return AnyHitDecision::accept_and_end;
            }, committed, counters);
            REQUIRE(found);
            REQUIRE(calls == 1);
            REQUIRE(counters.any_hit_invocations == 1);
            const auto same = std::find_if(hits.begin(), hits.end(), [&](const RefHit& h) { return h.prim == committed.primitive; });
            REQUIRE(same != hits.end());
            REQUIRE(same->t == committed.t);
        }
        {  // accept_and_end on the second candidate, after ignoring the first
            BlasHit committed;
            BlasCounters counters;
            std::vector<BlasHit> offered;
            const bool found = any_hit_traversal(blas, r, [&](const BlasHit& h) {
                offered.push_back(h);
                return offered.size() == 2 ? AnyHitDecision::accept_and_end : AnyHitDecision::ignore;
            }, committed, counters);
            REQUIRE(found);
            REQUIRE(offered.size() == 2);
            REQUIRE(committed.primitive == offered[1].primitive);
            REQUIRE(committed.t == offered[1].t);
            REQUIRE(counters.any_hit_invocations == 2);
        }
    }
    CHECK(multi_hit_rays > 300);
}

// The exact counters of an ignore-everything traversal of a mesh BLAS's wide tree: tmax never shrinks, so
// the traversal visits exactly the wide nodes and leaves whose box and all of whose ancestors' boxes the
// ray enters, and tests the boxes of every filled slot of each node it visits (the root's own box is not
// tested). Boxes are tested here with the scalar intersect().
struct ExpectedCounters {
    std::uint32_t nodes = 0, boxes = 0, prims = 0;
};
template <unsigned W>
Aabb slot_box(const BlasWideNode<W>& n, unsigned i) {
    Aabb b;
    b.lo = glm::vec3(n.bounds[0][i], n.bounds[1][i], n.bounds[2][i]);
    b.hi = glm::vec3(n.bounds[3][i], n.bounds[4][i], n.bounds[5][i]);
    return b;
}
template <unsigned W>
void expected_counters(const BlasWideBvh<W>& bvh, const BoxRay& br, float tmax, std::uint32_t node,
                       ExpectedCounters& c) {
    ++c.nodes;
    const BlasWideNode<W>& n = bvh.nodes()[node];
    for (unsigned i = 0; i < n.used; ++i) {
        ++c.boxes;
        float t;
        if (!intersect(slot_box(n, i), br, tmax, t)) continue;
        if ((n.leaves >> i) & 1u) {
            ++c.nodes;
            c.prims += n.count[i];
        } else {
            expected_counters(bvh, br, tmax, n.child[i], c);
        }
    }
}

TEST_CASE("Traversal counters: exact for an ignore-all search, plausible for closest hit", "[bvh]") {
    const TriangleMesh m = random_soup(4000, 0.1f, 81);
    const MeshBlas blas(m);
    long closest_nodes = 0, all_nodes = 0;
    for (const Ray& r : random_rays(3000, 82)) {
        ExpectedCounters want;
        expected_counters(blas.wide(), BoxRay(r), r.tmax, 0, want);
        const auto hits = brute_force_hits(m, r);

        BlasHit committed;
        BlasCounters all;
        any_hit_traversal(blas, r, [](const BlasHit&) { return AnyHitDecision::ignore; }, committed, all);
        REQUIRE(all.traversal.nodes_visited == want.nodes);
        REQUIRE(all.traversal.boxes_tested == want.boxes);
        REQUIRE(all.traversal.primitives_tested == want.prims);
        REQUIRE(all.any_hit_invocations == hits.size());

        BlasCounters closest;
        closest_hit(blas, r, committed, closest);
        const TraversalStats& s = closest.traversal;
        REQUIRE(s.nodes_visited <= s.boxes_tested);  // a node is visited only after its box was tested
        REQUIRE(s.boxes_tested <= kMeshBlasWidth * s.nodes_visited);  // at most W slots per node
        REQUIRE(s.nodes_visited <= all.traversal.nodes_visited);  // shrinking tmax only prunes
        REQUIRE(s.primitives_tested <= all.traversal.primitives_tested);
        REQUIRE(s.primitives_tested <= blas.leaf_triangles().size());
        REQUIRE(closest.any_hit_invocations == 0);
        if (!hits.empty()) REQUIRE(s.primitives_tested >= 1);
        closest_nodes += s.nodes_visited;
        all_nodes += all.traversal.nodes_visited;
    }
    // Front-to-back order with tmax pruning visits fewer nodes than the exhaustive search.
    CHECK(closest_nodes < all_nodes);
    // Counters accumulate across calls (per-ray counters are the caller's fresh struct).
    BlasCounters twice;
    BlasHit h;
    const Ray r = random_rays(1, 83)[0];
    closest_hit(blas, r, h, twice);
    const auto once = twice.traversal.nodes_visited;
    closest_hit(blas, r, h, twice);
    CHECK(twice.traversal.nodes_visited == 2 * once);
}

TEST_CASE("Traversal stays exact on a maximally deep tree", "[bvh]") {
    // Triangles on the six adversarial chains: the tree reaches the depth bound, so the traversal stack
    // (kMaxBvhDepth + 1 entries) is used to its limit. Each triangle spans its chain box exactly.
    TriangleMesh m;
    const auto items = six_chain_items();
    std::vector<glm::vec3> centroids;
    for (const auto& it : items) {
        const auto base = std::uint32_t(m.vertices.size());
        m.vertices.push_back(it.centre + it.size * glm::vec3(-1, -1, -1));
        m.vertices.push_back(it.centre + it.size * glm::vec3(1, 1, -1));
        m.vertices.push_back(it.centre + it.size * glm::vec3(-1, 1, 1));
        m.triangles.push_back({base, base + 1, base + 2});
        centroids.push_back((m.vertices[base] + m.vertices[base + 1] + m.vertices[base + 2]) / 3.0f);
    }
    for (unsigned leaf : {1u, 4u}) {
        const MeshBlas blas(m, BvhBuildSettings{{}, leaf});
        REQUIRE(blas.bvh().depth() >= kMaxBvhDepth - 8);
        REQUIRE(blas.bvh().depth() <= kMaxBvhDepth);
        // Rays aimed at each triangle's centroid from a distance of a few times its size.
        Pcg32 rng(91);
        for (std::size_t i = 0; i < items.size(); ++i)
            for (int k = 0; k < 20; ++k) {
                const glm::vec3 u(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
                Ray r;
                r.origin = centroids[i] + 8.0f * items[i].size * u;
                r.direction = -u;
                const auto hits = brute_force_hits(m, r);
                BlasHit got;
                BlasCounters c;
                REQUIRE(closest_hit(blas, r, got, c) == !hits.empty());
                if (!hits.empty()) REQUIRE(got.t == min_t(hits));
                std::size_t all = 0;
                any_hit_traversal(blas, r, [&](const BlasHit&) { ++all; return AnyHitDecision::ignore; }, got, c);
                REQUIRE(all == hits.size());
            }
    }
}

TEST_CASE("Closest hit keeps a triangle lying in a face of its box when a commit lands just behind it", "[bvh]") {
    // A ground triangle (flat box) and a small upright triangle whose hit lies one float ulp behind the
    // ground's: brute force (the same triangle function) says the ground is nearer, so closest_hit must
    // return it. The ground's box entry is computed from the plane z = 0 exactly, while the triangle
    // test's t carries an error relative to the distance of its far vertices (|v − o| ~ 1400 here against
    // t·|d| ~ 3): the box of the nearer triangle must not be skipped by the pop test.
    Ray r;
    r.origin = {0.1f, 0.7f, 1.0f};
    r.direction = {0.3f, -1.9f, -0.7f};
    const glm::vec3 g0(-1000, -1000, 0), g1(1000, -1000, 0), g2(0, 1000, 0);
    TriangleHit ground{};
    REQUIRE(intersect_triangle(TriangleRay(r), g0, g1, g2, kInf, ground));
    const float t_blocker = std::nextafter(ground.t, kInf);
    const glm::vec3 p = r.origin + t_blocker * r.direction;
    TriangleMesh m;
    m.vertices = {g0, g1, g2, {p.x, p.y - 0.01f, p.z - 0.01f}, {p.x, p.y + 0.01f, p.z - 0.01f}, {p.x, p.y, p.z + 0.01f}};
    m.triangles = {{0, 1, 2}, {3, 4, 5}};
    const auto hits = brute_force_hits(m, r);
    REQUIRE(hits.size() == 2);
    REQUIRE(hits[0].t < hits[1].t);  // precondition: the ground is the nearer by the triangle function
    const MeshBlas blas(m, BvhBuildSettings{{}, 1});
    BlasHit got;
    BlasCounters c;
    REQUIRE(closest_hit(blas, r, got, c));
    INFO("ground t " << std::setprecision(9) << hits[0].t << ", blocker t " << hits[1].t << ", returned t " << got.t);
    CHECK(got.primitive == 0);
    CHECK(got.t == hits[0].t);
}

// ---------------------------------------------------------------------------------------------------
// Stand-in meshes

// A float vertex of a unit-scale mesh is within half an ulp per coordinate of its double position;
// 4 float epsilons of the radius bounds both that and the length of the rounded vector.
constexpr double kVertexTol = 4.0 * std::numeric_limits<float>::epsilon();

// Closed and consistently oriented: every directed edge exactly once, and its reverse exactly once.
void check_closed(const TriangleMesh& m) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
    for (const auto& t : m.triangles)
        for (int e = 0; e < 3; ++e) ++directed[{t[e], t[(e + 1) % 3]}];
    for (const auto& [edge, count] : directed) {
        REQUIRE(count == 1);
        const auto reverse = directed.find({edge.second, edge.first});
        REQUIRE(reverse != directed.end());
        REQUIRE(reverse->second == 1);
    }
    // Euler characteristic of a sphere: V − E + F = 2.
    REQUIRE(long(m.vertices.size()) - long(directed.size() / 2) + long(m.triangles.size()) == 2);
}

// Every face counter-clockwise seen from outside (normal away from the centre), and the mesh strictly
// convex: every other vertex strictly on the inner side of each face's plane.
void check_outward_and_convex(const TriangleMesh& m) {
    for (const auto& t : m.triangles) {
        const glm::dvec3 a(m.vertices[t.x]), b(m.vertices[t.y]), c(m.vertices[t.z]);
        const glm::dvec3 n = glm::cross(b - a, c - a);
        REQUIRE(glm::dot(n, a + b + c) > 0.0);
        for (std::size_t k = 0; k < m.vertices.size(); ++k) {
            if (k == t.x || k == t.y || k == t.z) continue;
            REQUIRE(glm::dot(n, glm::dvec3(m.vertices[k]) - a) < 0.0);
        }
    }
}

TEST_CASE("Icosahedron: the normalised cyclic permutations of (0, ±1, ±φ), 20 outward faces", "[bvh]") {
    for (float radius : {1.0f, 0.25f, 3.0f}) {
        const TriangleMesh m = make_icosahedron(radius);
        REQUIRE(m.vertices.size() == 12);
        REQUIRE(m.triangles.size() == 20);
        const double phi = (1.0 + std::sqrt(5.0)) / 2.0;
        std::vector<glm::dvec3> expected;
        for (double s1 : {-1.0, 1.0})
            for (double s2 : {-phi, phi}) {
                expected.push_back(glm::normalize(glm::dvec3(0, s1, s2)) * double(radius));
                expected.push_back(glm::normalize(glm::dvec3(s1, s2, 0)) * double(radius));
                expected.push_back(glm::normalize(glm::dvec3(s2, 0, s1)) * double(radius));
            }
        std::vector<int> matched(12, 0);
        for (const auto& v : m.vertices) {
            REQUIRE(std::abs(glm::length(glm::dvec3(v)) - radius) <= kVertexTol * radius);  // on the sphere
            int matches = 0;
            for (int k = 0; k < 12; ++k)
                if (glm::length(glm::dvec3(v) - expected[k]) <= kVertexTol * radius) {
                    ++matches;
                    ++matched[k];
                }
            REQUIRE(matches == 1);
        }
        for (int k = 0; k < 12; ++k) REQUIRE(matched[k] == 1);
        // All 30 edges have the icosahedron's edge length 2r/|(0, 1, φ)|.
        const double edge = 2.0 * radius / std::sqrt(1.0 + phi * phi);
        for (const auto& t : m.triangles)
            for (int e = 0; e < 3; ++e) {
                const double len = glm::length(glm::dvec3(m.vertices[t[e]]) - glm::dvec3(m.vertices[t[(e + 1) % 3]]));
                REQUIRE(std::abs(len - edge) <= 2.0 * kVertexTol * radius);
            }
        check_closed(m);
        check_outward_and_convex(m);
    }
}

TEST_CASE("Icospheres: 20·4^L faces on the sphere, closed, outward, convex", "[bvh]") {
    const TriangleMesh ico = make_icosahedron(1.0f);
    for (int level = 0; level <= 4; ++level) {
        const float radius = level % 2 ? 2.0f : 1.0f;
        const TriangleMesh m = make_icosphere(level, radius);
        INFO("level " << level);
        REQUIRE(m.triangles.size() == 20u << (2 * level));
        REQUIRE(m.vertices.size() == (10u << (2 * level)) + 2);
        for (const auto& v : m.vertices) REQUIRE(std::abs(glm::length(glm::dvec3(v)) - radius) <= kVertexTol * radius);
        check_closed(m);
        check_outward_and_convex(m);
        if (level == 0) {
            REQUIRE(m.vertices == ico.vertices);
            REQUIRE(m.triangles == ico.triangles);
        }
        // A ray through the centre crosses the closed surface twice: in through a front face, out through
        // a back face.
        const MeshBlas blas(m);
        std::vector<BlasHit> seen;
        Ray r;
        r.origin = {0.3f, -5.0f, 0.2f};
        r.direction = {-0.05f, 1.0f, 0.02f};
        BlasHit h;
        BlasCounters c;
        any_hit_traversal(blas, r, [&](const BlasHit& hit) { seen.push_back(hit); return AnyHitDecision::ignore; }, h, c);
        REQUIRE(seen.size() == 2);
        std::sort(seen.begin(), seen.end(), [](const BlasHit& a, const BlasHit& b) { return a.t < b.t; });
        REQUIRE(seen[0].front_face);
        REQUIRE_FALSE(seen[1].front_face);
    }
    REQUIRE_THROWS(make_icosphere(-1));
    REQUIRE_THROWS(make_icosphere(9));
}

// A ray for the box tests' comparisons with the scalar slab test: origins often exactly on the slab planes
// -1, -0.5, 0, 0.5, 1 (0·∞ = NaN there), direction components of +0 and −0, tmin and tmax often 0 or ∞.
Ray box_test_ray(Pcg32& rng, float& tmax) {
    const float planes[] = {-1.0f, -0.5f, 0.0f, 0.5f, 1.0f};
    Ray r;
    for (int k = 0; k < 3; ++k) {
        r.origin[k] = rng.next_u32() % 3 ? planes[rng.next_u32() % 5] : rng.uniform(-2.0f, 2.0f);
        const std::uint32_t kind = rng.next_u32() % 5;
        r.direction[k] = kind == 0 ? 0.0f : kind == 1 ? -0.0f : rng.uniform(-1.0f, 1.0f);
    }
    if (r.direction == glm::vec3(0.0f)) r.direction.x = 1.0f;
    r.tmin = rng.next_u32() % 2 ? 0.0f : rng.uniform(0.0f, 1.0f);
    tmax = rng.next_u32() % 3 ? kInf : rng.uniform(0.0f, 2.0f);
    return r;
}

}  // namespace

TEST_CASE("Grouped build: no node below the top mixes groups, every primitive once, boxes exact", "[bvh]") {
    // Three interleaved groups of random boxes, as the TLAS's stand-ins, billboards and ground are.
    Pcg32 rng(77);
    std::vector<Aabb> boxes;
    std::vector<std::uint32_t> group;
    for (int i = 0; i < 3000; ++i) {
        const glm::vec3 c(rng.uniform(-10, 10), rng.uniform(-10, 10), rng.uniform(-10, 10));
        const float r = rng.uniform(0.1f, 1.0f);
        Aabb b;
        b.grow(c - r);
        b.grow(c + r);
        boxes.push_back(b);
        group.push_back(i % 7 == 0 ? 4u : (i % 2 == 0 ? 1u : 2u));
    }
    const Bvh bvh = build_grouped_bvh(boxes, group, BvhBuildSettings{{}, 1});
    REQUIRE(bvh.prim_indices.size() == boxes.size());
    std::vector<int> seen(boxes.size(), 0);
    for (std::uint32_t p : bvh.prim_indices) ++seen.at(p);
    CHECK(std::all_of(seen.begin(), seen.end(), [](int s) { return s == 1; }));
    // Per node: the set of groups below it, and the box must be exactly the union of its primitives'.
    std::vector<std::set<std::uint32_t>> below(bvh.nodes.size());
    std::vector<Aabb> exact(bvh.nodes.size());
    for (std::size_t k = bvh.nodes.size(); k-- > 0;) {
        if (k == 1) continue;
        const BvhNode& n = bvh.nodes[k];
        if (n.is_leaf()) {
            for (std::uint32_t i = 0; i < n.count; ++i) {
                below[k].insert(group[bvh.prim_indices[n.first + i]]);
                exact[k].grow(boxes[bvh.prim_indices[n.first + i]]);
            }
        } else {
            REQUIRE(n.first > k);  // depth-first: a pair comes after its parent
            for (std::uint32_t c : {n.first, n.first + 1}) {
                below[k].insert(below[c].begin(), below[c].end());
                exact[k].grow(exact[c]);
            }
        }
        CHECK(n.bounds.lo == exact[k].lo);
        CHECK(n.bounds.hi == exact[k].hi);
    }
    // Nodes whose subtree holds one group: every primitive is under such a node whose parent mixes groups
    // (the top tree) — i.e. exactly three maximal single-group subtrees.
    int maximal_single = 0;
    for (std::size_t k = 0; k < bvh.nodes.size(); ++k) {
        if (k == 1 || bvh.nodes[k].is_leaf()) continue;
        const BvhNode& n = bvh.nodes[k];
        if (below[k].size() > 1)
            for (std::uint32_t c : {n.first, n.first + 1}) maximal_single += below[c].size() == 1 ? 1 : 0;
    }
    CHECK(maximal_single == 3);
    CHECK(below[0].size() == 3);
}

// The grouped TLAS build against its definition, built here from the plain builder: each group's tree
// over its members' boxes (in primitive order) joined under the tree of the groups' boxes, copied node by
// node depth-first (a node's pair appended when the node is reached, left subtree first), leaves mapped to
// global indices. The builder makes each group's tree in place, one primitive per leaf, in parallel: the
// same array, at any thread count.
namespace {
void append_reference(const Bvh& src, std::uint32_t node, const std::vector<std::uint32_t>& to_global, Bvh& dst,
                      std::uint32_t slot) {
    const BvhNode n = src.nodes[node];
    dst.nodes[slot].bounds = n.bounds;
    dst.nodes[slot].count = n.count;
    if (n.is_leaf()) {
        dst.nodes[slot].first = static_cast<std::uint32_t>(dst.prim_indices.size());
        for (std::uint32_t i = 0; i < n.count; ++i)
            dst.prim_indices.push_back(to_global[src.prim_indices[n.first + i]]);
        return;
    }
    const auto pair = static_cast<std::uint32_t>(dst.nodes.size());
    dst.nodes.resize(dst.nodes.size() + 2);
    dst.nodes[slot].first = pair;
    append_reference(src, n.first, to_global, dst, pair);
    append_reference(src, n.first + 1, to_global, dst, pair + 1);
}

void join_reference(const Bvh& top, std::uint32_t node, const std::vector<Bvh>& trees,
                    const std::vector<std::vector<std::uint32_t>>& members, Bvh& dst, std::uint32_t slot) {
    const BvhNode n = top.nodes[node];
    if (n.is_leaf()) {
        const std::uint32_t g = top.prim_indices[n.first];
        return append_reference(trees[g], 0, members[g], dst, slot);
    }
    const auto pair = static_cast<std::uint32_t>(dst.nodes.size());
    dst.nodes.resize(dst.nodes.size() + 2);
    dst.nodes[slot] = BvhNode{n.bounds, pair, 0};
    join_reference(top, n.first, trees, members, dst, pair);
    join_reference(top, n.first + 1, trees, members, dst, pair + 1);
}
}  // namespace

TEST_CASE("Grouped build: the joined per-group trees, the same node array with 1, 2 and 8 threads", "[bvh]") {
    // A large group (its top levels bin and partition in parallel), a small one and a single primitive: the
    // smoke scene's stand-ins, billboards and ground.
    Pcg32 rng(2026);
    std::vector<Aabb> boxes;
    std::vector<std::uint32_t> group;
    for (int i = 0; i < 120000; ++i) {
        const glm::vec3 c(rng.uniform(-10, 10), rng.uniform(-3, 3), rng.uniform(-10, 10));
        const float r = rng.uniform(0.01f, 0.2f);
        boxes.push_back(Aabb{c - r, c + r});
        group.push_back(i == 777 ? 4u : (i % 10 == 0 ? 2u : 1u));
    }
    const BvhBuildSettings settings{{}, 1};
    // The reference, from build_bvh() of each group on one thread.
    Bvh reference;
    {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
        const std::vector<std::uint32_t> keys{1, 2, 4};
        std::vector<std::vector<std::uint32_t>> members(keys.size());
        for (std::uint32_t i = 0; i < boxes.size(); ++i)
            members[std::size_t(std::find(keys.begin(), keys.end(), group[i]) - keys.begin())].push_back(i);
        std::vector<Bvh> trees;
        std::vector<Aabb> group_boxes;
        for (const auto& m : members) {
            std::vector<Aabb> b;
            for (std::uint32_t i : m) b.push_back(boxes[i]);
            trees.push_back(build_bvh(b, settings));
            group_boxes.push_back(trees.back().bounds());
        }
        const Bvh top = build_bvh(group_boxes, settings);
        reference.nodes.resize(2);
        reference.nodes[1] = BvhNode{Aabb{}, 0, 0};
        join_reference(top, 0, trees, members, reference, 0);
    }
    for (int threads : {1, 2, 8}) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
        const Bvh bvh = build_grouped_bvh(boxes, group, settings);
        INFO("threads " << threads);
        REQUIRE(bvh.nodes.size() == reference.nodes.size());
        REQUIRE(bvh.prim_indices == reference.prim_indices);
        for (std::size_t i = 0; i < bvh.nodes.size(); ++i) {
            REQUIRE(bvh.nodes[i].bounds.lo == reference.nodes[i].bounds.lo);
            REQUIRE(bvh.nodes[i].bounds.hi == reference.nodes[i].bounds.hi);
            REQUIRE(bvh.nodes[i].first == reference.nodes[i].first);
            REQUIRE(bvh.nodes[i].count == reference.nodes[i].count);
        }
    }
}

TEST_CASE("BVH builder: one primitive per leaf, built in place, is the depth-first layout of its own tree",
          "[bvh]") {
    // The in-place build computes where each pair goes; a depth-first copy of the tree it built (a pair
    // appended when its node is reached, left subtree first) must give back the same array.
    const auto boxes = random_boxes(50000, 91);
    const Bvh bvh = build_bvh(boxes, BvhBuildSettings{{}, 1});
    check_structure(bvh, boxes, 1);
    Bvh copy;
    copy.nodes.resize(2);
    copy.nodes[1] = BvhNode{Aabb{}, 0, 0};
    std::vector<std::uint32_t> identity(boxes.size());
    for (std::uint32_t i = 0; i < identity.size(); ++i) identity[i] = i;
    append_reference(bvh, 0, identity, copy, 0);
    REQUIRE(copy.nodes.size() == bvh.nodes.size());
    CHECK(copy.prim_indices == bvh.prim_indices);
    for (std::size_t i = 0; i < bvh.nodes.size(); ++i) {
        REQUIRE(copy.nodes[i].first == bvh.nodes[i].first);
        REQUIRE(copy.nodes[i].count == bvh.nodes[i].count);
    }
}

// ChildPairTest (the AVX2 two-box test of child_pair_test_avx2.hpp where available, the scalar one
// otherwise) must agree with the scalar slab test of aabb.hpp on every ray: the same hit bits and equal
// entry distances. The rays
// include the cases the scalar test is careful about: direction components of +0 and −0, origins exactly
// on slab planes (0·∞ = NaN there), tmin and tmax exactly at a box face, and boxes that are flat.
TEST_CASE("BVH traversal: the paired child test equals the scalar slab test on every ray", "[bvh]") {
    alignas(64) BvhNode pair[2];
    Pcg32 rng(77);
    const float planes[] = {-1.0f, -0.5f, 0.0f, 0.5f, 1.0f};
    auto pick = [&](std::span<const float> v) { return v[rng.next_u32() % v.size()]; };
    std::uint64_t checked = 0, hits = 0;
    for (int i = 0; i < 200000; ++i) {
        for (BvhNode& n : pair) {
            glm::vec3 a, b;
            for (int k = 0; k < 3; ++k) {
                // Mostly planes from a small set (so origins land exactly on faces), some random.
                a[k] = rng.next_u32() % 4 ? pick(planes) : rng.uniform(-1.0f, 1.0f);
                b[k] = rng.next_u32() % 4 ? pick(planes) : rng.uniform(-1.0f, 1.0f);
            }
            n.bounds = Aabb{glm::min(a, b), glm::max(a, b)};
            n.first = rng.next_u32();
            n.count = rng.next_u32();
        }
        float tmax = 0.0f;
        const Ray r = box_test_ray(rng, tmax);
        const BoxRay br(r);
        float tl = -1.0f, tr = -1.0f, sl = -1.0f, sr = -1.0f;
        const unsigned bits = ChildPairTest(br).test(pair, tmax, tl, tr);
        const bool hl = intersect(pair[0].bounds, br, tmax, sl), hr = intersect(pair[1].bounds, br, tmax, sr);
        INFO("ray " << i);
        REQUIRE(bits == (unsigned(hl) | unsigned(hr) << 1));
        // Entry distances are compared where the scalar test reports them as meaningful (a hit); as
        // floats, so that +0 and −0 (which the two reductions may order differently) count as equal.
        if (hl) REQUIRE(tl == sl);
        if (hr) REQUIRE(tr == sr);
        REQUIRE_FALSE(std::isnan(tl));
        REQUIRE_FALSE(std::isnan(tr));
        hits += unsigned(hl) + unsigned(hr);
        ++checked;
    }
    // The generator really produces both (about 7 % of the boxes are hit: many are flat or missed).
    CHECK(hits > checked / 20);
    CHECK(hits < checked * 2 - checked / 4);
}

// WideBoxTest (four lanes of floats: SSE2 on x86-64, the lanes' scalar definition elsewhere) against the
// scalar slab test, child by child: the same hit bits and, where a child is hit, the same entry distance
// bit for bit (the same operations in the same order, so not even the sign of a zero may differ). And
// admitted_children() against the mask bytes one by one.
// The greedy collapse the wide trees used before the least-area cut: start from a node's two children and
// keep opening the inner slot of largest box area while fewer than `width` are taken. One feasible cut, the
// baseline the cut's area is compared with. Writes the slots (room for `width`); returns their count.
unsigned greedy_slots(const Bvh& binary, std::uint32_t node, unsigned width, std::uint32_t* slot) {
    const BvhNode& top = binary.nodes[node];
    if (top.is_leaf()) {
        slot[0] = node;
        return 1;
    }
    unsigned n = 0;
    slot[n++] = top.first;
    slot[n++] = top.first + 1;
    while (n < width) {
        int best = -1;
        float best_area = -1.0f;
        for (unsigned i = 0; i < n; ++i)
            if (const BvhNode& c = binary.nodes[slot[i]]; !c.is_leaf() && c.bounds.area() > best_area) {
                best = int(i);
                best_area = c.bounds.area();
            }
        if (best < 0) break;
        const std::uint32_t opened = binary.nodes[slot[best]].first;
        slot[best] = opened;
        slot[n++] = opened + 1;
    }
    return n;
}

// The total box area of the wide inner nodes a slot rule makes from `binary` (each the box of the binary
// node it is made from) and their count.
template <class SlotRule>
std::pair<double, std::size_t> wide_inner_area(const Bvh& binary, unsigned width, SlotRule&& slots) {
    double area = 0.0;
    std::size_t nodes = 0;
    std::vector<std::uint32_t> todo{0};
    while (!todo.empty()) {
        const std::uint32_t b = todo.back();
        todo.pop_back();
        area += binary.nodes[b].bounds.area();
        ++nodes;
        std::uint32_t slot[16];
        const unsigned n = slots(b, slot);
        REQUIRE(n <= width);
        for (unsigned i = 0; i < n; ++i)
            if (!binary.nodes[slot[i]].is_leaf()) todo.push_back(slot[i]);
    }
    return {area, nodes};
}

// The 4-wide tree's layout, one node at a time: a node's inner children take the next indices when it is
// filled, and the last child's subtree is filled next, then the one before it. The slots are the least-area
// cut's (which cut that is, is checked against every cut of small trees below), ordered by order_slots().
struct ReferenceWideNode {
    std::uint32_t slot[kWideBvhWidth];  // the binary node of each used slot
    unsigned count;
    int axis;
    std::uint32_t child[kWideBvhWidth];
};
std::vector<ReferenceWideNode> reference_wide_layout(const Bvh& binary) {
    const WideCut<kWideBvhWidth> cut(binary);
    std::vector<ReferenceWideNode> nodes(1);
    std::vector<std::pair<std::uint32_t, std::uint32_t>> jobs{{0u, 0u}};  // (binary node, wide node)
    while (!jobs.empty()) {
        const auto [b, w] = jobs.back();
        jobs.pop_back();
        ReferenceWideNode n{};
        n.count = cut.slots(b, n.slot);
        n.axis = order_slots(binary, n.slot, n.count);
        for (unsigned i = 0; i < n.count; ++i) {
            const BvhNode& c = binary.nodes[n.slot[i]];
            n.child[i] = c.is_leaf() ? c.first : static_cast<std::uint32_t>(nodes.size());
            if (!c.is_leaf()) {
                jobs.emplace_back(n.slot[i], n.child[i]);
                nodes.emplace_back();
            }
        }
        nodes[w] = n;
    }
    return nodes;
}

TEST_CASE("Bottom-up sweep: each node once, after its children, and the sum's bits the same at 1, 2 and 8 threads",
          "[bvh]") {
    for (const std::size_t count : {std::size_t{1}, std::size_t{2}, std::size_t{3000}, std::size_t{120000}}) {
        const auto boxes = random_boxes(count, 95 + count);
        const Bvh bvh = build_bvh(boxes, BvhBuildSettings{{}, 1});
        // The serial definition: every node but the padding slot, backward.
        double backward = 0.0;
        for (std::size_t k = bvh.nodes.size(); k-- > 0;)
            if (k != 1 || bvh.nodes.size() == 1) backward += sah_term(bvh.nodes[k], SahCosts{});
        double first_sum = 0.0;
        for (const int threads : {1, 2, 8}) {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
            std::vector<std::atomic<int>> visits(bvh.nodes.size());
            std::atomic<int> early{0};
            const double sum = sweep_bottom_up(bvh, [&](std::uint32_t k) {
                const BvhNode& n = bvh.nodes[k];
                if (!n.is_leaf() && (visits[n.first].load() != 1 || visits[n.first + 1].load() != 1)) ++early;
                ++visits[k];
                return sah_term(n, SahCosts{});
            });
            INFO(count << " primitives, threads " << threads);
            CHECK(early.load() == 0);
            int wrong = 0;
            for (std::size_t k = 0; k < visits.size(); ++k)
                wrong += visits[k].load() != (k == 1 && visits.size() > 1 ? 0 : 1) ? 1 : 0;
            CHECK(wrong == 0);
            if (threads == 1) first_sum = sum;
            CHECK(sum == first_sum);
            // A tree within one task sums in backward array order; a larger one differs from it by rounding.
            if (bvh.nodes.size() <= kSerialSweepNodes) CHECK(sum == backward);
            CHECK(std::abs(sum - backward) <= 1e-12 * backward);
        }
    }
}

TEST_CASE("Wide BVH: the collapse of a large tree lays out its nodes depth first, slots and boxes as chosen, "
          "at 1, 2 and 8 threads",
          "[bvh]") {
    // 200k binary nodes: a dozen subtrees laid out by tasks of their own, below a top laid out serially.
    const auto boxes = random_boxes(100000, 93);
    const Bvh binary = build_bvh(boxes, BvhBuildSettings{{}, 1});
    REQUIRE(binary.nodes.size() > 8 * kSerialSweepNodes);
    std::vector<std::uint8_t> masks(binary.nodes.size());
    for (std::size_t k = 0; k < masks.size(); ++k) masks[k] = static_cast<std::uint8_t>(k * 37 + 1);
    const std::vector<ReferenceWideNode> want = reference_wide_layout(binary);
    const int threads = GENERATE(1, 2, 8);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
    WideBvh wide;
    wide.collapse(binary, masks);
    INFO("threads " << threads);
    REQUIRE(wide.node_count() == want.size());
    CHECK(wide.root_mask() == masks[0]);
    int bad = 0;
    for (std::size_t k = 0; k < want.size(); ++k) {
        const WideBvhNode& n = wide.nodes()[k];
        const ReferenceWideNode& r = want[k];
        bool ok = n.axis == r.axis;
        for (unsigned i = 0; i < kWideBvhWidth; ++i) {
            if (i >= r.count) {
                ok = ok && n.mask[i] == 0 && n.count[i] == 0 && n.bounds[0][i] == kInf && n.bounds[3][i] == -kInf;
                continue;
            }
            const BvhNode& c = binary.nodes[r.slot[i]];
            ok = ok && n.child[i] == r.child[i] && n.count[i] == c.count && n.mask[i] == masks[r.slot[i]] &&
                 ((n.leaves >> i) & 1u) == (c.is_leaf() ? 1u : 0u);
            const float* p = planes(c.bounds);
            for (int k6 = 0; k6 < 6; ++k6) ok = ok && n.bounds[k6][i] == p[k6];
        }
        bad += ok ? 0 : 1;
    }
    CHECK(bad == 0);
}

// Every cut of a small binary tree, by brute force: each set of inner nodes that holds the root and gives no
// wide node more than `width` slots (a wide node's slots: its children, where a child that is an inner node
// outside the set is opened into its own). Returns the least total area of such a set.
double least_cut_area(const Bvh& binary, unsigned width) {
    std::vector<std::uint32_t> inner;
    for (std::uint32_t i = 0; i < binary.nodes.size(); ++i)
        if (i != 1 && !binary.nodes[i].is_leaf()) inner.push_back(i);
    REQUIRE(inner.front() == 0u);
    REQUIRE(inner.size() <= 20);
    double best = std::numeric_limits<double>::infinity();
    std::vector<bool> wide(binary.nodes.size());
    for (std::uint32_t set = 0; set < (1u << (inner.size() - 1)); ++set) {
        std::fill(wide.begin(), wide.end(), false);
        wide[0] = true;
        for (std::size_t k = 1; k < inner.size(); ++k) wide[inner[k]] = ((set >> (k - 1)) & 1u) != 0;
        bool feasible = true;
        double area = 0.0;
        for (std::uint32_t w : inner) {
            if (!wide[w]) continue;
            area += binary.nodes[w].bounds.area();
            unsigned slots = 0;
            std::vector<std::uint32_t> open{binary.nodes[w].first, binary.nodes[w].first + 1};
            while (!open.empty()) {
                const std::uint32_t c = open.back();
                open.pop_back();
                if (binary.nodes[c].is_leaf() || wide[c]) ++slots;
                else open.insert(open.end(), {binary.nodes[c].first, binary.nodes[c].first + 1});
            }
            feasible = feasible && slots <= width;
        }
        if (feasible) best = std::min(best, area);
    }
    return best;
}

TEST_CASE("Wide BVH: the cut has the least inner-node area of every cut of small trees", "[bvh]") {
    // The cut's sums are in float, the brute force's in double: a near tie may go either way by rounding.
    constexpr double kTieTolerance = 1e-5;
    int strictly_better_than_greedy = 0;
    for (std::size_t n = 2; n <= 15; ++n)
        for (std::uint64_t seed = 0; seed < 8; ++seed) {
            const Bvh binary = build_bvh(random_boxes(n, 500 + 31 * n + seed), BvhBuildSettings{{}, 1});
            const WideCut<kWideBvhWidth> cut(binary);
            const auto [area, nodes] = wide_inner_area(binary, kWideBvhWidth, [&](std::uint32_t b, std::uint32_t* slot) {
                return cut.slots(b, slot);
            });
            const double least = least_cut_area(binary, kWideBvhWidth);
            CAPTURE(n, seed, area, least);
            CHECK(area <= least * (1.0 + kTieTolerance));
            CHECK(area >= least * (1.0 - kTieTolerance));
            const double greedy = wide_inner_area(binary, kWideBvhWidth, [&](std::uint32_t b, std::uint32_t* slot) {
                                      return greedy_slots(binary, b, kWideBvhWidth, slot);
                                  }).first;
            strictly_better_than_greedy += area < greedy * (1.0 - kTieTolerance) ? 1 : 0;
        }
    // Small trees where opening the largest child first is not the least-area cut exist: the cases are
    // not all ones both rules get right.
    CHECK(strictly_better_than_greedy > 0);
}

TEST_CASE("Wide BVH: the top level's wide tree weighs less inner area, in fewer nodes, than the greedy collapse",
          "[bvh]") {
    // A TLAS as AccelScene builds it (grouped by mask, one instance per leaf) over random instance boxes.
    const auto boxes = random_boxes(50000, 96);
    std::vector<std::uint32_t> groups(boxes.size());
    for (std::size_t i = 0; i < groups.size(); ++i) groups[i] = 1u << (i % 2);
    const Bvh binary = build_grouped_bvh(boxes, groups, BvhBuildSettings{{}, 1});
    const std::vector<std::uint8_t> masks(binary.nodes.size(), 0xFF);
    WideBvh wide;
    wide.collapse(binary, masks);
    double area = 0.0;
    for (std::size_t k = 0; k < wide.node_count(); ++k) {
        const WideBvhNode& n = wide.nodes()[k];
        Aabb box;
        unsigned used = 0;
        for (unsigned i = 0; i < kWideBvhWidth; ++i)
            if (n.mask[i] != 0) {
                ++used;
                box.grow(Aabb{{n.bounds[0][i], n.bounds[1][i], n.bounds[2][i]},
                              {n.bounds[3][i], n.bounds[4][i], n.bounds[5][i]}});
            }
        REQUIRE(used >= 2);
        area += box.area();
    }
    const auto [greedy_area, greedy_nodes] = wide_inner_area(binary, kWideBvhWidth, [&](std::uint32_t b, std::uint32_t* slot) {
        return greedy_slots(binary, b, kWideBvhWidth, slot);
    });
    CAPTURE(area, greedy_area, wide.node_count(), greedy_nodes);
    // The cut is found with float sums: a near tie may go either way by their rounding.
    CHECK(area <= greedy_area * (1.0 + 1e-5));
    CHECK(wide.node_count() < greedy_nodes);
}

TEST_CASE("Wide BVH traversal: the four-child box test equals the scalar slab test on every ray", "[bvh]") {
    Pcg32 rng(78);
    const float planes[] = {-1.0f, -0.5f, 0.0f, 0.5f, 1.0f};
    auto pick = [&](std::span<const float> v) { return v[rng.next_u32() % v.size()]; };
    std::uint64_t checked = 0, hits = 0;
    for (int i = 0; i < 100000; ++i) {
        WideBvhNode n{};
        for (unsigned c = 0; c < kWideBvhWidth; ++c) {
            for (int k = 0; k < 3; ++k) {
                const float a = rng.next_u32() % 4 ? pick(planes) : rng.uniform(-1.0f, 1.0f);
                const float b = rng.next_u32() % 4 ? pick(planes) : rng.uniform(-1.0f, 1.0f);
                n.bounds[k][c] = std::min(a, b);
                n.bounds[k + 3][c] = std::max(a, b);
            }
            n.mask[c] = std::uint8_t(rng.next_u32() % 3 == 0 ? 0u : rng.next_u32());
        }
        float tmax = 0.0f;
        const Ray r = box_test_ray(rng, tmax);
        const BoxRay br(r);
        alignas(16) float t[kWideBvhWidth];
        const unsigned bits = WideBoxTest<kWideBvhWidth>(br).test(n, tmax, t);
        const auto inclusion = std::uint8_t(rng.next_u32());
        const unsigned admitted = admitted_children(n, inclusion);
        INFO("ray " << i);
        for (unsigned c = 0; c < kWideBvhWidth; ++c) {
            Aabb box;
            box.lo = {n.bounds[0][c], n.bounds[1][c], n.bounds[2][c]};
            box.hi = {n.bounds[3][c], n.bounds[4][c], n.bounds[5][c]};
            float t_scalar = -1.0f;
            const bool hit = intersect(box, br, tmax, t_scalar);
            REQUIRE(((bits >> c) & 1u) == unsigned(hit));
            if (hit) REQUIRE(std::bit_cast<std::uint32_t>(t[c]) == std::bit_cast<std::uint32_t>(t_scalar));
            REQUIRE(((admitted >> c) & 1u) == unsigned((n.mask[c] & inclusion) != 0));
            hits += hit;
            ++checked;
        }
        REQUIRE((admitted >> kWideBvhWidth) == 0u);
    }
    CHECK(hits > checked / 20);  // both outcomes well represented
    CHECK(hits < checked - checked / 4);
}

// WideBoxTest on a mesh BLAS's nodes at both widths (W = 4: SSE2; W = 8: AVX2 where the build has it, else the lanes'
// scalar definition) against the scalar slab test, child by child, bit for bit as above. Unused slots carry the empty
// box, which every ray must miss.
template <unsigned W>
void check_blas_wide_box_test(std::uint64_t seed) {
    Pcg32 rng(seed);
    const float planes[] = {-1.0f, -0.5f, 0.0f, 0.5f, 1.0f};
    auto pick = [&](std::span<const float> v) { return v[rng.next_u32() % v.size()]; };
    std::uint64_t checked = 0, hits = 0;
    for (int i = 0; i < 50000; ++i) {
        BlasWideNode<W> n{};
        n.used = std::uint8_t(1 + rng.next_u32() % W);
        for (unsigned c = 0; c < W; ++c) {
            Aabb box;  // empty
            if (c < n.used)
                for (int k = 0; k < 3; ++k) {
                    const float a = rng.next_u32() % 4 ? pick(planes) : rng.uniform(-1.0f, 1.0f);
                    const float b = rng.next_u32() % 4 ? pick(planes) : rng.uniform(-1.0f, 1.0f);
                    box.lo[k] = std::min(a, b);
                    box.hi[k] = std::max(a, b);
                }
            for (int k = 0; k < 3; ++k) {
                n.bounds[k][c] = box.lo[k];
                n.bounds[k + 3][c] = box.hi[k];
            }
        }
        float tmax = 0.0f;
        const Ray r = box_test_ray(rng, tmax);
        const BoxRay br(r);
        alignas(4 * W) float t[W];
        const unsigned bits = WideBoxTest<W>(br).test(n, tmax, t);
        INFO("W " << W << ", ray " << i);
        REQUIRE((bits >> W) == 0u);
        for (unsigned c = 0; c < W; ++c) {
            float t_scalar = -1.0f;
            const bool hit = intersect(slot_box(n, c), br, tmax, t_scalar);
            REQUIRE(((bits >> c) & 1u) == unsigned(hit));
            if (c >= n.used) REQUIRE_FALSE(hit);
            if (hit) REQUIRE(std::bit_cast<std::uint32_t>(t[c]) == std::bit_cast<std::uint32_t>(t_scalar));
            hits += hit;
            checked += c < n.used;
        }
    }
    CHECK(hits > checked / 20);  // both outcomes well represented
    CHECK(hits < checked - checked / 4);
}

TEST_CASE("Mesh BLAS wide tree: the W-child box test equals the scalar slab test on every ray", "[bvh]") {
    check_blas_wide_box_test<4>(91);
    check_blas_wide_box_test<8>(92);
}

// The collapse keeps every leaf of the binary tree exactly once (same primitive ranges), and the walks in
// both orders at both widths find the binary walk's closest hit and the same set of all hits.
template <unsigned W>
void check_blas_wide_walks(const MeshBlas& blas, const std::vector<Ray>& rays) {
    BlasWideBvh<W> wide;
    wide.collapse(blas.bvh(), blas.leaf_blocks());
    std::multiset<std::pair<std::uint32_t, std::uint32_t>> binary_leaves, wide_leaves;
    const auto& nodes = blas.bvh().nodes;
    for (std::size_t i = 0; i < nodes.size(); ++i)
        if (i != 1 && nodes[i].is_leaf()) binary_leaves.insert({blas.leaf_blocks()[i], nodes[i].count});
    for (std::size_t k = 0; k < wide.node_count(); ++k) {
        const BlasWideNode<W>& n = wide.nodes()[k];
        REQUIRE(n.used >= 1);
        for (unsigned i = 0; i < n.used; ++i)
            if ((n.leaves >> i) & 1u) wide_leaves.insert({n.child[i], n.count[i]});
    }
    REQUIRE(wide_leaves == binary_leaves);

    for (const Ray& r : rays) {
        const BlasRay br(r);
        // The binary walk's closest hit, the reference.
        float tmax_ref = r.tmax;
        BlasHit ref;
        TraversalStats s;
        auto closest_leaf = [&](float& tmax, BlasHit& best) {
            return [&](std::uint32_t f, std::uint32_t c) {
                return mesh_leaf_hits(blas, br, tmax, f, c, s, [&](const BlasHit& h) {
                    best = h;
                    tmax = h.t;
                    return false;
                });
            };
        };
        // The binary walk's leaf callback is given a leaf's range; the kernel wants its blocks.
        auto by_range = [&](auto&& leaf) {
            return [&, leaf](std::uint32_t f, std::uint32_t c) mutable { return leaf(blas.leaf_block(f), c); };
        };
        traverse_bvh(blas.bvh(), BoxRay(r), tmax_ref, by_range(closest_leaf(tmax_ref, ref)), s);
        float tmax_near = r.tmax, tmax_any = r.tmax;
        BlasHit near, any;
        traverse_blas_wide<BlasWalkOrder::nearest_first>(wide, BoxRay(r), tmax_near, closest_leaf(tmax_near, near), s);
        traverse_blas_wide<BlasWalkOrder::any_order>(wide, BoxRay(r), tmax_any, closest_leaf(tmax_any, any), s);
        REQUIRE(tmax_near == tmax_ref);
        REQUIRE(tmax_any == tmax_ref);
        REQUIRE(near.primitive == ref.primitive);
        REQUIRE(any.primitive == ref.primitive);
        // All hits: the same (primitive, t) multiset in any order.
        auto all = [&](auto&& walk) {
            std::multiset<std::pair<std::uint32_t, float>> got;
            const float tmax = r.tmax;
            walk(tmax, [&](std::uint32_t f, std::uint32_t c) {
                return mesh_leaf_hits(blas, br, tmax, f, c, s, [&](const BlasHit& h) {
                    got.insert({h.primitive, h.t});
                    return false;
                });
            });
            return got;
        };
        const auto all_ref =
            all([&](const float& tmax, auto&& leaf) { traverse_bvh(blas.bvh(), BoxRay(r), tmax, by_range(leaf), s); });
        REQUIRE(all([&](const float& tmax, auto&& leaf) {
                    traverse_blas_wide<BlasWalkOrder::nearest_first>(wide, BoxRay(r), tmax, leaf, s);
                }) == all_ref);
        REQUIRE(all([&](const float& tmax, auto&& leaf) {
                    traverse_blas_wide<BlasWalkOrder::any_order>(wide, BoxRay(r), tmax, leaf, s);
                }) == all_ref);
    }
}

TEST_CASE("Mesh BLAS wide tree: collapse keeps every leaf, and both walks at both widths match the binary walk",
          "[bvh]") {
    const TriangleMesh m = random_soup(3000, 0.1f, 93);
    const MeshBlas blas(m);
    const std::vector<Ray> rays = random_rays(2000, 94);
    check_blas_wide_walks<4>(blas, rays);
    check_blas_wide_walks<8>(blas, rays);
}

TEST_CASE("Mesh BLAS wide tree: the cut's inner nodes weigh no more area than the greedy collapse's", "[bvh]") {
    // The cut minimises the total area of the wide inner nodes (each the box of the binary node it is made
    // from); opening the largest slot first (greedy_slots()) is one feasible cut.
    const TriangleMesh m = random_soup(4000, 0.1f, 95);
    const MeshBlas blas(m);
    const Bvh& binary = blas.bvh();
    const double greedy = wide_inner_area(binary, kMeshBlasWidth, [&](std::uint32_t b, std::uint32_t* slot) {
                              return greedy_slots(binary, b, kMeshBlasWidth, slot);
                          }).first;
    const auto& wide = blas.wide();
    double cut = 0.0;
    for (std::size_t k = 0; k < wide.node_count(); ++k) {
        const auto& n = wide.nodes()[k];
        REQUIRE(n.used >= 2);
        Aabb box;
        for (unsigned i = 0; i < n.used; ++i)
            box.grow(Aabb{{n.bounds[0][i], n.bounds[1][i], n.bounds[2][i]},
                          {n.bounds[3][i], n.bounds[4][i], n.bounds[5][i]}});
        cut += box.area();
    }
    // The cut is found with float sums: a near tie may go either way by their rounding.
    CHECK(cut <= greedy * (1.0 + 1e-5));
}

TEST_CASE("Mesh BLAS wide walk: the key sorting networks sort every input", "[bvh]") {
    // 0/1 principle: a comparator network sorts every input iff it sorts every sequence of zeros and ones.
    for (unsigned v = 0; v < 256; ++v) {
        std::uint64_t k8[8], k4[4];
        for (unsigned i = 0; i < 8; ++i) k8[i] = (v >> i) & 1u;
        for (unsigned i = 0; i < 4; ++i) k4[i] = (v >> i) & 1u;
        detail::sort_keys<8>(k8);
        detail::sort_keys<4>(k4);
        CAPTURE(v);
        REQUIRE(std::is_sorted(k8, k8 + 8));
        REQUIRE(std::is_sorted(k4, k4 + 4));
    }
    const float ts[] = {-2.0f, -0.0f, 0.0f, 1e-30f, 0.5f, 1.0f, 3e38f};
    for (std::size_t i = 0; i + 1 < std::size(ts); ++i)
        REQUIRE(detail::ordered_bits(ts[i]) <= detail::ordered_bits(ts[i + 1]));
}

// ---------------------------------------------------------------------------------------------------
// Deforming meshes: MeshBlas::update_vertices

namespace {

// Closest hit and every hit of the ray against the BLAS, as comparable values.
struct BlasAnswer {
    bool hit = false;
    float t = 0.0f;
    std::uint32_t prim = 0;
    std::vector<std::pair<std::uint32_t, float>> all;
};
BlasAnswer answer(const MeshBlas& blas, const Ray& r) {
    BlasAnswer a;
    BlasHit hit;
    BlasCounters counters;
    a.hit = closest_hit(blas, r, hit, counters);
    a.t = hit.t;
    a.prim = hit.primitive;
    BlasHit committed;
    any_hit_traversal(blas, r, [&](const BlasHit& h) {
        a.all.emplace_back(h.primitive, h.t);
        return AnyHitDecision::ignore;
    }, committed, counters);
    std::sort(a.all.begin(), a.all.end());
    return a;
}

// The refit BLAS answers every ray as a fresh build over the same vertices does: the same closest t and
// triangle (either of two at exactly the same t is right) and the same set of all hits, bit for bit.
// Returns the number of hits compared, so that a caller can require the rays to have met the mesh.
long require_same_answers(const MeshBlas& refit, const MeshBlas& fresh, std::uint64_t seed) {
    long hits = 0;
    for (const Ray& r : random_rays(2000, seed)) {
        const BlasAnswer a = answer(refit, r), b = answer(fresh, r);
        REQUIRE(a.hit == b.hit);
        REQUIRE(a.all == b.all);
        hits += long(b.all.size());
        if (!b.hit) continue;
        REQUIRE(a.t == b.t);
        const auto at_t = std::count_if(b.all.begin(), b.all.end(), [&](const auto& h) { return h.second == b.t; });
        if (at_t == 1) REQUIRE(a.prim == b.prim);
    }
    return hits;
}

// What a refit must leave behind: leaf copies equal to the vertices' triangles (records, blocks), and every
// node box exactly the union of what lies below it.
void require_refit_consistent(const MeshBlas& blas, const TriangleMesh& m) {
    const auto& tris = blas.leaf_triangles();
    for (std::size_t k = 0; k < tris.size(); ++k) {
        const glm::uvec3 t = m.triangles[blas.primitive_id(std::uint32_t(k))];
        REQUIRE(tris[k].v0 == m.vertices[t.x]);
        REQUIRE(tris[k].v1 == m.vertices[t.y]);
        REQUIRE(tris[k].v2 == m.vertices[t.z]);
    }
    require_blocks_hold_leaves(blas);
    const auto& nodes = blas.bvh().nodes;
    for (std::size_t i = 0; i < nodes.size(); ++i) {
        if (i == 1) continue;
        Aabb b;
        if (nodes[i].is_leaf()) {
            for (std::uint32_t k = nodes[i].first; k < nodes[i].first + nodes[i].count; ++k) {
                b.grow(tris[k].v0);
                b.grow(tris[k].v1);
                b.grow(tris[k].v2);
            }
        } else {
            b = merge(nodes[nodes[i].first].bounds, nodes[nodes[i].first + 1].bounds);
        }
        REQUIRE(b.lo == nodes[i].bounds.lo);
        REQUIRE(b.hi == nodes[i].bounds.hi);
    }
}

TriangleMesh jittered(TriangleMesh m, Pcg32& rng, float step) {
    for (glm::vec3& v : m.vertices) v += step * glm::vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    return m;
}

}  // namespace

TEST_CASE("MeshBlas refit: a deformed mesh gives the hits of a fresh build over the same vertices", "[bvh][refit]") {
    // A soup (every 97th triangle degenerate by a repeated index, so it stays degenerate) deformed over
    // ten frames; an infinite ratio forces a refit each time, however degraded.
    TriangleMesh m = random_soup(3000, 0.1f, 71);
    MeshBlas blas(m);
    const double at_build = blas.sah_cost_at_build();
    REQUIRE(blas.sah_cost() == at_build);
    Pcg32 rng(72);
    for (int frame = 0; frame < 10; ++frame) {
        m = jittered(std::move(m), rng, 0.05f);
        REQUIRE(blas.update_vertices(m.vertices, std::numeric_limits<double>::infinity()) == BlasUpdate::refit);
    }
    require_refit_consistent(blas, m);
    const MeshBlas fresh(m);
    CHECK(blas.degenerate_count() == fresh.degenerate_count());
    CHECK(blas.bounds().lo == fresh.bounds().lo);
    CHECK(blas.bounds().hi == fresh.bounds().hi);
    // The refit tree really is another tree than the fresh one (else the comparison below proves nothing).
    CHECK(blas.sah_cost() > fresh.sah_cost());
    CHECK(blas.sah_cost_at_build() == at_build);
    CHECK(require_same_answers(blas, fresh, 73) > 5000);
}

TEST_CASE("MeshBlas refit: rebuilds exactly when the refit SAH passes the ratio", "[bvh][refit]") {
    // Growing deformations of an icosphere. `probe` always refits, so its SAH cost is the one the policy
    // sees; `policy` must rebuild exactly when that exceeds kRebuildSahRatio × its cost at build.
    const TriangleMesh base = make_icosphere(3, 1.0f);
    Pcg32 rng(81);
    int refits = 0, rebuilds = 0;
    for (int k = 0; k < 12; ++k) {
        const float step = 0.004f * float(1 << (k / 2));  // 0.004 … 0.128 of the radius
        const TriangleMesh moved = jittered(base, rng, step);
        MeshBlas probe(base), policy(base);
        REQUIRE(probe.update_vertices(moved.vertices, std::numeric_limits<double>::infinity()) == BlasUpdate::refit);
        const bool degraded = probe.sah_cost() > kRebuildSahRatio * policy.sah_cost_at_build();
        const BlasUpdate u = policy.update_vertices(moved.vertices);
        CAPTURE(k, step, probe.sah_cost(), policy.sah_cost_at_build());
        REQUIRE(u == (degraded ? BlasUpdate::rebuild : BlasUpdate::refit));
        const MeshBlas fresh(moved);
        if (u == BlasUpdate::rebuild) {
            ++rebuilds;
            // A rebuild is a fresh build: the same tree, its cost the new reference.
            CHECK(policy.sah_cost() == fresh.sah_cost());
            CHECK(policy.sah_cost_at_build() == fresh.sah_cost());
        } else {
            ++refits;
            CHECK(policy.sah_cost() == probe.sah_cost());
            CHECK(policy.sah_cost() <= kRebuildSahRatio * policy.sah_cost_at_build());
        }
        require_refit_consistent(policy, moved);
        require_same_answers(policy, fresh, 82 + std::uint64_t(k));
    }
    CHECK(refits > 0);
    CHECK(rebuilds > 0);
}

TEST_CASE("MeshBlas refit: a triangle becoming degenerate, or no longer, rebuilds", "[bvh][refit]") {
    TriangleMesh m = make_icosphere(2, 1.0f);
    MeshBlas blas(m);
    REQUIRE(blas.degenerate_count() == 0);
    // Vertex a moved onto its neighbour b: every triangle with both collapses to a segment.
    const glm::uvec3 t0 = m.triangles[0];
    TriangleMesh collapsed = m;
    collapsed.vertices[t0.x] = collapsed.vertices[t0.y];
    REQUIRE(blas.update_vertices(collapsed.vertices, std::numeric_limits<double>::infinity()) == BlasUpdate::rebuild);
    const MeshBlas fresh(collapsed);
    CHECK(blas.degenerate_count() == fresh.degenerate_count());
    CHECK(blas.degenerate_count() >= 2);
    require_refit_consistent(blas, collapsed);
    require_same_answers(blas, fresh, 91);
    // And back: the degenerate ones are triangles again, so the tree must hold them again.
    REQUIRE(blas.update_vertices(m.vertices, std::numeric_limits<double>::infinity()) == BlasUpdate::rebuild);
    CHECK(blas.degenerate_count() == 0);
    require_same_answers(blas, MeshBlas(m), 92);
}

TEST_CASE("MeshBlas refit: a wrong vertex count or a non-finite vertex is an error, the BLAS unchanged",
          "[bvh][refit]") {
    const TriangleMesh m = make_icosphere(1, 1.0f);
    MeshBlas blas(m);
    const double sah = blas.sah_cost();
    std::vector<glm::vec3> fewer(m.vertices.begin(), m.vertices.end() - 1);
    try {
        (void)blas.update_vertices(fewer);
        FAIL("no exception");
    } catch (const std::invalid_argument& e) {
        const std::string what = e.what();
        CHECK(what.find(std::to_string(fewer.size()) + " vertices given") != std::string::npos);
        CHECK(what.find("has " + std::to_string(m.vertices.size())) != std::string::npos);
    }
    std::vector<glm::vec3> bad = m.vertices;
    bad[5].y = std::numeric_limits<float>::quiet_NaN();
    try {
        (void)blas.update_vertices(bad);
        FAIL("no exception");
    } catch (const std::invalid_argument& e) {
        CHECK(std::string(e.what()).find("vertex 5 is not finite") != std::string::npos);
    }
    CHECK(blas.sah_cost() == sah);
    require_refit_consistent(blas, m);
}

TEST_CASE("BVH builder: the binning's lanes give the bins of the scalar definition", "[bvh][simd]") {
    // Random boxes against random centroid bounds (positions inside, on and past both ends, which clamp),
    // plus the extremes of bin_scale: FLT_MAX bins per unit (a subnormal extent) and 0 (a flat axis).
    Pcg32 rng(111);
    const float kMaxScale = std::numeric_limits<float>::max();
    int checked = 0, clamped = 0;
    for (int i = 0; i < 200000; ++i) {
        const glm::vec3 lo(rng.uniform(-10, 10), rng.uniform(-10, 10), rng.uniform(-10, 10));
        // About one bin per unit, so that 16 bins span [lo, lo + 16] and most centroids land inside.
        glm::vec3 scale(rng.uniform(0.7f, 1.3f), rng.uniform(0.7f, 1.3f), rng.uniform(0.7f, 1.3f));
        if (i % 17 == 0) scale[i % 3] = kMaxScale;
        if (i % 19 == 0) scale[(i + 1) % 3] = 0.0f;
        const glm::vec3 c = lo + glm::vec3(rng.uniform(-2, 18), rng.uniform(-2, 18), rng.uniform(-2, 18));
        const glm::vec3 e(rng.uniform(0, 1), rng.uniform(0, 1), rng.uniform(0, 1));
        const Aabb box{c - e, c + e};
        const std::array<int, 3> lanes = detail::box_bins(box, lo, scale);
        for (int a = 0; a < 3; ++a) {
            const int want = detail::bin_of(box.center()[a], lo[a], scale[a]);
            REQUIRE(lanes[std::size_t(a)] == want);
            clamped += want == 0 || want == BvhBuildSettings::kBins - 1;
            ++checked;
        }
    }
    CHECK(clamped > 1000);
    CHECK(clamped < checked / 2);
}
