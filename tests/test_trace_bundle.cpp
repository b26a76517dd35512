// trace_bundle(): rays traced sixteen at a time must each see exactly what trace() shows them alone.
//
// The kernels first, lane by lane against the scalar code they stand for (bit for bit, no tolerance: they
// perform the same operations): the bundle's box test against intersect(), its sphere test against
// sphere_roots(). Then whole bundles against trace() on random scenes of every instance kind (world
// spheres, object-space spheres and meshes, world-space quads, opaque and not, mixed masks), compared on
// what DXR fixes whatever the traversal order: the set of candidates (with their t, bit for bit) when
// every candidate is ignored, the closest hit when every candidate is accepted, whether anything is
// committed under ACCEPT_FIRST_HIT_AND_END_SEARCH, and the cutoff; and on what this walk fixes beyond DXR:
// with every candidate ignored, their order, trace<TlasWalk::all_hits>'s. Last, bundle_order().
#include <smoketrace/accel/bundle_traversal.hpp>
#include <smoketrace/core/prng.hpp>
#include <smoketrace/geometry/ray_bundle.hpp>
#include <smoketrace/geometry/ray_sphere_bundle.hpp>
#include <smoketrace/smoke/stand_in_shapes.hpp>
#include <smoketrace/trace/trace.hpp>
#include <smoketrace/trace/trace_bundle.hpp>

#include <catch2/catch.hpp>

#include "support/mixed_scene.hpp"

#include <glm/geometric.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <set>
#include <tuple>
#include <vector>

using namespace smoketrace;
using namespace smoketrace::test;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// Directions that stress the slab test: random, along an axis (two components ±0), and in a coordinate
// plane (one component ±0).
glm::vec3 test_direction(Pcg32& rng, int k) {
    glm::vec3 d = random_unit(rng);
    switch (k % 4) {
        case 1: d = glm::vec3(0.0f, rng.below(2) ? 1.0f : -1.0f, rng.below(2) ? 0.0f : -0.0f); break;
        case 2: d.y = rng.below(2) ? 0.0f : -0.0f; break;
        default: break;
    }
    return d;
}

}  // namespace

TEST_CASE("trace_bundle: the bundle's box test is intersect() lane by lane", "[trace-bundle]") {
    // Random boxes and rays, and rays whose origins lie exactly on a slab plane of the box (0·∞ when the
    // direction's component is ±0 there), with random [tmin, tmax] per lane: every lane's bit must be the
    // scalar slab test's answer.
    Pcg32 rng(31);
    int tested = 0, hits = 0;
    for (int k = 0; k < 4000; ++k) {
        WideBvhNode node{};
        for (unsigned s = 0; s < kWideBvhWidth; ++s) {
            const glm::vec3 c(rng.uniform(-4, 4), rng.uniform(-4, 4), rng.uniform(-4, 4));
            const glm::vec3 h(rng.uniform(0, 2), rng.uniform(0, 2), rng.uniform(0, 2));
            for (int a = 0; a < 3; ++a) {
                node.bounds[a][s] = c[a] - h[a];
                node.bounds[a + 3][s] = c[a] + h[a];
            }
        }
        // kBundleWidth parallel rays aimed near one of the boxes, from 10 units back, spread across the direction.
        const glm::vec3 d = test_direction(rng, k);
        const glm::vec3 side = glm::normalize(glm::cross(d, glm::vec3(0.36f, 0.48f, 0.8f)));
        const glm::vec3 side2 = glm::cross(d, side);
        const unsigned aim = rng.below(kWideBvhWidth);
        const glm::vec3 target(0.5f * (node.bounds[0][aim] + node.bounds[3][aim]), 0.5f * (node.bounds[1][aim] + node.bounds[4][aim]),
                               0.5f * (node.bounds[2][aim] + node.bounds[5][aim]));
        RayBundle b(d);
        for (unsigned i = 0; i < kBundleWidth; ++i) {
            glm::vec3 o = target - 10.0f * d + rng.uniform(-2, 2) * side + rng.uniform(-2, 2) * side2;
            if (i % 3 == 0) o.y = node.bounds[rng.below(2) ? 1 : 4][rng.below(kWideBvhWidth)];  // on a y slab plane
            b.add(o, rng.below(4) == 0 ? rng.uniform(0, 12) : 0.0f, rng.below(4) == 0 ? rng.uniform(0, 16) : kInf);
        }
        alignas(64) float tmax[kBundleWidth];
        std::copy(std::begin(b.tmax), std::end(b.tmax), tmax);
        const BundleBoxTest test(b);
        for (unsigned s = 0; s < kWideBvhWidth; ++s) {
            const unsigned got = test.test(node, s, BundleBoxTest::far_limits(tmax));
            Aabb box;
            box.lo = {node.bounds[0][s], node.bounds[1][s], node.bounds[2][s]};
            box.hi = {node.bounds[3][s], node.bounds[4][s], node.bounds[5][s]};
            for (unsigned i = 0; i < kBundleWidth; ++i) {
                float t;
                const bool expected = intersect(box, BoxRay(b.ray(i)), b.tmax[i], t);
                CAPTURE(k, s, i);
                CHECK(((got >> i) & 1u) == unsigned(expected));
                hits += expected;
                ++tested;
            }
        }
    }
    CHECK(tested == 4000 * 4 * int(kBundleWidth));
    CHECK(hits > tested / 20);  // both outcomes well represented
    CHECK(hits < tested * 19 / 20);
}

TEST_CASE("trace_bundle: the bundle's sphere test is sphere_roots() lane by lane, bit for bit", "[trace-bundle]") {
    // Spheres of radius 1e-3 … 1e3 near the origin and 1e5 away, origins inside and outside, rays aimed at
    // the centre, at the rim (nearly tangent) and anywhere. For each lane: the entry and exit bits are
    // set exactly when sphere_roots() finds roots whose float values lie in [tmin, tmax], and the roots
    // are sphere_roots()'s, bit for bit in double (a reordered or fused operation would show here).
    Pcg32 rng(37);
    int crossings = 0, lanes_tested = 0;
    for (int k = 0; k < 6000; ++k) {
        const double radius = std::pow(10.0, rng.uniform(-3.0f, 3.0f));
        const glm::dvec3 translation = (k % 2 ? 1e5 : 1.0) * glm::dvec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        const glm::dvec3 offset = radius * glm::dvec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        const glm::dvec3 centre = translation + offset;
        const glm::vec3 dir = test_direction(rng, k) * rng.uniform(0.5f, 2.0f);
        RayBundle b(dir);
        const glm::dvec3 u = glm::normalize(glm::cross(glm::dvec3(dir), glm::dvec3(0.3, 0.7, 0.1)));
        for (unsigned i = 0; i < kBundleWidth; ++i) {
            const double away = radius * (i % 4 == 0 ? 0.5 : rng.uniform(1.0f, 20.0f));  // inside or outside
            const double aside = radius * (i % 4 == 1 ? 0.0 : i % 4 == 2 ? 1.0 - 1e-6 : rng.uniform(0.0f, 1.5f));
            const glm::dvec3 o = centre - away * glm::normalize(glm::dvec3(dir)) + aside * u;
            b.add(glm::vec3(o), i % 3 == 0 ? float(away) : 1e-7f, i % 5 == 0 ? float(away) : kInf);
        }
        const unsigned lanes = k % 7 == 0 ? 0x5Au : b.lanes();
        alignas(64) float tmax[kBundleWidth];
        std::copy(std::begin(b.tmax), std::end(b.tmax), tmax);
        BundleSphereCrossings x;
        sphere_crossings_bundle(b, lanes, tmax, translation, offset, radius, x);
        CHECK((x.enter & ~lanes) == 0u);
        CHECK((x.exit & ~lanes) == 0u);
        for (unsigned i = 0; i < kBundleWidth; ++i) {
            if (!((lanes >> i) & 1u)) continue;
            ++lanes_tested;
            SphereRoots r{};
            const bool found = sphere_roots(glm::dvec3(b.origin(i)) - translation, glm::dvec3(dir), offset, radius, r);
            const float te = float(r.t_enter), tx = float(r.t_exit);
            const bool enter = found && te >= b.tmin[i] && te <= tmax[i];
            const bool exit = found && tx >= b.tmin[i] && tx <= tmax[i];
            CAPTURE(k, i, radius);
            CHECK(((x.enter >> i) & 1u) == unsigned(enter));
            CHECK(((x.exit >> i) & 1u) == unsigned(exit));
            if (enter || exit) {
                CHECK(std::bit_cast<std::uint64_t>(x.t_enter[i]) == std::bit_cast<std::uint64_t>(r.t_enter));
                CHECK(std::bit_cast<std::uint64_t>(x.t_exit[i]) == std::bit_cast<std::uint64_t>(r.t_exit));
            }
            crossings += enter + exit;
        }
    }
    CHECK(crossings > lanes_tested / 2);
}

namespace {

// kBundleWidth (or fewer) parallel rays from origins scattered around a point, toward the scene.
RayBundle random_bundle(Pcg32& rng, unsigned count) {
    const glm::vec3 toward(rng.uniform(-10, 10), rng.uniform(-10, 10), rng.uniform(-10, 10));
    const glm::vec3 around(rng.uniform(-45, 45), rng.uniform(-45, 45), rng.uniform(-45, 45));
    RayBundle b(toward - around);
    for (unsigned i = 0; i < count; ++i) {
        const glm::vec3 o = around + glm::vec3(rng.uniform(-4, 4), rng.uniform(-4, 4), rng.uniform(-4, 4));
        b.add(o, rng.below(3) == 0 ? rng.uniform(0, 30) : 0.0f, rng.below(3) == 0 ? rng.uniform(30, 90) : kInf);
    }
    return b;
}

}  // namespace

TEST_CASE("trace_bundle: every ray of a bundle meets the candidates trace() shows it alone, in its order",
          "[trace-bundle]") {
    // Every candidate ignored, the scene's opaque instances made non-opaque (nothing commits), random
    // inclusion masks and facing culls: per ray the same candidates in the same order, t bit for bit (the
    // world-sphere kernel is exact, the rest is the very code trace() runs), and, since nothing shrinks
    // tmax, the same counters as trace<TlasWalk::all_hits>: both walk the 4-wide tree with the same box test.
    Pcg32 rng(41);
    const AccelScene s = mixed_scene(rng);
    std::size_t candidates = 0;
    for (int k = 0; k < 500; ++k) {
        const RayBundle b = random_bundle(rng, 1 + rng.below(kBundleWidth));
        const std::uint8_t incl = std::uint8_t(1u + rng.below(7));
        const std::uint32_t flags = ray_flag_force_non_opaque | (k % 3 == 1   ? ray_flag_cull_back_facing_triangles
                                                                : k % 3 == 2 ? ray_flag_cull_front_facing_triangles
                                                                             : ray_flag_none);
        std::vector<HitKey> got[kBundleWidth];
        const BundleResults results = trace_bundle(s, b, flags, incl, [&](unsigned lane, const TraceHit& h) {
            got[lane].push_back(key_of(h));
            return AnyHitDecision::ignore;
        });
        for (unsigned i = 0; i < b.count; ++i) {
            std::vector<HitKey> expected;
            const TraceResult alone = trace<TlasWalk::all_hits>(s, b.ray(i), flags, incl, [&](const TraceHit& h) {
                expected.push_back(key_of(h));
                return AnyHitDecision::ignore;
            });
            CAPTURE(k, i, int(incl), flags);
            // In the same order, too: with nothing committed, lane by lane the bundle's walk is the lone
            // ray's (bundle_traversal.hpp), which lets either sum a ray's kernel shares to the same bits
            // (kernel_bundle_sums.hpp).
            CHECK(got[i] == expected);
            const TraceCounters &c = results[i].counters, &e = alone.counters;
            CHECK_FALSE(results[i].hit);
            CHECK(c.tlas_nodes == e.tlas_nodes);
            CHECK(c.boxes_tested == e.boxes_tested);
            CHECK(c.blas_nodes == e.blas_nodes);
            CHECK(c.instances_entered == e.instances_entered);
            CHECK(c.primitives_tested == e.primitives_tested);
            CHECK(c.any_hit_invocations == e.any_hit_invocations);
            candidates += expected.size();
        }
    }
    CHECK(candidates > 3000);
}

TEST_CASE("trace_bundle: commits, first-hit ends, skipped closest hits and cutoffs per ray", "[trace-bundle]") {
    // What does not depend on the order candidates come in, ray by ray against trace():
    //  * every candidate accepted (and opaque hits): the closest hit, the same instance, primitive, kind, t;
    //  * ACCEPT_FIRST_HIT_AND_END_SEARCH | SKIP_CLOSEST_HIT_SHADER (a shadow ray): whether anything is hit;
    //  * a cutoff of 3 on ignored, non-opaque candidates: whether the ray is cut off, and the calls made.
    Pcg32 rng(43);
    const AccelScene s = mixed_scene(rng);
    int closest = 0, shadowed = 0, cut = 0;
    for (int k = 0; k < 400; ++k) {
        const RayBundle b = random_bundle(rng, 1 + rng.below(kBundleWidth));
        const std::uint8_t incl = std::uint8_t(1u + rng.below(7));
        const BundleResults near = trace_bundle(s, b, ray_flag_none, incl, [](unsigned, const TraceHit&) {
            return AnyHitDecision::accept;
        });
        const std::uint32_t shadow_flags = ray_flag_accept_first_hit_and_end_search | ray_flag_skip_closest_hit_shader;
        const BundleResults shadow = trace_bundle(s, b, shadow_flags, incl, [](unsigned, const TraceHit&) {
            return AnyHitDecision::accept;
        });
        auto ignore = [](unsigned, const TraceHit&) { return AnyHitDecision::ignore; };
        const BundleResults limited = trace_bundle(s, b, ray_flag_force_non_opaque, incl, ignore, TraceLimits{3});
        for (unsigned i = 0; i < b.count; ++i) {
            const Ray r = b.ray(i);
            const TraceResult a = trace(s, r, ray_flag_none, incl);
            CAPTURE(k, i, int(incl));
            REQUIRE(near[i].hit == a.hit);
            if (a.hit) {
                CHECK(near[i].committed.t == a.committed.t);
                CHECK(near[i].committed.instance_index == a.committed.instance_index);
                CHECK(near[i].committed.primitive_index == a.committed.primitive_index);
                CHECK(near[i].committed.kind == a.committed.kind);
                ++closest;
            }
            const TraceResult sa = trace(s, r, shadow_flags, incl);
            CHECK(shadow[i].hit == sa.hit);
            CHECK(shadow[i].counters.hits_accepted == (sa.hit ? 1u : 0u));
            CHECK(shadow[i].committed.instance_index == ~0u);  // SKIP_CLOSEST_HIT_SHADER: no hit data
            shadowed += sa.hit;
            const TraceResult la = trace(s, r, ray_flag_force_non_opaque, incl, [](const TraceHit&) {
                return AnyHitDecision::ignore;
            }, TraceLimits{3});
            CHECK(limited[i].cut_off == la.cut_off);
            CHECK(limited[i].counters.any_hit_invocations == la.counters.any_hit_invocations);
            cut += la.cut_off;
        }
    }
    CHECK(closest > 300);
    CHECK(shadowed > 300);
    CHECK(cut > 100);
}

TEST_CASE("trace_bundle: a committed sphere entry drops that sphere's exit, as in trace()", "[trace-bundle]") {
    // A bundle hands each ray its world-sphere entries first and the exits after (trace_bundle.hpp), the
    // exits found in range before the entries were reported: an entry that commits (accepted, or an opaque
    // sphere) lowers tmax below its exit, which must then be dropped. Rays along +z through a row of spheres
    // (non-opaque and opaque), every candidate accepted: per ray the committed hit (the first entry) and
    // the counts of accepted hits and any-hit calls equal trace()'s. (The random scenes above rarely make a
    // ray's first candidate a sphere whose exit is also in range.)
    AccelScene s;
    const std::uint32_t glassy = s.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 1.0f}}, false));
    const std::uint32_t solid = s.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 1.0f}}, true));
    for (int k = 0; k < 4; ++k)
        s.add_instance(Instance{k % 2 == 0 ? glassy : solid,
                                AffineTransform::translate_scale(glm::dvec3(0.0, 0.0, 5.0 + 3.0 * k), 1.0 + 0.1 * k), 1,
                                std::uint32_t(k), instance_flag_none});
    s.commit();
    REQUIRE(s.record(0).path == InstancePath::world_sphere);
    Pcg32 rng(47);
    int checked = 0;
    for (int k = 0; k < 50; ++k) {
        RayBundle b(glm::vec3(0.0f, 0.0f, 1.0f));
        for (unsigned i = 0; i < kBundleWidth; ++i)
            b.add(glm::vec3(rng.uniform(-0.9f, 0.9f), rng.uniform(-0.9f, 0.9f), rng.uniform(-2.0f, 12.0f)), 0.0f, kInf);
        for (const std::uint32_t flags : {std::uint32_t(ray_flag_none), std::uint32_t(ray_flag_force_non_opaque)}) {
            const BundleResults got = trace_bundle(s, b, flags, 0xFF, [](unsigned, const TraceHit&) {
                return AnyHitDecision::accept;
            });
            for (unsigned i = 0; i < b.count; ++i) {
                const TraceResult alone = trace(s, b.ray(i), flags, 0xFF, [](const TraceHit&) {
                    return AnyHitDecision::accept;
                });
                CAPTURE(k, i, flags);
                REQUIRE(got[i].hit == alone.hit);
                CHECK(got[i].committed.t == alone.committed.t);
                CHECK(got[i].committed.kind == alone.committed.kind);
                CHECK(got[i].committed.instance_index == alone.committed.instance_index);
                CHECK(got[i].counters.hits_accepted == alone.counters.hits_accepted);
                CHECK(got[i].counters.any_hit_invocations == alone.counters.any_hit_invocations);
                checked += alone.hit;
            }
        }
    }
    CHECK(checked > 1000);
}

TEST_CASE("trace_bundle: a ray that ends its search leaves the others unchanged", "[trace-bundle]") {
    // Lane 0 accepts its first candidate and ends (AcceptHitAndEndSearch), the others ignore everything:
    // they must meet exactly the candidates they meet in a bundle where nobody ends, and lane 0 must have
    // called any-hit once.
    Pcg32 rng(47);
    const AccelScene s = mixed_scene(rng);
    int checked = 0;
    for (int k = 0; k < 300; ++k) {
        const RayBundle b = random_bundle(rng, kBundleWidth);
        std::vector<HitKey> mixed[kBundleWidth], plain[kBundleWidth];
        auto record_into = [](std::vector<HitKey>* into, bool ending) {
            return [into, ending](unsigned lane, const TraceHit& h) {
                into[lane].push_back(key_of(h));
                return ending && lane == 0 ? AnyHitDecision::accept_and_end : AnyHitDecision::ignore;
            };
        };
        const BundleResults r = trace_bundle(s, b, ray_flag_force_non_opaque, 0xFF, record_into(mixed, true));
        trace_bundle(s, b, ray_flag_force_non_opaque, 0xFF, record_into(plain, false));
        if (plain[0].empty()) continue;
        CAPTURE(k);
        CHECK(r[0].hit);
        CHECK(r[0].counters.any_hit_invocations == 1u);
        CHECK(mixed[0].size() == 1u);
        for (unsigned i = 1; i < kBundleWidth; ++i) {
            std::sort(mixed[i].begin(), mixed[i].end());
            std::sort(plain[i].begin(), plain[i].end());
            CHECK(mixed[i] == plain[i]);
        }
        ++checked;
    }
    CHECK(checked > 100);
}

TEST_CASE("bundle_order: a permutation that keeps neighbours across the direction together", "[trace-bundle]") {
    // A 32 x 32 grid of origins in the plane perpendicular to the direction, each shifted a random
    // distance along the direction (which must not matter), in shuffled input order. The order returned
    // is a permutation and the same on every call, and runs of kBundleWidth consecutive rays are compact:
    // where the grid lines up with the Morton curve's axes (an axis-aligned direction), every run is one
    // aligned block of the curve, `side` cells on its longer side (4 x 4 for 16 rays, 8 x 4 for 32); for
    // any direction, runs span at most 2 * side cells on average (measured 6.6 for 16 rays and 9.6 for
    // 32; a random order: about 28 and 30), the Z curve's jumps making a few of them wider.
    static_assert(std::has_single_bit(kBundleWidth));
    const int log2_width = std::bit_width(kBundleWidth) - 1;
    const int side = 1 << ((log2_width + 1) / 2);  // 2^ceil(log2(width) / 2)
    for (const glm::vec3 dir : {glm::vec3(0, 1, 0), glm::vec3(1, 2, -0.5f), glm::vec3(0, 0, -3)}) {
        const glm::vec3 d = glm::normalize(dir);
        const glm::vec3 helper = std::abs(d.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
        const glm::vec3 u = glm::normalize(glm::cross(d, helper)), v = glm::cross(d, u);
        Pcg32 rng(53);
        std::vector<glm::vec3> origins;
        std::vector<glm::ivec2> cell;
        for (int a = 0; a < 32; ++a)
            for (int c = 0; c < 32; ++c) {
                origins.push_back(float(a) * u + float(c) * v + rng.uniform(-50, 50) * d);
                cell.emplace_back(a, c);
            }
        for (std::size_t i = origins.size(); i > 1; --i) {
            const std::uint32_t j = rng.below(std::uint32_t(i));
            std::swap(origins[i - 1], origins[j]);
            std::swap(cell[i - 1], cell[j]);
        }
        std::vector<std::uint32_t> order, again;
        BundleOrderScratch scratch;
        bundle_order(origins, dir, order, scratch);
        bundle_order(origins, dir, again, scratch);
        CHECK(order == again);
        std::vector<std::uint32_t> sorted = order;
        std::sort(sorted.begin(), sorted.end());
        std::vector<std::uint32_t> identity(origins.size());
        std::iota(identity.begin(), identity.end(), 0u);
        REQUIRE(sorted == identity);
        int worst = 0;
        double mean = 0.0;
        for (std::size_t k = 0; k < order.size(); k += kBundleWidth) {
            glm::ivec2 lo(1 << 20), hi(-(1 << 20));
            for (std::size_t j = k; j < k + kBundleWidth; ++j) {
                lo = glm::min(lo, cell[order[j]]);
                hi = glm::max(hi, cell[order[j]]);
            }
            worst = std::max({worst, hi.x - lo.x, hi.y - lo.y});
            mean += std::max(hi.x - lo.x, hi.y - lo.y);
        }
        mean /= double(order.size() / kBundleWidth);
        CAPTURE(dir.x, dir.y, dir.z);
        const bool aligned = std::abs(d.x) == 1.0f || std::abs(d.y) == 1.0f || std::abs(d.z) == 1.0f;
        if (aligned) CHECK(worst == side - 1);
        CHECK(mean <= 2.0 * side);
    }
    // Equal origins keep their input order; no origins give an empty order.
    std::vector<std::uint32_t> order;
    BundleOrderScratch scratch;
    bundle_order(std::vector<glm::vec3>(5, glm::vec3(1, 2, 3)), glm::vec3(0, 1, 0), order, scratch);
    CHECK(order == std::vector<std::uint32_t>{0, 1, 2, 3, 4});
    bundle_order({}, glm::vec3(0, 1, 0), order, scratch);
    CHECK(order.empty());
}

TEST_CASE("bundle_order: the grid refines with the ray count, so that rays far apart in input never share a cell",
          "[trace-bundle]") {
    // 1100 x 1100 origins on a lattice across the direction, aligned with the grid's axes: more rays than
    // 1024 x 1024 cells, so a grid of that size puts some two in one cell, where they keep their input
    // order. The grid refines to 2048 x 2048 for this count, every ray gets a cell of its own (1.86 cells
    // per lattice step), and the order of the lattice points is the same for two different input orders.
    constexpr int kSide = 1100;
    const glm::vec3 dir(0, 1, 0);
    const glm::vec3 d = glm::normalize(dir);
    const glm::vec3 u = glm::normalize(glm::cross(d, glm::vec3(1, 0, 0))), v = glm::cross(d, u);
    std::vector<std::uint32_t> point(std::size_t(kSide) * kSide);
    std::iota(point.begin(), point.end(), 0u);
    auto lattice_order = [&](std::uint64_t seed) {
        Pcg32 rng(seed);
        for (std::size_t i = point.size(); i > 1; --i) std::swap(point[i - 1], point[rng.below(std::uint32_t(i))]);
        std::vector<glm::vec3> origins(point.size());
        for (std::size_t i = 0; i < point.size(); ++i)
            origins[i] = float(point[i] / kSide) * u + float(point[i] % kSide) * v + rng.uniform(-50, 50) * d;
        std::vector<std::uint32_t> order;
        BundleOrderScratch scratch;
        bundle_order(origins, dir, order, scratch);
        for (std::uint32_t& k : order) k = point[k];
        return order;
    };
    const std::vector<std::uint32_t> a = lattice_order(61), b = lattice_order(62);
    REQUIRE(a.size() == b.size());
    std::size_t differ = 0;
    for (std::size_t i = 0; i < a.size(); ++i) differ += a[i] != b[i] ? 1 : 0;
    CHECK(differ == 0);
}
