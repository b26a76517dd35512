// textbook::optical_depths() (textbook/optical_depth.hpp) is the definition the fast optical-depth pass and
// hit resolver (OpticalPathLengths: bundles, packed hits, every HitSort) are held to, on the shipped scenes and
// on adversarial ones (nested and overlapping particles, the ground under and through particles, cutoffs at
// exactly K and K + 1 crossings, every stand-in shape and density kernel): the same statuses and hit counts,
// and lengths within the tolerances below. Also eq. 3.1 itself (length_in_smoke) on hand-made crossings.
#include <smoketrace/core/prng.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/smoke/hit_resolver.hpp>
#include <smoketrace/smoke/optical_path_lengths.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>
#include <smoketrace/textbook/optical_depth.hpp>

#include "support/fixtures.hpp"

#include <catch2/catch.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <vector>

using namespace smoketrace;

namespace {

// Tolerances, for a float length l of a particle whose ray crosses n surfaces, the farthest at distance D.
//  * Uniform kernel: the fast and the textbook l are double sums of the same gaps in different orders (the fast
//    walk's eight running sums, hit_resolver.cpp; the textbook's one), each rounded once to float: at most one
//    float ulp apart, 2^-23·l. Where the fast path tests a particle as a world sphere (every sphere stand-in
//    under its similarity transform, accel_scene.hpp) each crossing's t may differ from the textbook's
//    object-space root by one float ulp (2^-23·t ≤ 2^-23·D), and l is a signed sum of the crossings' t: n such
//    ulps more.
//  * Smooth kernels: each exit's share is the same double (particle_stretch_integral(), whoever calls it),
//    summed in another order: one float ulp, 2^-23·l. The crossings' t do not enter.
constexpr double kFloatUlp = 0x1p-23;
double uniform_tolerance(double l, std::uint32_t n, double D) { return kFloatUlp * (l + double(n) * D); }
// Two recursive sums in double of the same n − 1 terms >= 0 (the gaps between n sorted crossings), in any two
// orders: each within (n − 1)·2^-53 of the exact sum l.
double summation_order_tolerance(double l, std::size_t n) { return 2.0 * double(n > 0 ? n - 1 : 0) * 0x1p-53 * l; }

// The farthest any light ray of these particles can reach a surface: the particles' bounding box diagonal.
double reach_of(std::span<const Particle> ps) {
    glm::dvec3 lo(1e300), hi(-1e300);
    for (const Particle& p : ps) {
        lo = glm::min(lo, glm::dvec3(p.center) - double(p.radius));
        hi = glm::max(hi, glm::dvec3(p.center) + double(p.radius));
    }
    return glm::length(hi - lo);
}

struct Case {
    std::vector<Particle> particles;
    std::optional<GroundQuad> ground;
    glm::vec3 to_light;
};

// The fast pass with `sort` against the textbook, every particle; returns how many were ok.
std::size_t check_against_textbook(const Case& c, StandInShape shape, const DensityKernel& kernel,
                                   std::uint32_t cutoff, HitSort sort) {
    SmokeScene scene(c.particles, shape, c.ground, false);
    scene.update(c.particles, glm::vec3(0.0f, 0.0f, 100.0f));
    const std::vector<std::uint32_t> all = test::all_of(c.particles.size());
    OpticalDepthSettings settings;
    settings.cutoff = cutoff;
    settings.kernel = kernel;
    OpticalPathLengths fast(c.particles.size());
    FrameTimings timings;
    fast.update(scene, c.particles, all, c.to_light, settings, sort, timings);
    const textbook::OpticalDepths book = textbook::optical_depths(scene, c.particles, all, c.to_light, cutoff, kernel);
    const double reach = reach_of(c.particles);
    std::size_t ok = 0;
    for (std::size_t i = 0; i < c.particles.size(); ++i) {
        CAPTURE(i, shape.name(), kernel.name(), cutoff, int(sort));
        REQUIRE(fast.status()[i] == book.status[i]);
        REQUIRE(fast.hit_counts()[i] == book.hit_counts[i]);
        const double want = book.lengths[i], got = fast.lengths()[i];
        if (book.status[i] != DepthStatus::ok) {
            CHECK(got == double(kFullyDarkPathLength));
            CHECK(want == double(kFullyDarkPathLength));
            continue;
        }
        ++ok;
        // World spheres only for the sphere stand-in: the meshes take the object-space path in both.
        const bool world_spheres = shape.kind == StandInKind::sphere && !kernel.smooth();
        const double tolerance = world_spheres ? uniform_tolerance(want, book.hit_counts[i], reach) : kFloatUlp * want;
        CHECK(std::abs(got - want) <= tolerance);
    }
    return ok;
}

constexpr DensityKernel kKernels[] = {kUniformKernel, kGaussianKernel, kPoly1Kernel, kPoly2Kernel};
constexpr HitSort kSorts[] = {HitSort::adaptive, HitSort::std_sort, HitSort::bubble};

std::vector<std::filesystem::path> shipped_scenes() {
    std::vector<std::filesystem::path> files;
    for (const auto& e : std::filesystem::directory_iterator(std::filesystem::path(SMOKETRACE_ASSET_DIR) / "scenes"))
        if (e.path().extension() == ".json") files.push_back(e.path());
    std::sort(files.begin(), files.end());
    return files;
}

}  // namespace

TEST_CASE("textbook optical depth: eq. 3.1 on hand-made crossings", "[textbook][optical-depth]") {
    using textbook::Crossing;
    using textbook::length_in_smoke;
    // Starting inside one particle that it leaves at 1: in smoke over [0, 1].
    CHECK(length_in_smoke(std::vector<Crossing>{{1.0f, -1}}) == 1.0);
    // Then a gap, and a second particle over [3, 5]: the gap is not smoke.
    CHECK(length_in_smoke(std::vector<Crossing>{{1.0f, -1}, {3.0f, +1}, {5.0f, -1}}) == 3.0);
    // Nested: [2, 8] holds [3, 4]; the union counts the overlap once.
    CHECK(length_in_smoke(std::vector<Crossing>{{0.5f, -1}, {2.0f, +1}, {3.0f, +1}, {4.0f, -1}, {8.0f, -1}}) == 6.5);
    // Overlapping, entered before the first is left: [2, 6] ∪ [5, 7] = [2, 7].
    CHECK(length_in_smoke(std::vector<Crossing>{{0.25f, -1}, {2.0f, +1}, {5.0f, +1}, {6.0f, -1}, {7.0f, -1}}) == 5.25);
    // Starting inside two (both left ahead): in smoke until the second exit.
    CHECK(length_in_smoke(std::vector<Crossing>{{1.0f, -1}, {1.5f, -1}}) == 1.5);
    // Touching at t = 4 (an exit and an entry at the same t, in either order): one stretch [2, 6].
    CHECK(length_in_smoke(std::vector<Crossing>{{0.5f, -1}, {2.0f, +1}, {4.0f, -1}, {4.0f, +1}, {6.0f, -1}}) == 4.5);
    CHECK(length_in_smoke(std::vector<Crossing>{{0.5f, -1}, {2.0f, +1}, {4.0f, +1}, {4.0f, -1}, {6.0f, -1}}) == 4.5);
    CHECK(length_in_smoke(std::vector<Crossing>{}) == 0.0);
}

TEST_CASE("textbook optical depth: the fast pass gives the shipped scenes' statuses, counts and lengths",
          "[textbook][optical-depth]") {
    std::size_t ok = 0, particles = 0;
    for (const auto& file : shipped_scenes()) {
        CAPTURE(file.string());
        const SceneDescription d = load_scene_file(file);
        Case c{d.smoke.particles, std::nullopt, d.light.direction};
        if (d.ground) c.ground = GroundQuad{d.ground->corners};
        for (const DensityKernel& kernel : kKernels)
            for (const std::uint32_t cutoff : {d.render.cutoff, 0u})
                for (const HitSort sort : kSorts) {
                    ok += check_against_textbook(c, d.smoke.shape, kernel, cutoff, sort);
                    particles += c.particles.size();
                }
        ok += check_against_textbook(c, StandInShape{StandInKind::icosahedron, 0}, kUniformKernel, 0, HitSort::adaptive);
    }
    CHECK(ok > particles / 2);
}

TEST_CASE("textbook optical depth: nested, overlapping and grounded particles, cutoffs at K and K + 1",
          "[textbook][optical-depth]") {
    // A column of particles along the light (each ray crosses its own exit and two surfaces of every particle
    // above it, fewer where they nest or overlap), a nested pair, an overlapping chain, particles on the
    // ground and under it, and a particle whose centre lies on another's surface.
    Case c;
    c.to_light = glm::vec3(0.0f, 1.0f, 0.0f);
    for (int k = 0; k < 6; ++k) c.particles.push_back(test::particle({0.0f, 1.0f + 1.5f * float(k), 0.0f}, 0.5f));
    c.particles.push_back(test::particle({3.0f, 2.0f, 0.0f}, 1.0f));   // holds the next one
    c.particles.push_back(test::particle({3.0f, 2.2f, 0.0f}, 0.25f));
    for (int k = 0; k < 5; ++k) c.particles.push_back(test::particle({-3.0f, 1.0f + 0.6f * float(k), 0.1f}, 0.5f));
    c.particles.push_back(test::particle({6.0f, 0.0f, 0.0f}, 0.5f));   // centre on the ground plane
    c.particles.push_back(test::particle({8.0f, -2.0f, 0.0f}, 0.5f));  // under the ground: occluded
    c.particles.push_back(test::particle({8.0f, -1.5f, 0.0f}, 0.5f));  // on the surface of the one below
    c.ground = GroundQuad{{glm::vec3(-20, 0, -20), glm::vec3(-20, 0, 20), glm::vec3(20, 0, 20), glm::vec3(20, 0, -20)}};
    // The lowest of the column crosses 1 + 2·5 = 11 surfaces: a cutoff of 11 keeps it, 10 cuts it off.
    for (const StandInShape shape : {StandInShape{StandInKind::sphere, 0}, StandInShape{StandInKind::icosahedron, 0},
                                     StandInShape{StandInKind::icosphere, 2}}) {
        for (const DensityKernel& kernel : kKernels)
            for (const std::uint32_t cutoff : {0u, 10u, 11u, 3u})
                for (const HitSort sort : kSorts) check_against_textbook(c, shape, kernel, cutoff, sort);
        SmokeScene scene(c.particles, shape, c.ground, false);
        scene.update(c.particles, glm::vec3(0.0f, 0.0f, 100.0f));
        const auto all = test::all_of(c.particles.size());
        const auto at_11 = textbook::optical_depths(scene, c.particles, all, c.to_light, 11, kUniformKernel);
        const auto at_10 = textbook::optical_depths(scene, c.particles, all, c.to_light, 10, kUniformKernel);
        CHECK(at_11.status[0] == DepthStatus::ok);
        CHECK(at_11.hit_counts[0] == 11);
        CHECK(at_10.status[0] == DepthStatus::cutoff);
        CHECK(at_10.hit_counts[0] == 11);
        CHECK(at_11.status[c.particles.size() - 2] == DepthStatus::occluded);
    }
}

TEST_CASE("textbook optical depth: the resolver's walk is eq. 3.1 as length_in_smoke writes it",
          "[textbook][optical-depth]") {
    // Random lists of particles along a ray (some around its origin: an exit only), their crossings shuffled,
    // many t shared (multiples of 1/8). Each is sorted by every HitSort and walked by the fast resolver, and by
    // std::sort and length_in_smoke. Both sum the same gaps, each exact in double (two floats of similar size):
    // summation_order_tolerance(); the float the resolver hands out, one ulp of l more.
    Pcg32 rng(31);
    for (int list = 0; list < 2000; ++list) {
        std::vector<SurfaceHit> hits;
        const int particles = 1 + int(rng.below(150));
        const bool ties = list % 3 == 0;
        for (int p = 0; p < particles; ++p) {
            // Every exit ahead of the origin (the resolver's precondition: hits at t >= 0).
            float a = rng.uniform(-2.0f, 40.0f), b = std::max(a, 0.0f) + rng.uniform(0.01f, 3.0f);
            if (ties) a = std::round(a * 8.0f) / 8.0f, b = std::max(a, 0.0f) + 0.125f * float(1 + rng.below(20));
            if (a > 0.0f) hits.push_back({a, +1});
            hits.push_back({b, -1});
        }
        for (std::size_t i = hits.size(); i > 1; --i) std::swap(hits[i - 1], hits[rng.below(std::uint32_t(i))]);
        std::vector<textbook::Crossing> crossings;
        for (const SurfaceHit& h : hits) crossings.push_back({h.t, h.value, 0});
        std::sort(crossings.begin(), crossings.end(),
                  [](const textbook::Crossing& x, const textbook::Crossing& y) { return x.t < y.t; });
        const double want = textbook::length_in_smoke(crossings);
        CAPTURE(list, hits.size());
        for (const HitSort sort : kSorts) {
            std::vector<SurfaceHit> sorted = hits, scratch(hits.size());
            sort_hits_by_t(sorted, scratch, sort);
            CHECK(std::abs(optical_path_length(sorted) - want) <= summation_order_tolerance(want, hits.size()));
            std::vector<SurfaceHit> again = hits;
            ListResolver resolver;
            CHECK(std::abs(double(resolver(again, sort)) - want) <=
                  kFloatUlp * want + summation_order_tolerance(want, hits.size()));
        }
    }
}
