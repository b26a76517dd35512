// The optical-depth pass (thesis 4.3.2) + resolve (4.3.3) against Embree 3 doing the same job independently:
// for each particle a ray from its centre toward the light (tmin 2^-22·radius) collects every stand-in crossing
// through an intersection filter that rejects every candidate (so Embree's traversal goes on), Embree's
// duplicate reports at shared edges and vertices are removed, the ground (an opaque quad) occludes, and the
// eq. 3.1 walk is done here in double. Statuses follow optical_depth_pass.hpp: occluded if the ground lies
// on the ray; else cutoff if more than K surfaces; else ok.
//
// Tolerance on lengths, 1e-4 relative (kLengthTolerance): both tracers intersect the same float triangles
// (make_icosahedron / make_icosphere, placed by translate(centre)·scale(radius)) up to one rounding of each
// vertex and of the ray: smoketrace maps the ray into object space in double and rounds it to float,
// Embree's flattened mesh has its world vertices computed in double and rounded to float. A hit distance
// therefore differs by a few float ulps of the scene's coordinates (≤ ~10 here): ~1e-6. Only the hits
// where the ray enters or leaves smoke enter l (a handful per ray), and l is at least the distance from the
// centre to the particle's own surface (≥ the inradius, 0.79·r for the icosahedron), so the expected
// disagreement is ~1e-5 relative at worst (measured: under 7e-6 on every scene here): 1e-4 leaves a margin,
// and a surface counted twice or missed (the defects these tests are for) changes l by a chord, ~0.1–1, or
// the hit count by one.
#include "support/fixtures.hpp"
#include "support/embree_reference.hpp"

#include <smoketrace/smoke/density_kernel.hpp>
#include <smoketrace/smoke/optical_depth_pass.hpp>
#include <smoketrace/smoke/optical_path_lengths.hpp>
#include <smoketrace/core/prng.hpp>
#include <smoketrace/smoke/stand_in_shapes.hpp>
#include <smoketrace/smoke/tube_generator.hpp>
#include <smoketrace/trace/trace.hpp>

#include <catch2/catch.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <numeric>
#include <optional>
#include <vector>

using namespace smoketrace;
using namespace smoketrace::test;
namespace er = smoketrace::embree_reference;

namespace {

// The thesis's optical-depth ray (4.3.2), restated here rather than taken from the code under test; its
// TMin is the pass's rule, optical_depth_tmin() of the particle's radius (the one rule the pass, this
// reference, the sphere reference and the benchmark share).
constexpr float kTmax = 1e38f;
static_assert(kTmax == kOpticalDepthTmax, "the pass's ray changed: update the test");

// See the file comment.
constexpr double kLengthTolerance = 1e-4;
// Embree (robust mode) reports a ray through a shared edge on both triangles and through a vertex on
// several, each t computed from its own triangle's plane: the copies agree to a few ulps. Two same-facing
// crossings of one convex stand-in closer than this (relative to max(t, the ray's particle's radius), the
// scale of the scene around the ray) are one crossing.
constexpr double kDuplicateT = 1e-5;

enum class Layout { flattened, instanced };

const char* name(Layout l) { return l == Layout::flattened ? "flattened" : "instanced"; }

TriangleMesh unit_mesh(StandInShape shape) {
    return shape.kind == StandInKind::icosahedron ? make_icosahedron(1.0f) : make_icosphere(shape.level, 1.0f);
}

// Every particle's stand-in in one Embree scene, with the ground, and a map from Embree's ids to particles.
class EmbreeStandIns {
public:
    EmbreeStandIns(const er::Device& device, const std::vector<Particle>& ps, StandInShape shape,
                   const std::optional<GroundQuad>& ground, Layout layout)
        : top_(device) {
        const TriangleMesh unit = unit_mesh(shape);
        triangles_per_particle_ = static_cast<std::uint32_t>(unit.triangles.size());
        if (ground) ground_geometry_ = top_.attach_mesh(er::quad_mesh(*ground));
        if (layout == Layout::flattened) {
            top_.attach_mesh(er::flattened_stand_ins(ps, unit));
        } else {
            child_ = std::make_unique<er::Scene>(device);
            child_->attach_mesh(unit);
            child_->commit();
            for (std::size_t i = 0; i < ps.size(); ++i) {
                RTCGeometry g = rtcNewGeometry(device.handle(), RTC_GEOMETRY_TYPE_INSTANCE);
                rtcSetGeometryInstancedScene(g, child_->handle());
                const Particle& p = ps[i];
                const float r = p.radius;
                const float xfm[12] = {r, 0, 0, 0, r, 0, 0, 0, r, p.center.x, p.center.y, p.center.z};
                rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, xfm);
                rtcCommitGeometry(g);
                const std::uint32_t id = rtcAttachGeometry(top_.handle(), g);
                rtcReleaseGeometry(g);
                if (i == 0) first_instance_ = id;
                if (id != first_instance_ + i) throw std::logic_error("embree: instance ids not consecutive");
            }
            device.check("instances");
        }
        top_.commit();
    }

    [[nodiscard]] const er::Scene& scene() const { return top_; }
    [[nodiscard]] bool is_ground(const er::EmbreeHit& h) const {
        return h.instance == RTC_INVALID_GEOMETRY_ID && h.geometry == ground_geometry_;
    }
    [[nodiscard]] std::uint32_t particle_of(const er::EmbreeHit& h) const {
        if (h.instance != RTC_INVALID_GEOMETRY_ID) return h.instance - first_instance_;
        return h.primitive / triangles_per_particle_;
    }

private:
    er::Scene top_;
    std::unique_ptr<er::Scene> child_;
    std::uint32_t triangles_per_particle_ = 0;
    std::uint32_t ground_geometry_ = RTC_INVALID_GEOMETRY_ID;
    std::uint32_t first_instance_ = 0;
};

struct Reference {
    DepthStatus status = DepthStatus::ok;
    std::uint32_t hits = 0;
    double length = 0.0;  // ok only
    std::vector<std::uint32_t> exits;  // ok only: the particles whose stand-ins the ray leaves, ascending
};

struct Tally {
    std::size_t ok = 0, occluded = 0, cutoff = 0;
    std::size_t duplicates = 0;  // Embree reports removed as shared-edge / vertex copies
    std::size_t anomalies = 0;   // same-facing crossings of one convex stand-in that are NOT copies
};

struct Crossing {
    std::uint32_t particle;
    bool front;
    double t;
};

// The reference answer of one particle, from Embree's reports.
Reference embree_reference(const EmbreeStandIns& s, const Particle& p, glm::vec3 dir, std::uint32_t cutoff,
                           Tally& tally) {
    std::vector<Crossing> found;
    double ground_t = std::numeric_limits<double>::infinity();
    s.scene().all_hits(Ray{p.center, optical_depth_tmin(p.radius), dir, kTmax}, [&](const er::EmbreeHit& h) {
        if (s.is_ground(h)) ground_t = std::min(ground_t, double(h.t));
        else found.push_back({s.particle_of(h), h.front_face, double(h.t)});
    });
    // Duplicates: a convex stand-in is entered at most once and left at most once.
    std::sort(found.begin(), found.end(), [](const Crossing& a, const Crossing& b) {
        return a.particle != b.particle ? a.particle < b.particle : a.front != b.front ? a.front < b.front : a.t < b.t;
    });
    std::vector<Crossing> unique;
    for (const Crossing& c : found) {
        if (!unique.empty() && unique.back().particle == c.particle && unique.back().front == c.front) {
            if (std::abs(c.t - unique.back().t) <= kDuplicateT * std::max(double(p.radius), c.t)) {
                ++tally.duplicates;
                continue;
            }
            ++tally.anomalies;
        }
        unique.push_back(c);
    }

    Reference r;
    if (ground_t < std::numeric_limits<double>::infinity()) {
        r.status = DepthStatus::occluded;
        r.hits = static_cast<std::uint32_t>(
            std::count_if(unique.begin(), unique.end(), [&](const Crossing& c) { return c.t < ground_t; }));
        ++tally.occluded;
        return r;
    }
    r.hits = static_cast<std::uint32_t>(unique.size());
    if (cutoff != 0 && r.hits > cutoff) {
        r.status = DepthStatus::cutoff;
        r.hits = cutoff + 1;
        ++tally.cutoff;
        return r;
    }
    for (const Crossing& c : unique)
        if (!c.front) r.exits.push_back(c.particle);  // sorted by particle above
    // Eq. 3.1 and the walk, in double: the counter starts at minus the sum of the hit values (the number of
    // stand-ins covering the origin) and the ray is in smoke while it is positive.
    std::sort(unique.begin(), unique.end(), [](const Crossing& a, const Crossing& b) { return a.t < b.t; });
    int counter = 0;
    for (const Crossing& c : unique) counter -= c.front ? 1 : -1;
    double previous = 0.0;
    for (const Crossing& c : unique) {
        if (counter > 0) r.length += c.t - previous;
        counter += c.front ? 1 : -1;
        if (counter < 0) ++tally.anomalies;  // left more stand-ins than were entered: a facing error
        previous = c.t;
    }
    ++tally.ok;
    return r;
}

// The particles whose stand-ins our ray alone (trace()) leaves, ascending: the hit set the pass sums over.
std::vector<std::uint32_t> our_exits(const SmokeScene& scene, const Particle& p, glm::vec3 dir) {
    std::vector<std::uint32_t> exits;
    const Ray ray{p.center, optical_depth_tmin(p.radius), dir, kTmax};
    (void)trace<TlasWalk::all_hits>(scene.scene(), ray, ray_flag_none, kLightRayMask, [&](const TraceHit& h) {
        if (!h.front_face()) exits.push_back(h.instance_id);
        return AnyHitDecision::ignore;
    });
    std::sort(exits.begin(), exits.end());
    return exits;
}

// Runs the pass (through OpticalPathLengths: pass + resolve) and the Embree reference on every particle and
// requires identical statuses and hit counts and lengths within kLengthTolerance. With a smooth `kernel` the
// reference's l is the sum of the kernel's closed-form shares (density_kernel.hpp) over the particles Embree
// saw the ray leave, which must be the particles our ray leaves; both sums add the same shares in their own
// order and round to float: they agree to (2^-23 + n·2^-53)·l, n the exits.
Tally compare_with_embree(const std::vector<Particle>& ps, StandInShape shape, const std::optional<GroundQuad>& ground,
                          glm::vec3 to_light, std::uint32_t cutoff, Layout layout, const DensityKernel& kernel = {}) {
    static const er::Device device;
    const EmbreeStandIns embree(device, ps, shape, ground, layout);
    const glm::vec3 dir(glm::normalize(glm::dvec3(to_light)));

    SmokeScene scene(ps, shape, ground, false);
    scene.update(ps, glm::vec3(0.0f, 0.0f, 10.0f));
    OpticalPathLengths od(ps.size());
    std::vector<std::uint32_t> all(ps.size());
    std::iota(all.begin(), all.end(), 0u);
    FrameTimings timings;
    OpticalDepthSettings settings{cutoff};
    settings.kernel = kernel;
    od.update(scene, ps, all, to_light, settings, HitSort::adaptive, timings);
    // The shares along the direction the pass traces with: to_light normalised in float, then in double
    // (optical_depth_pass.cpp); Embree's rays take the double normalisation rounded once, an ulp apart at most.
    const glm::dvec3 unit_dir = glm::normalize(glm::dvec3(glm::normalize(to_light)));

    Tally tally;
    std::size_t mismatches = 0;
    double worst = 0.0;  // largest relative length difference among ok particles
    for (std::size_t i = 0; i < ps.size(); ++i) {
        Reference want = embree_reference(embree, ps[i], dir, cutoff, tally);
        double tolerance = kLengthTolerance * want.length;
        if (kernel.smooth() && want.status == DepthStatus::ok) {
            const std::vector<std::uint32_t> ours = our_exits(scene, ps[i], dir);
            if (ours != want.exits && ++mismatches <= 10)
                UNSCOPED_INFO("particle " << i << ": Embree's ray leaves " << want.exits.size()
                                          << " stand-ins, ours " << ours.size() << " (or others)");
            want.length = 0.0;
            for (const std::uint32_t j : want.exits)
                want.length += particle_stretch_integral(kernel, ps[i].center, unit_dir, ps[j].center, ps[j].radius);
            tolerance = (0x1p-23 + double(want.exits.size()) * 0x1p-53) * want.length;
        }
        const DepthStatus got_status = od.status()[i];
        const std::uint32_t got_hits = od.hit_counts()[i];
        const float got_length = od.lengths()[i];
        const bool ok = got_status == want.status && got_hits == want.hits &&
                        (want.status == DepthStatus::ok
                             ? std::abs(double(got_length) - want.length) <= tolerance
                             : got_length == std::numeric_limits<float>::infinity());
        if (want.status == DepthStatus::ok && got_status == DepthStatus::ok)
            worst = std::max(worst, std::abs(double(got_length) - want.length) / want.length);
        if (!ok && ++mismatches <= 10) {
            UNSCOPED_INFO("particle " << i << " at (" << ps[i].center.x << ", " << ps[i].center.y << ", "
                                      << ps[i].center.z << ") r " << ps[i].radius << ": embree status "
                                      << int(want.status) << " hits " << want.hits << " l " << want.length
                                      << "; smoketrace status " << int(got_status) << " hits " << got_hits << " l "
                                      << got_length);
        }
    }
    INFO(shape.name() << ", " << name(layout) << ", cutoff " << cutoff << ", kernel " << kernel.name() << ": "
                      << ps.size() << " particles, "
                      << tally.ok << " ok, " << tally.occluded << " occluded, " << tally.cutoff << " cut off, "
                      << tally.duplicates << " Embree duplicates removed, largest relative length difference "
                      << worst);
    CHECK(mismatches == 0);
    CHECK(tally.anomalies == 0);  // the reference itself is consistent
    return tally;
}

const StandInShape kIcosahedron{StandInKind::icosahedron, 0};
const StandInShape kIcosphere1{StandInKind::icosphere, 1};
const StandInShape kIcosphere2{StandInKind::icosphere, 2};

}  // namespace

TEST_CASE("Embree: two-tube scene, light from above, icosahedron stand-ins (own exits through edge midpoints)",
          "[embree][optical-depth]") {
    // Light straight up: each particle's ray leaves its own icosahedron exactly through the midpoint of the
    // edge (−1, φ, 0)–(1, φ, 0): the shared-edge rule is exercised once per particle, on top of the other
    // particles' crossings. A duplicate shows up as one hit too many (or, for the own exit, a counter
    // started one too low), a leak as one too few.
    const auto ps = generate_tubes(TubeSettings{});
    for (Layout layout : {Layout::flattened, Layout::instanced}) {
        const Tally t = compare_with_embree(ps, kIcosahedron, std::nullopt, {0.0f, 1.0f, 0.0f}, 0, layout);
        CHECK(t.ok == ps.size());
        // Embree itself reported edge crossings twice: the scene really hits shared edges.
        CHECK(t.duplicates >= ps.size() / 2);
    }
    // With the thesis's lowest cutoff (4.4.3), which the rays through both tubes exceed.
    const Tally t = compare_with_embree(ps, kIcosahedron, std::nullopt, {0.0f, 1.0f, 0.0f}, 20, Layout::flattened);
    CHECK(t.cutoff > 50);
    CHECK(t.ok > 50);
}

TEST_CASE("Embree: two-tube scene, icosphere stand-ins (own exits through a vertex)", "[embree][optical-depth]") {
    // Subdivided icospheres have a vertex at (0, 1, 0): each particle's own exit passes exactly through it.
    const auto ps = generate_tubes(TubeSettings{});
    for (StandInShape shape : {kIcosphere1, kIcosphere2}) {
        const Tally t = compare_with_embree(ps, shape, std::nullopt, {0.0f, 1.0f, 0.0f}, 0, Layout::flattened);
        CHECK(t.ok == ps.size());
        CHECK(t.duplicates >= ps.size());  // several triangles of the vertex fan report it
    }
    compare_with_embree(ps, kIcosphere1, std::nullopt, {1.0f, 0.35f, -0.2f}, 60, Layout::instanced);
}

TEST_CASE("Embree: dense cluster, every ray starts inside many stand-ins", "[embree][optical-depth]") {
    Pcg32 rng(11);
    std::vector<Particle> ps;
    while (ps.size() < 200) {
        const glm::vec3 c(rng.uniform(-0.6f, 0.6f), rng.uniform(-0.6f, 0.6f), rng.uniform(-0.6f, 0.6f));
        if (glm::dot(c, c) <= 0.36f) ps.push_back(particle(c, rng.uniform(0.5f, 1.0f)));
    }
    for (StandInShape shape : {kIcosahedron, kIcosphere1}) {
        const Tally t = compare_with_embree(ps, shape, std::nullopt, {0.3f, 1.0f, -0.2f}, 0, Layout::flattened);
        CHECK(t.ok == ps.size());
    }
    // Light straight up through the cluster as well (exits through edge midpoints, as in the tube test).
    compare_with_embree(ps, kIcosahedron, std::nullopt, {0.0f, 1.0f, 0.0f}, 0, Layout::instanced);
}

TEST_CASE("Embree: particles in a line along the light direction", "[embree][optical-depth]") {
    // Overlapping (spacing 0.3 < radius 0.4) and separate (spacing 1) lines along +y: every ray runs through
    // the centres of the particles above it, entering and leaving each exactly through edge midpoints
    // (icosahedron) or vertices (icosphere).
    for (float spacing : {0.3f, 1.0f}) {
        std::vector<Particle> ps;
        for (int i = 0; i < 24; ++i) ps.push_back(particle({0.25f, -3.0f + spacing * float(i), -0.5f}, 0.4f));
        for (StandInShape shape : {kIcosahedron, kIcosphere1}) {
            INFO("spacing " << spacing);
            const Tally t = compare_with_embree(ps, shape, std::nullopt, {0.0f, 1.0f, 0.0f}, 0, Layout::flattened);
            CHECK(t.ok == ps.size());
            compare_with_embree(ps, shape, std::nullopt, {0.0f, 1.0f, 0.0f}, 0, Layout::instanced);
        }
    }
}

TEST_CASE("Embree: random scenes with the ground occluding some particles", "[embree][optical-depth]") {
    // Particles in a box; a ground quad hung across part of it (y = 0.3, x, z in [−2, 2]); light from above
    // and to the side: particles under the quad are occluded, others lit through smoke, some cut off.
    const GroundQuad ground{{glm::vec3(-2.0f, 0.3f, 2.0f), glm::vec3(2.0f, 0.3f, 2.0f), glm::vec3(2.0f, 0.3f, -2.0f),
                             glm::vec3(-2.0f, 0.3f, -2.0f)}};
    for (std::uint64_t seed : {1u, 2u, 3u}) {
        Pcg32 rng(seed, 99);
        std::vector<Particle> ps;
        for (int i = 0; i < 400; ++i)
            ps.push_back(particle({rng.uniform(-3.0f, 3.0f), rng.uniform(-2.0f, 2.0f), rng.uniform(-3.0f, 3.0f)},
                                  rng.uniform(0.2f, 0.6f)));
        const glm::vec3 light(rng.uniform(-0.5f, 0.5f), 1.0f, rng.uniform(-0.5f, 0.5f));
        INFO("seed " << seed);
        for (StandInShape shape : {kIcosahedron, kIcosphere1}) {
            const Tally t = compare_with_embree(ps, shape, ground, light, 0, Layout::flattened);
            CHECK(t.occluded > 40);
            CHECK(t.ok > 40);
            const Tally c = compare_with_embree(ps, shape, ground, light, 6, Layout::instanced);
            CHECK(c.cutoff > 10);
            CHECK(c.occluded == t.occluded);  // occlusion does not depend on the cutoff
        }
    }
}

TEST_CASE("Embree: particles in a line, scaled from 1e-9 to 1e12", "[embree][optical-depth]") {
    // The line test's overlapping line, scaled by s: the ray's tmin is relative to the radius
    // (optical_depth_tmin()), so every scale agrees with Embree, statuses, hit counts and lengths alike (at
    // s = 1e-9 a fixed tmin of 1e-7 lost every particle's own exit). Not beyond 1e12: there Embree itself
    // loses the crossings (no hits at all at 1e13 flattened, 1e14 instanced; its float triangle test
    // multiplies three coordinates); test_start_offset.cpp checks up to 1e15 against exact chords.
    for (const double s : {1e-9, 1e-3, 1e12}) {
        std::vector<Particle> ps;
        for (int i = 0; i < 24; ++i)
            ps.push_back(particle(glm::vec3(s * glm::dvec3(0.25, -3.0 + 0.3 * i, -0.5)), float(0.4 * s)));
        INFO("scale " << s);
        for (const glm::vec3 light : {glm::vec3(0.0f, 1.0f, 0.0f), glm::vec3(0.1f, 1.0f, -0.05f)}) {
            for (const Layout layout : {Layout::flattened, Layout::instanced}) {
                const Tally t = compare_with_embree(ps, kIcosahedron, std::nullopt, light, 0, layout);
                CHECK(t.ok == ps.size());
            }
        }
    }
}

TEST_CASE("Embree: the smooth kernels sum the same shares over the stand-ins Embree sees the rays leave",
          "[embree][optical-depth][kernel]") {
    // The scenes above once more under each smooth kernel: the same statuses and counts as Embree's, the same
    // particles left (our trace() against Embree's unique exits), and each l the sum of their shares.
    const auto tubes = generate_tubes(TubeSettings{});
    const GroundQuad ground{{glm::vec3(-2.0f, 0.3f, 2.0f), glm::vec3(2.0f, 0.3f, 2.0f), glm::vec3(2.0f, 0.3f, -2.0f),
                             glm::vec3(-2.0f, 0.3f, -2.0f)}};
    Pcg32 rng(3, 99);
    std::vector<Particle> box;
    for (int i = 0; i < 400; ++i)
        box.push_back(particle({rng.uniform(-3.0f, 3.0f), rng.uniform(-2.0f, 2.0f), rng.uniform(-3.0f, 3.0f)},
                               rng.uniform(0.2f, 0.6f)));
    std::vector<Particle> tiny;
    for (int i = 0; i < 24; ++i)
        tiny.push_back(particle(glm::vec3(1e-9 * glm::dvec3(0.25, -3.0 + 0.3 * i, -0.5)), float(0.4e-9)));
    for (const DensityKernel& kernel : {kGaussianKernel, kPoly1Kernel, kPoly2Kernel}) {
        for (const Layout layout : {Layout::flattened, Layout::instanced}) {
            const Tally t = compare_with_embree(tubes, kIcosahedron, std::nullopt, {0.0f, 1.0f, 0.0f}, 0, layout, kernel);
            CHECK(t.ok == tubes.size());
        }
        const Tally c = compare_with_embree(tubes, kIcosphere1, std::nullopt, {1.0f, 0.35f, -0.2f}, 20,
                                            Layout::instanced, kernel);
        CHECK(c.cutoff > 10);
        const Tally g = compare_with_embree(box, kIcosahedron, ground, {0.3f, 1.0f, -0.2f}, 6, Layout::flattened, kernel);
        CHECK(g.occluded > 40);
        CHECK(g.ok > 40);
        CHECK(compare_with_embree(tiny, kIcosahedron, std::nullopt, {0.1f, 1.0f, -0.05f}, 0, Layout::instanced, kernel)
                  .ok == tiny.size());
    }
}
