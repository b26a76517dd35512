// The optical-depth pass (thesis 4.3.2) and OpticalPathLengths (pass + resolve, 4.3.3, with particle groups 4.4.2),
// checked against exact answers computed here in double precision, independently of the code under test:
//  * sphere stand-ins against the analytic union of spheres (the ray meets sphere i on [t0, t1]; the optical
//    path length is the length of the union of [max(t0, 0), t1] over all spheres);
//  * the status rules of optical_depth_pass.hpp (ok / occluded / cutoff) on scenes built so that the number
//    of surfaces each ray meets is known exactly, for the cutoff at K − 1, K and K + 1;
//  * particle groups, the three hit sorts, thread-count determinism, the ground, empty inputs;
//  * the smooth density kernels (density_kernel.hpp): each particle's sum against every particle's share
//    summed by brute force (no tracing), and the statuses, hit counts and cutoff of the uniform kernel kept.
#include "support/fixtures.hpp"
#include "support/sphere_reference.hpp"

#include <smoketrace/smoke/density_kernel.hpp>
#include <smoketrace/smoke/optical_depth_pass.hpp>
#include <smoketrace/smoke/optical_path_lengths.hpp>
#include <smoketrace/smoke/particle_groups.hpp>
#include <smoketrace/core/prng.hpp>
#include <smoketrace/core/radix_sort.hpp>
#include <smoketrace/trace/trace.hpp>
#include <smoketrace/smoke/tube_generator.hpp>

#include <catch2/catch.hpp>
#include <tbb/global_control.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numeric>
#include <optional>
#include <set>
#include <utility>
#include <vector>

using namespace smoketrace;
using namespace smoketrace::test;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

const StandInShape kSphere{StandInKind::sphere, 0};
const StandInShape kIcosahedron{StandInKind::icosahedron, 0};
const StandInShape kIcosphere1{StandInKind::icosphere, 1};

// A committed scene for the optical-depth pass (no billboards: the pass never sees them).
SmokeScene make_scene(const std::vector<Particle>& ps, StandInShape shape,
                      const std::optional<GroundQuad>& ground = {}) {
    SmokeScene s(ps, shape, ground, false);
    s.update(ps, glm::vec3(0.0f, 0.0f, 10.0f));
    return s;
}

OpticalDepthSettings settings_of(std::uint32_t cutoff, const DensityKernel& kernel) {
    OpticalDepthSettings s{cutoff};
    s.kernel = kernel;
    return s;
}

OpticalDepthHits run_pass(const SmokeScene& scene, const std::vector<Particle>& ps, glm::vec3 to_light,
                          std::uint32_t cutoff = 0, const DensityKernel& kernel = {}) {
    OpticalDepthPass pass;
    OpticalDepthHits out;
    pass.run(scene, ps, all_of(ps.size()), to_light, settings_of(cutoff, kernel), out);
    return out;
}

struct Depths {
    std::vector<float> lengths;
    std::vector<DepthStatus> status;
    std::vector<std::uint32_t> hit_counts;
};

Depths full_update(const SmokeScene& scene, const std::vector<Particle>& ps, glm::vec3 to_light,
                   std::uint32_t cutoff = 0, HitSort sort = HitSort::adaptive, const DensityKernel& kernel = {}) {
    OpticalPathLengths od(ps.size());
    FrameTimings timings;
    od.update(scene, ps, all_of(ps.size()), to_light, settings_of(cutoff, kernel), sort, timings);
    return {od.lengths(), od.status(), od.hit_counts()};
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
}

// ---------------------------------------------------------------------------------------------------------
// Checks every particle of `ps` (sphere stand-ins, no ground, no cutoff) against exact_spheres().
void check_against_exact_spheres(const std::vector<Particle>& ps, glm::vec3 to_light) {
    const SmokeScene scene = make_scene(ps, kSphere);
    const Depths got = full_update(scene, ps, to_light);
    for (std::size_t i = 0; i < ps.size(); ++i) {
        const SphereAnswer want = exact_spheres(ps, glm::dvec3(ps[i].center), glm::dvec3(to_light));
        INFO("particle " << i << " exact l = " << want.length << " got " << got.lengths[i] << " tolerance "
                         << want.tolerance << " surfaces " << want.surfaces << " (+" << want.ambiguous
                         << " ambiguous) got " << got.hit_counts[i]);
        REQUIRE(got.status[i] == DepthStatus::ok);
        REQUIRE(std::abs(double(got.lengths[i]) - want.length) <= want.tolerance);
        REQUIRE(got.hit_counts[i] >= want.surfaces);
        REQUIRE(got.hit_counts[i] <= want.surfaces + want.ambiguous);
    }
}

// ---------------------------------------------------------------------------------------------------------
// Scenes.

// The thesis's two tubes (4.1, tube_generator.hpp defaults: 750 particles).
std::vector<Particle> tube_particles(std::uint32_t n = 750) {
    TubeSettings s;
    s.particles = n;
    return generate_tubes(s);
}

// Many particles around one point, so that each ray starts inside many of them (eq. 3.1's counter_start).
std::vector<Particle> dense_cluster(std::uint64_t seed, std::size_t n) {
    Pcg32 rng(seed);
    std::vector<Particle> ps;
    while (ps.size() < n) {
        const glm::vec3 c(rng.uniform(-0.6f, 0.6f), rng.uniform(-0.6f, 0.6f), rng.uniform(-0.6f, 0.6f));
        if (glm::dot(c, c) > 0.36f) continue;
        ps.push_back(particle(c, rng.uniform(0.5f, 1.0f)));
    }
    return ps;
}

// Overlapping particles in a line along +y: each ray runs through the centres of all the particles above it.
std::vector<Particle> line_along_y(std::size_t n, float spacing, float radius) {
    std::vector<Particle> ps;
    for (std::size_t i = 0; i < n; ++i) ps.push_back(particle({0.25f, spacing * float(i), -0.5f}, radius));
    return ps;
}

std::vector<Particle> random_box(std::uint64_t seed, std::size_t n) {
    Pcg32 rng(seed);
    std::vector<Particle> ps;
    for (std::size_t i = 0; i < n; ++i)
        ps.push_back(particle({rng.uniform(-3.0f, 3.0f), rng.uniform(-2.0f, 2.0f), rng.uniform(-3.0f, 3.0f)},
                              rng.uniform(0.2f, 0.6f)));
    return ps;
}

// A horizontal quad at height y, counter-clockwise seen from above (normal +y).
GroundQuad horizontal_quad(float y, float half) {
    return GroundQuad{{glm::vec3(-half, y, half), glm::vec3(half, y, half), glm::vec3(half, y, -half),
                       glm::vec3(-half, y, -half)}};
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------

TEST_CASE("optical depth: sphere stand-ins match the analytic union of spheres on the two-tube scene",
          "[optical-depth]") {
    const auto ps = tube_particles();
    SECTION("light from above") { check_against_exact_spheres(ps, {0.0f, 1.0f, 0.0f}); }
    SECTION("light from the right, along the lower tube") { check_against_exact_spheres(ps, {1.0f, 0.0f, 0.0f}); }
    SECTION("oblique light of non-unit length") { check_against_exact_spheres(ps, {0.7f, 1.9f, -0.4f}); }
}

TEST_CASE("optical depth: sphere stand-ins match the analytic answer in a dense cluster", "[optical-depth]") {
    const auto ps = dense_cluster(7, 200);
    // Every ray starts inside many particles: the eq. 3.1 counter starts high.
    const SphereAnswer first = exact_spheres(ps, glm::dvec3(ps[0].center), glm::dvec3(0.3, 1.0, -0.2));
    REQUIRE(first.surfaces > 100);
    check_against_exact_spheres(ps, {0.3f, 1.0f, -0.2f});
}

TEST_CASE("optical depth: sphere stand-ins in a line along the light", "[optical-depth]") {
    // Spacing 0.3, radius 0.4: each ray starts inside its neighbours and runs through every centre above.
    const auto ps = line_along_y(16, 0.3f, 0.4f);
    const std::size_t last = ps.size() - 1;
    check_against_exact_spheres(ps, {0.0f, 1.0f, 0.0f});
    // By hand: particle i's ray runs in smoke in one unbroken stretch up to the top of the last sphere.
    const SmokeScene scene = make_scene(ps, kSphere);
    const Depths got = full_update(scene, ps, {0.0f, 1.0f, 0.0f});
    for (std::size_t i = 0; i < ps.size(); ++i) {
        const double want = double(ps[last].center.y) + double(ps[last].radius) - double(ps[i].center.y);
        const SphereAnswer exact = exact_spheres(ps, glm::dvec3(ps[i].center), {0.0, 1.0, 0.0});
        CHECK(exact.length == Approx(want).epsilon(1e-12));  // the reference agrees with the hand answer
        CHECK(std::abs(double(got.lengths[i]) - want) <= exact.tolerance);
        // Own exit; the neighbour below (0.3 < 0.4 away) covers the origin: its exit; the neighbour above
        // too; every particle from i + 2 up is entered and left.
        const std::size_t surfaces =
            1 + (i >= 1 ? 1 : 0) + (i + 1 <= last ? 1 : 0) + 2 * (i + 2 <= last ? last - (i + 1) : 0);
        CHECK(got.hit_counts[i] == surfaces);
    }
}

TEST_CASE("optical depth: sphere stand-ins in random scenes", "[optical-depth]") {
    for (std::uint64_t seed : {1u, 2u, 3u}) {
        INFO("seed " << seed);
        check_against_exact_spheres(random_box(seed, 300), {0.2f, 1.0f, 0.45f});
    }
}

TEST_CASE("optical depth: a particle far from everything has l equal to its radius", "[optical-depth]") {
    std::vector<Particle> ps = tube_particles(100);
    ps.push_back(particle({1.0e4f, 0.0f, 0.0f}, 0.5f));
    ps.push_back(particle({-50.0f, 3.0f, 20.0f}, 0.35f));
    const SmokeScene scene = make_scene(ps, kSphere);

    // Radius 0.5, light straight up: the object-space direction (0, 2, 0) is exact, so is the exit t = 0.5.
    const Depths up = full_update(scene, ps, {0.0f, 1.0f, 0.0f});
    CHECK(up.lengths[100] == 0.5f);
    CHECK(up.hit_counts[100] == 1);  // its own exit only
    // Radius 0.35 (not a power of two) and an oblique light: the length of the direction is off by at most 4
    // roundings after normalising, 1 more after scaling into object space, and t is rounded once: 6 in all,
    // within kRoundingsPerRay.
    const Depths oblique = full_update(scene, ps, {0.3f, 0.8f, -0.5f});
    for (std::size_t i : {100u, 101u}) {
        const double r = ps[i].radius;
        CHECK(std::abs(double(oblique.lengths[i]) - r) <= kRoundingsPerRay * kFloatUnit * r);
        CHECK(oblique.hit_counts[i] == 1);
        CHECK(oblique.status[i] == DepthStatus::ok);
    }
}

TEST_CASE("optical depth: cutoff at K - 1, K and K + 1 surfaces", "[optical-depth]") {
    // Particle 0 at the origin; `above` separate particles straight above it (spacing 1 > 2·radius), each
    // entered and left: its ray meets 1 + 2·above surfaces. With `covering`, one more particle contains the
    // origin but lies off the line of the others: one more surface (its exit), so both parities occur.
    // Along +y the rays pass exactly through icosahedron edge midpoints (entry and exit), so a duplicate
    // report at a shared edge would show up as an extra hit.
    constexpr std::uint32_t above = 5;
    for (bool covering : {false, true}) {
        for (StandInShape shape : {kSphere, kIcosahedron, kIcosphere1}) {
            std::vector<Particle> ps{particle({0.0f, 0.0f, 0.0f}, 0.4f)};
            for (std::uint32_t k = 1; k <= above; ++k) ps.push_back(particle({0.0f, float(k), 0.0f}, 0.4f));
            if (covering) ps.push_back(particle({0.2f, 0.0f, 0.0f}, 0.3f));
            const std::uint32_t m = 1 + 2 * above + (covering ? 1 : 0);
            const SmokeScene scene = make_scene(ps, shape);
            const glm::vec3 up(0.0f, 1.0f, 0.0f);
            INFO("shape " << shape.name() << ", covering " << covering << ", particle 0 meets " << m);

            const Depths none = full_update(scene, ps, up, 0);
            REQUIRE(none.status[0] == DepthStatus::ok);
            REQUIRE(none.hit_counts[0] == m);
            // The others in the line: own exit plus 2 per particle above.
            for (std::uint32_t k = 1; k <= above; ++k) CHECK(none.hit_counts[k] == 1 + 2 * (above - k));

            const Depths at_k_minus_1 = full_update(scene, ps, up, m - 1);
            CHECK(at_k_minus_1.status[0] == DepthStatus::cutoff);
            CHECK(at_k_minus_1.hit_counts[0] == m);  // K + 1: the search ended at the (K+1)-th surface
            CHECK(at_k_minus_1.lengths[0] == kInf);

            for (std::uint32_t cutoff : {m, m + 1}) {
                const Depths d = full_update(scene, ps, up, cutoff);
                CHECK(d.status[0] == DepthStatus::ok);
                CHECK(d.hit_counts[0] == m);
                CHECK(same_bits(std::vector<float>{d.lengths[0]}, std::vector<float>{none.lengths[0]}));
            }
            if (shape == kSphere) {
                // r (own exit) + 2·r per particle above, plus nothing for the covering one (it ends at
                // y = √(0.3² − 0.2²) ≈ 0.22 < r, inside particle 0's own stretch).
                const double want = double(0.4f) * (1 + 2 * above);
                const SphereAnswer exact = exact_spheres(ps, {0.0, 0.0, 0.0}, {0.0, 1.0, 0.0});
                CHECK(exact.length == Approx(want).epsilon(1e-12));
                CHECK(std::abs(double(none.lengths[0]) - want) <= exact.tolerance);
            }
        }
    }
}

TEST_CASE("optical depth: the ground occludes, before and after the cutoff", "[optical-depth]") {
    // Particles in a column along +y at y = −2.5, −1.5, … 2.5 (radius 0.4: separate); the ground at y = 0
    // covers the column, between particles 2 and 3. Along +y the icosahedra are entered and left exactly
    // through edge midpoints.
    std::vector<Particle> ps;
    for (int k = 0; k < 6; ++k) ps.push_back(particle({0.1f, -2.5f + float(k), 0.2f}, 0.4f));
    const GroundQuad ground = horizontal_quad(0.0f, 10.0f);
    for (StandInShape shape : {kSphere, kIcosahedron}) {
        INFO("shape " << shape.name());
        const SmokeScene scene = make_scene(ps, shape, ground);
        const glm::vec3 up(0.0f, 1.0f, 0.0f);
        // Cutoff 2 and 3: particle 0 meets 5 surfaces before the ground (the pass is cut off before it
        // knows about the ground), particle 1 meets 3 (at or under the cutoff): both must come out occluded.
        for (std::uint32_t cutoff : {0u, 2u, 3u}) {
            INFO("cutoff " << cutoff);
            const Depths d = full_update(scene, ps, up, cutoff);
            // Below the ground: own exit, then 2 for each particle between it and y = 0.
            for (int k = 0; k < 3; ++k) {
                CHECK(d.status[k] == DepthStatus::occluded);
                CHECK(d.hit_counts[k] == std::uint32_t(1 + 2 * (2 - k)));
                CHECK(d.lengths[k] == kInf);
            }
            // Above the ground: own exit plus 2 per particle above, with the cutoff rule.
            for (int k = 3; k < 6; ++k) {
                const std::uint32_t m = std::uint32_t(1 + 2 * (5 - k));
                if (cutoff != 0 && m > cutoff) {
                    CHECK(d.status[k] == DepthStatus::cutoff);
                    CHECK(d.hit_counts[k] == cutoff + 1);
                    CHECK(d.lengths[k] == kInf);
                } else {
                    CHECK(d.status[k] == DepthStatus::ok);
                    CHECK(d.hit_counts[k] == m);
                    CHECK(d.lengths[k] < kInf);
                }
            }
        }
    }
    // Light from the side: the rays run parallel to the ground and nothing is occluded.
    const SmokeScene scene = make_scene(ps, kSphere, ground);
    const Depths side = full_update(scene, ps, {1.0f, 0.0f, 0.0f});
    for (std::size_t k = 0; k < ps.size(); ++k) {
        CHECK(side.status[k] == DepthStatus::ok);
        CHECK(std::abs(double(side.lengths[k]) - 0.4) <= kRoundingsPerRay * kFloatUnit);
    }
}

TEST_CASE("optical depth: ground under the two tubes with oblique light occludes exactly the shadowed rays",
          "[optical-depth]") {
    // A ground quad hung ABOVE part of the smoke (y = 1.5, x < 0 only), light oblique: a particle is occluded
    // exactly when its ray meets the quad, which is computed here in double (the quad is a rectangle in a
    // horizontal plane: one division and two range checks). Non-occluded particles must still match the
    // analytic spheres; occluded ones must count exactly the spheres' surfaces between the centre and the quad.
    const auto ps = tube_particles();
    const GroundQuad quad{{glm::vec3(-4.0f, 1.5f, 4.0f), glm::vec3(0.0f, 1.5f, 4.0f), glm::vec3(0.0f, 1.5f, -4.0f),
                           glm::vec3(-4.0f, 1.5f, -4.0f)}};
    const glm::vec3 to_light(0.25f, 1.0f, 0.1f);
    const SmokeScene scene = make_scene(ps, kSphere, quad);
    const Depths got = full_update(scene, ps, to_light);
    const glm::dvec3 d = glm::normalize(glm::dvec3(to_light));
    // A ray within this distance of the quad's border or plane may go either way after float rounding.
    constexpr double kBorderMargin = 1e-5;
    std::size_t occluded = 0, decided = 0;
    for (std::size_t i = 0; i < ps.size(); ++i) {
        const glm::dvec3 o(ps[i].center);
        const double t = (1.5 - o.y) / d.y;
        const glm::dvec3 at = o + t * d;
        const bool near_border = std::abs(at.x) < kBorderMargin || std::abs(at.x + 4.0) < kBorderMargin ||
                                 std::abs(std::abs(at.z) - 4.0) < kBorderMargin || std::abs(t) < kBorderMargin;
        if (near_border) continue;
        ++decided;
        const bool hits_quad = t > 0.0 && at.x > -4.0 && at.x < 0.0 && std::abs(at.z) < 4.0;
        INFO("particle " << i);
        if (hits_quad) {
            ++occluded;
            CHECK(got.status[i] == DepthStatus::occluded);
            CHECK(got.lengths[i] == kInf);
            // Surfaces in front of the quad: the spheres' surfaces on the ray cut at the quad.
            const SphereAnswer front = exact_spheres(ps, o, d, {.t_cut = t, .cut_margin = kBorderMargin});
            CHECK(got.hit_counts[i] >= front.surfaces);
            CHECK(got.hit_counts[i] <= front.surfaces + front.ambiguous);
        } else {
            CHECK(got.status[i] == DepthStatus::ok);
            const SphereAnswer want = exact_spheres(ps, o, d);
            CHECK(std::abs(double(got.lengths[i]) - want.length) <= want.tolerance);
        }
    }
    // The scene must really exercise both outcomes.
    CHECK(occluded > 100);
    CHECK(decided - occluded > 100);
}

TEST_CASE("optical depth: particle groups update 1/G of the particles, the others keep their values",
          "[optical-depth]") {
    SECTION("particle_group partitions the particles round-robin") {
        for (std::size_t n : {0u, 1u, 7u, 750u}) {
            for (std::uint32_t g : {1u, 3u, 32u}) {
                std::vector<int> seen(n, 0);
                for (std::uint64_t frame = 0; frame < g; ++frame) {
                    const std::uint64_t f = frame + 1000003ull * g;  // any frame number, not just 0…G−1
                    const auto ids = particle_group(n, g, f);
                    REQUIRE(std::is_sorted(ids.begin(), ids.end()));
                    for (std::uint32_t i : ids) {
                        REQUIRE(i < n);
                        REQUIRE(i % g == f % g);
                        ++seen[i];
                    }
                }
                CHECK(std::all_of(seen.begin(), seen.end(), [](int s) { return s == 1; }));
            }
        }
        CHECK_THROWS_AS(particle_group(10, 0, 0), std::invalid_argument);
    }
    SECTION("OpticalPathLengths updates the group and keeps stale values elsewhere") {
        const auto ps = tube_particles();
        const SmokeScene scene = make_scene(ps, kIcosahedron);
        const glm::vec3 light_a(0.0f, 1.0f, 0.0f), light_b(1.0f, 0.2f, 0.0f);
        const std::uint32_t cutoff = 40;  // some particles cut off: statuses differ between the lights
        const Depths full_a = full_update(scene, ps, light_a, cutoff);
        const Depths full_b = full_update(scene, ps, light_b, cutoff);

        OpticalPathLengths od(ps.size());
        for (std::size_t i = 0; i < ps.size(); ++i) {  // before any update: fully lit, nothing counted
            REQUIRE(od.lengths()[i] == 0.0f);
            REQUIRE(od.status()[i] == DepthStatus::ok);
            REQUIRE(od.hit_counts()[i] == 0);
        }
        const std::uint32_t groups = 4;
        const auto g0 = particle_group(ps.size(), groups, 0);
        const auto g1 = particle_group(ps.size(), groups, 1);
        // update() times its two stages into od_pass and resolve and leaves the other fields to its caller
        // (the fields start at -1 to see which were written). The stages run one after the other inside the
        // call, so together they take at most the call itself, timed around it with the same clock (1e-12:
        // each duration is rounded once when converted to double milliseconds).
        for (const auto& [group, light] : {std::pair{g0, light_a}, std::pair{g1, light_b}}) {
            FrameTimings timings{-1.0, -1.0, -1.0, -1.0, -1.0};
            StageClock call;
            od.update(scene, ps, group, light, OpticalDepthSettings{cutoff}, HitSort::adaptive, timings);
            const double call_ms = call.lap_ms();
            CHECK(timings.od_pass >= 0.0);
            CHECK(timings.resolve >= 0.0);
            CHECK(timings.od_pass + timings.resolve <= call_ms * (1.0 + 1e-12));
            CHECK(timings.tlas_update == -1.0);
            CHECK(timings.view == -1.0);
            CHECK(timings.total == -1.0);
        }
        std::size_t differ = 0;
        for (std::size_t i = 0; i < ps.size(); ++i) {
            INFO("particle " << i);
            const Depths* want = nullptr;
            if (i % groups == 0) want = &full_a;       // updated in frame 0 and stale since
            else if (i % groups == 1) want = &full_b;  // updated in frame 1
            if (want) {
                CHECK(std::bit_cast<std::uint32_t>(od.lengths()[i]) == std::bit_cast<std::uint32_t>(want->lengths[i]));
                CHECK(od.status()[i] == want->status[i]);
                CHECK(od.hit_counts()[i] == want->hit_counts[i]);
            } else {
                CHECK(od.lengths()[i] == 0.0f);  // never updated
                CHECK(od.hit_counts()[i] == 0);
            }
            differ += full_a.lengths[i] != full_b.lengths[i];
        }
        CHECK(differ > ps.size() / 2);  // the two lights really give different answers
    }
    SECTION("the pass reports the group's particles in the order given") {
        const auto ps = tube_particles(200);
        const SmokeScene scene = make_scene(ps, kSphere);
        const std::vector<std::uint32_t> which{150, 3, 77, 3, 199};
        OpticalDepthPass pass;
        OpticalDepthHits out;
        pass.run(scene, ps, which, {0.0f, 1.0f, 0.0f}, {}, out);
        const OpticalDepthHits all = run_pass(scene, ps, {0.0f, 1.0f, 0.0f});
        REQUIRE(out.particles == which);
        REQUIRE(out.lists.particle_count() == which.size());
        for (std::size_t k = 0; k < which.size(); ++k) {
            CHECK(out.hit_counts[k] == all.hit_counts[which[k]]);
            CHECK(out.status[k] == all.status[which[k]]);
            const std::span<const SurfaceHit> a = out.lists.of(k), b = all.lists.of(which[k]);
            REQUIRE(a.size() == b.size());
            CHECK(std::memcmp(a.data(), b.data(), a.size_bytes()) == 0);
        }
    }
}

TEST_CASE("optical depth: radix, std::sort and bubble sort give bit-identical lengths on the tube scene",
          "[optical-depth]") {
    // 750 particles (the thesis's default), 1500, and 3000, whose rays along the lower tube (light from +x)
    // meet enough surfaces for the long-list radix path as well as the short-list rank sort.
    std::uint32_t longest = 0;
    for (const auto& [n, shape] : {std::pair{750u, kSphere}, std::pair{750u, kIcosahedron},
                                   std::pair{1500u, kSphere}, std::pair{1500u, kIcosahedron},
                                   std::pair{3000u, kSphere}}) {
        const auto ps = tube_particles(n);
        const SmokeScene scene = make_scene(ps, shape);
        for (std::uint32_t cutoff : {0u, 60u}) {
            for (glm::vec3 light : {glm::vec3(0, 1, 0), glm::vec3(1, 0.3f, 0.2f), glm::vec3(1, 0, 0)}) {
                INFO(n << " particles, shape " << shape.name() << " cutoff " << cutoff);
                const Depths radix = full_update(scene, ps, light, cutoff, HitSort::adaptive);
                const Depths stds = full_update(scene, ps, light, cutoff, HitSort::std_sort);
                const Depths bubble = full_update(scene, ps, light, cutoff, HitSort::bubble);
                CHECK(same_bits(radix.lengths, stds.lengths));
                CHECK(same_bits(radix.lengths, bubble.lengths));
                CHECK(radix.status == stds.status);
                CHECK(radix.status == bubble.status);
                CHECK(radix.hit_counts == bubble.hit_counts);
                for (std::size_t i = 0; i < ps.size(); ++i)
                    longest = std::max(longest, radix.status[i] == DepthStatus::ok ? radix.hit_counts[i] : 0u);
            }
        }
    }
    // Long lists occurred, so the radix path ran, not only the short-list rank sort (radix_sort.hpp).
    CHECK(longest >= kRadixSortMinItems);
}

TEST_CASE("optical depth: resolving the kept hits in place gives the bits of gathering them first",
          "[optical-depth]") {
    // OpticalPathLengths resolves the hits where the pass kept them (OpticalDepthPass::resolve); run() gathers
    // them into one buffer for resolve_optical_path_lengths(). Both, for every sort, with a cutoff that
    // cuts some rays off and a quad over part of the smoke that occludes others, for all particles and
    // for a group (every third particle, in reverse order).
    const auto ps = tube_particles(1500);
    const GroundQuad quad{{glm::vec3(-4.0f, 1.5f, 4.0f), glm::vec3(0.0f, 1.5f, 4.0f), glm::vec3(0.0f, 1.5f, -4.0f),
                           glm::vec3(-4.0f, 1.5f, -4.0f)}};
    const std::vector<std::uint32_t> all = all_of(ps.size());
    const std::vector<std::uint32_t> group = [&] {
        std::vector<std::uint32_t> g;
        for (std::size_t i = ps.size(); i-- > 0;)
            if (i % 3 == 0) g.push_back(static_cast<std::uint32_t>(i));
        return g;
    }();
    for (StandInShape shape : {kSphere, kIcosahedron}) {
        const SmokeScene scene = make_scene(ps, shape, quad);
        for (const std::uint32_t cutoff : {0u, 40u}) {
            for (const HitSort sort : {HitSort::adaptive, HitSort::std_sort, HitSort::bubble}) {
                for (const std::vector<std::uint32_t>* which : {&all, &group}) {
                    INFO("shape " << shape.name() << ", cutoff " << cutoff << ", sort " << int(sort) << ", "
                                  << which->size() << " particles");
                    OpticalDepthPass pass;
                    OpticalDepthHits gathered;
                    pass.trace(scene, ps, *which, {0.25f, 1.0f, 0.1f}, OpticalDepthSettings{cutoff});
                    pass.gather(gathered);
                    std::vector<float> in_place(which->size()), from_gathered(which->size());
                    pass.resolve(sort, in_place);
                    resolve_optical_path_lengths(gathered.lists, gathered.status, from_gathered, sort);
                    CHECK(same_bits(in_place, from_gathered));
                    CHECK(std::equal(pass.status().begin(), pass.status().end(), gathered.status.begin(),
                                     gathered.status.end()));
                    CHECK(std::count(gathered.status.begin(), gathered.status.end(), DepthStatus::occluded) > 0);
                    if (cutoff > 0)
                        CHECK(std::count(gathered.status.begin(), gathered.status.end(), DepthStatus::cutoff) > 0);
                    std::vector<float> wrong(which->size() + 1);
                    CHECK_THROWS_AS(pass.resolve(sort, wrong), std::invalid_argument);
                }
            }
        }
    }
}

TEST_CASE("optical depth: results do not depend on the thread count", "[optical-depth]") {
    // 1500 particles: more than one 64-particle chunk per thread, and chunks of uneven work.
    const auto ps = tube_particles(1500);
    for (StandInShape shape : {kSphere, kIcosahedron}) {
        const SmokeScene scene = make_scene(ps, shape);
        const glm::vec3 light(0.4f, 1.0f, 0.1f);
        auto run_with = [&](std::size_t threads) {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
            return std::pair{full_update(scene, ps, light, 60), run_pass(scene, ps, light, 60)};
        };
        const auto [one, one_hits] = run_with(1);
        const auto [two, two_hits] = run_with(2);
        INFO("shape " << shape.name());
        CHECK(same_bits(one.lengths, two.lengths));
        CHECK(one.status == two.status);
        CHECK(one.hit_counts == two.hit_counts);
        // The flat hit buffer itself (any-hit order included) is laid out identically.
        REQUIRE(one_hits.lists.offsets == two_hits.lists.offsets);
        REQUIRE(one_hits.lists.hits.size() == two_hits.lists.hits.size());
        CHECK(std::memcmp(one_hits.lists.hits.data(), two_hits.lists.hits.data(),
                          one_hits.lists.hits.size() * sizeof(SurfaceHit)) == 0);
    }
}

TEST_CASE("optical depth: the bundled pass gives every particle what its ray alone finds", "[optical-depth]") {
    // The pass traces its rays sixteen at a time (trace_bundle). Against the same pass done one ray at a
    // time with trace(), the status rules of optical_depth_pass.hpp written out again here: the same
    // status and hit count for every particle and, for ok particles, the same hits (t bit for bit, as a
    // multiset: the order any-hit sees them in is not fixed). Spheres and icosahedra, oblique light with
    // the ground shadowing part of the tubes, with and without a cutoff.
    const auto ps = tube_particles(750);
    const GroundQuad ground = horizontal_quad(-1.2f, 30.0f);  // through the lower tube
    const glm::vec3 light = glm::normalize(glm::vec3(0.3f, 1.0f, -0.2f));
    for (StandInShape shape : {kSphere, kIcosahedron}) {
        const SmokeScene scene = make_scene(ps, shape, ground);
        for (std::uint32_t cutoff : {0u, 20u}) {
            const OpticalDepthHits out = run_pass(scene, ps, light, cutoff);
            std::size_t ok = 0, occluded = 0, cut = 0;
            for (std::size_t i = 0; i < ps.size(); ++i) {
                const Ray ray{ps[i].center, optical_depth_tmin(ps[i].radius), light, kOpticalDepthTmax};
                std::vector<SurfaceHit> alone;
                const TraceResult r = trace<TlasWalk::all_hits>(scene.scene(), ray, ray_flag_none, kLightRayMask,
                                                               [&](const TraceHit& h) {
                                                                   alone.push_back({h.t, h.front_face() ? 1 : -1});
                                                                   return AnyHitDecision::ignore;
                                                               });
                // Uncut, every surface is seen; the ground, when on the ray, commits (opaque).
                DepthStatus status = DepthStatus::ok;
                std::size_t count = alone.size();
                if (r.hit) {
                    status = DepthStatus::occluded;
                    count = std::size_t(std::count_if(alone.begin(), alone.end(),
                                                      [&](const SurfaceHit& h) { return h.t < r.committed.t; }));
                } else if (cutoff != 0 && count > cutoff) {
                    status = DepthStatus::cutoff;
                    count = cutoff + 1;
                }
                CAPTURE(shape.name(), cutoff, i);
                REQUIRE(out.status[i] == status);
                CHECK(out.hit_counts[i] == count);
                if (status != DepthStatus::ok) {
                    occluded += status == DepthStatus::occluded;
                    cut += status == DepthStatus::cutoff;
                    continue;
                }
                ++ok;
                auto bits = [](std::span<const SurfaceHit> hits) {
                    std::vector<std::pair<std::uint32_t, int>> v;
                    for (const SurfaceHit& h : hits) v.emplace_back(std::bit_cast<std::uint32_t>(h.t), h.value);
                    std::sort(v.begin(), v.end());
                    return v;
                };
                CHECK(bits(out.lists.of(i)) == bits(alone));
            }
            CHECK(ok > 100);
            CHECK(occluded > 50);
            if (cutoff != 0) CHECK(cut > 10);
        }
    }
}

TEST_CASE("optical depth: hits kept over several blocks per thread", "[optical-depth]") {
    // The two tubes at 50,000 particles (radius 0.35·√(750/N), as the large scenes: ~18 surfaces per ray),
    // some 900,000 kept hits: at one thread more than three blocks, at two more than one block per thread,
    // with rays' lists ending at block ends. Against each ray traced alone and the analytic answer for a
    // sample, against gathering the hits first for all, at one and two threads alike.
    constexpr std::uint32_t kParticles = 50'000;
    TubeSettings settings;
    settings.particles = kParticles;
    settings.particle_radius = 0.35f * std::sqrt(750.0f / float(kParticles));
    const std::vector<Particle> ps = generate_tubes(settings);
    const SmokeScene scene = make_scene(ps, kSphere);
    const glm::vec3 light(0.0f, 1.0f, 0.0f);
    std::vector<float> first_lengths;
    for (const std::size_t threads : {1u, 2u}) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        OpticalDepthPass pass;
        OpticalDepthHits gathered;
        pass.trace(scene, ps, all_of(ps.size()), light, OpticalDepthSettings{});
        pass.gather(gathered);
        INFO(threads << " threads, " << gathered.lists.hit_count() << " hits");
        REQUIRE(gathered.lists.hit_count() > 5 * kKeptHitsPerBlock / 2);
        std::vector<float> in_place(ps.size()), from_gathered(ps.size());
        pass.resolve(HitSort::adaptive, in_place);
        resolve_optical_path_lengths(gathered.lists, gathered.status, from_gathered, HitSort::adaptive);
        CHECK(same_bits(in_place, from_gathered));
        if (first_lengths.empty()) first_lengths = in_place;
        else CHECK(same_bits(in_place, first_lengths));
        for (std::size_t i = 0; i < ps.size(); i += 37) {
            CAPTURE(i);
            REQUIRE(gathered.status[i] == DepthStatus::ok);
            const Ray ray{ps[i].center, optical_depth_tmin(ps[i].radius), light, kOpticalDepthTmax};
            std::vector<std::uint32_t> alone, kept;
            trace<TlasWalk::all_hits>(scene.scene(), ray, ray_flag_none, kLightRayMask, [&](const TraceHit& h) {
                alone.push_back(std::bit_cast<std::uint32_t>(h.t) ^ (h.front_face() ? 0u : 1u));
                return AnyHitDecision::ignore;
            });
            for (const SurfaceHit& h : gathered.lists.of(i))
                kept.push_back(std::bit_cast<std::uint32_t>(h.t) ^ (h.value > 0 ? 0u : 1u));
            std::sort(alone.begin(), alone.end());
            std::sort(kept.begin(), kept.end());
            CHECK(kept == alone);
            const SphereAnswer want = exact_spheres(ps, glm::dvec3(ps[i].center), glm::dvec3(light));
            CHECK(std::abs(double(in_place[i]) - want.length) <= want.tolerance);
        }
    }
}

TEST_CASE("optical depth: empty particle lists", "[optical-depth]") {
    const std::vector<Particle> none;
    for (bool with_ground : {false, true}) {
        std::optional<GroundQuad> ground;
        if (with_ground) ground = horizontal_quad(-1.0f, 5.0f);
        const SmokeScene scene = make_scene(none, kIcosahedron, ground);
        const OpticalDepthHits out = run_pass(scene, none, {0.0f, 1.0f, 0.0f}, 10);
        CHECK(out.particles.empty());
        CHECK(out.status.empty());
        CHECK(out.hit_counts.empty());
        CHECK(out.lists.particle_count() == 0);
        CHECK(out.lists.hit_count() == 0);
        OpticalPathLengths od(0);
        FrameTimings t;
        od.update(scene, none, {}, {0.0f, 1.0f, 0.0f}, {}, HitSort::adaptive, t);
        CHECK(od.lengths().empty());
    }
    // Particles, but an empty group.
    const auto ps = tube_particles(10);
    const SmokeScene scene = make_scene(ps, kSphere);
    OpticalDepthPass pass;
    OpticalDepthHits out;
    pass.run(scene, ps, {}, {0.0f, 1.0f, 0.0f}, {}, out);
    CHECK(out.lists.particle_count() == 0);
    OpticalPathLengths od(ps.size());
    FrameTimings t;
    od.update(scene, ps, {}, {0.0f, 1.0f, 0.0f}, {}, HitSort::adaptive, t);
    CHECK(std::all_of(od.lengths().begin(), od.lengths().end(), [](float l) { return l == 0.0f; }));
}

// ---------------------------------------------------------------------------------------------------------
// Smooth density kernels.

namespace {

constexpr DensityKernel kSmoothKernels[] = {kGaussianKernel, kPoly1Kernel, kPoly2Kernel};

// Particle i's l under a smooth kernel without tracing: every particle's share of its ray (0 for those its
// support misses), summed in double, and a bound on the pass's distance from it: the pass sums only the
// particles whose stand-in's exit lies at t >= tmin (the shares it may leave out, of supports left within
// tmin of the origin, are at most peak·tmin each), in another order (n·2^-53 of the shares' sum), and rounds
// to float (2^-24 of l).
struct KernelSum {
    double length = 0, tolerance = 0;
    std::size_t met = 0;  // particles with a share > 0
};
KernelSum brute_force_sum(const DensityKernel& k, const std::vector<Particle>& ps, std::size_t i, glm::vec3 to_light) {
    const glm::dvec3 d = glm::normalize(glm::dvec3(glm::normalize(to_light)));
    KernelSum sum;
    for (const Particle& p : ps) {
        const double share = particle_stretch_integral(k, ps[i].center, d, p.center, p.radius);
        sum.length += share;
        sum.met += share > 0.0;
    }
    sum.tolerance = 0x1p-24 * sum.length + double(ps.size()) * 0x1p-53 * sum.length +
                    double(ps.size()) * double(k.peak) * double(optical_depth_tmin(ps[i].radius));
    return sum;
}

}  // namespace

TEST_CASE("optical depth: a smooth kernel's l is the sum of the shares of every particle its ray meets",
          "[optical-depth][kernel]") {
    // The two tubes, a dense cluster (every ray starts inside many supports) and a line along the light (the
    // rays run through the centres); spheres, and the icosahedron and icosphere, whose inradii hold the fitted
    // supports: they meet the same particles.
    struct Scene {
        const char* name;
        std::vector<Particle> ps;
        glm::vec3 light;
    };
    const Scene scenes[] = {{"tubes", tube_particles(750), glm::normalize(glm::vec3(0.4f, 1.0f, 0.1f))},
                            {"cluster", dense_cluster(9, 60), glm::vec3(0.0f, 1.0f, 0.0f)},
                            {"line", line_along_y(12, 0.3f, 0.5f), glm::vec3(0.0f, 1.0f, 0.0f)}};
    for (const Scene& scene : scenes) {
        for (const StandInShape shape : {kSphere, kIcosahedron, kIcosphere1}) {
            const SmokeScene smoke = make_scene(scene.ps, shape);
            for (const DensityKernel& k : kSmoothKernels) {
                const Depths got = full_update(smoke, scene.ps, scene.light, 0, HitSort::adaptive, k);
                std::size_t several = 0;
                for (std::size_t i = 0; i < scene.ps.size(); ++i) {
                    const KernelSum want = brute_force_sum(k, scene.ps, i, scene.light);
                    INFO(scene.name << ", " << shape.name() << ", " << k.name() << ", particle " << i << ": l "
                                    << got.lengths[i] << ", brute force " << want.length << " ± " << want.tolerance);
                    REQUIRE(got.status[i] == DepthStatus::ok);
                    REQUIRE(std::abs(double(got.lengths[i]) - want.length) <= want.tolerance);
                    several += want.met > 1;
                }
                CHECK(several > scene.ps.size() / 2);  // the rays meet more than their own particle
            }
        }
    }
}

TEST_CASE("optical depth: a smooth kernel keeps the uniform kernel's statuses, hit counts and cutoff",
          "[optical-depth][kernel]") {
    // The same rays and the same any-hit calls: only what is made of the hits differs. Oblique light, the
    // ground through the lower tube, with and without a cutoff.
    const auto ps = tube_particles(750);
    const GroundQuad ground = horizontal_quad(-1.2f, 30.0f);
    const glm::vec3 light = glm::normalize(glm::vec3(0.3f, 1.0f, -0.2f));
    for (const StandInShape shape : {kSphere, kIcosahedron}) {
        const SmokeScene scene = make_scene(ps, shape, ground);
        for (const std::uint32_t cutoff : {0u, 20u}) {
            const Depths uniform = full_update(scene, ps, light, cutoff);
            std::size_t dark = 0;
            for (const DensityKernel& k : kSmoothKernels) {
                CAPTURE(shape.name(), cutoff, k.name());
                const Depths got = full_update(scene, ps, light, cutoff, HitSort::adaptive, k);
                CHECK(got.status == uniform.status);
                CHECK(got.hit_counts == uniform.hit_counts);
                for (std::size_t i = 0; i < ps.size(); ++i) {
                    if (got.status[i] == DepthStatus::ok) {
                        CHECK(std::isfinite(got.lengths[i]));
                        CHECK(got.lengths[i] > 0.0f);  // its own support, from the centre
                    } else {
                        CHECK(got.lengths[i] == kInf);
                        ++dark;
                    }
                }
                // The sort is the union walk's: a smooth kernel gives the same bits with any of them.
                CHECK(same_bits(full_update(scene, ps, light, cutoff, HitSort::bubble, k).lengths, got.lengths));
                // No hits kept: gather() gives the statuses and counts, and empty lists.
                const OpticalDepthHits hits = run_pass(scene, ps, light, cutoff, k);
                CHECK(hits.status == uniform.status);
                CHECK(hits.hit_counts == uniform.hit_counts);
                CHECK(hits.lists.particle_count() == ps.size());
                CHECK(hits.lists.hit_count() == 0);
            }
            CHECK(dark > 50);
        }
    }
}

TEST_CASE("optical depth: a smooth kernel's lengths do not depend on the thread count", "[optical-depth][kernel]") {
    const auto ps = tube_particles(1500);
    const glm::vec3 light(0.4f, 1.0f, 0.1f);
    for (const StandInShape shape : {kSphere, kIcosahedron}) {
        const SmokeScene scene = make_scene(ps, shape);
        for (const DensityKernel& k : kSmoothKernels) {
            auto run_with = [&](std::size_t threads) {
                tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
                return full_update(scene, ps, light, 60, HitSort::adaptive, k);
            };
            const Depths one = run_with(1), two = run_with(2);
            CAPTURE(shape.name(), k.name());
            CHECK(same_bits(one.lengths, two.lengths));
            CHECK(one.status == two.status);
            CHECK(one.hit_counts == two.hit_counts);
        }
    }
}

TEST_CASE("optical depth: a smooth kernel's sum is that of the exits its ray alone finds", "[optical-depth][kernel]") {
    // Each ray traced alone with trace(): the shares of its exits (back faces, their particles by user id)
    // summed in double, against the bundled pass's l. The walk of a bundle may meet the exits in another order
    // (trace_bundle.hpp), so the two sums agree to their roundings: 2^-24 of l for the float, and n·2^-53 of
    // it for the order, n the exits.
    const auto ps = tube_particles(750);
    const glm::vec3 light = glm::normalize(glm::vec3(0.3f, 1.0f, -0.2f));
    const glm::dvec3 d = glm::normalize(glm::dvec3(light));
    for (const StandInShape shape : {kSphere, kIcosahedron}) {
        const SmokeScene scene = make_scene(ps, shape);
        for (const DensityKernel& k : kSmoothKernels) {
            const Depths got = full_update(scene, ps, light, 0, HitSort::adaptive, k);
            for (std::size_t i = 0; i < ps.size(); ++i) {
                const Ray ray{ps[i].center, optical_depth_tmin(ps[i].radius), light, kOpticalDepthTmax};
                double sum = 0;
                std::size_t exits = 0;
                (void)trace<TlasWalk::all_hits>(scene.scene(), ray, ray_flag_none, kLightRayMask, [&](const TraceHit& h) {
                    if (!h.front_face()) {
                        const Particle& p = ps[h.instance_id];
                        sum += particle_stretch_integral(k, ps[i].center, d, p.center, p.radius);
                        ++exits;
                    }
                    return AnyHitDecision::ignore;
                });
                CAPTURE(shape.name(), k.name(), i);
                REQUIRE(got.status[i] == DepthStatus::ok);
                CHECK(std::abs(double(got.lengths[i]) - sum) <= (0x1p-24 + double(exits) * 0x1p-53) * sum);
            }
        }
    }
}

TEST_CASE("optical depth: a kernel out of range is refused before any ray is traced", "[optical-depth][kernel]") {
    const auto ps = tube_particles(10);
    const SmokeScene scene = make_scene(ps, kSphere);
    OpticalDepthPass pass;
    for (const DensityKernel& bad : {DensityKernel{DensityKernelKind::poly1, 1.25f, 1.0f},
                                     DensityKernel{DensityKernelKind::gaussian, 0.5f, -1.0f}}) {
        CHECK_THROWS_AS(pass.trace(scene, ps, all_of(ps.size()), {0.0f, 1.0f, 0.0f}, settings_of(0, bad)),
                        std::invalid_argument);
        CHECK(pass.status().empty());
    }
}
