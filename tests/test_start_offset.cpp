// Where the optical-depth ray starts (optical_depth_tmin(), optical_depth_pass.hpp): tmin is a fraction of the
// particle's radius, so the pass gives the exact optical path length at every scale, for particles from 1e-13
// to 1e15 across, and each ray of a bundle keeps its own tmin. The exact answers are computed here in double:
// the union of sphere chords (support/sphere_reference.hpp) and of icosahedron chords (the float unit mesh
// placed by translate(centre)·scale(radius), clipped face by face).
#include "support/fixtures.hpp"
#include "support/sphere_reference.hpp"

#include <smoketrace/smoke/optical_depth_pass.hpp>
#include <smoketrace/smoke/optical_path_lengths.hpp>
#include <smoketrace/core/prng.hpp>
#include <smoketrace/smoke/stand_in_shapes.hpp>
#include <smoketrace/trace/trace.hpp>

#include <catch2/catch.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

using namespace smoketrace;
using namespace smoketrace::test;

namespace {

const StandInShape kSphere{StandInKind::sphere, 0};
const StandInShape kIcosahedron{StandInKind::icosahedron, 0};

struct Depths {
    std::vector<float> lengths;
    std::vector<DepthStatus> status;
    std::vector<std::uint32_t> hit_counts;
};

// The pass and the resolve (OpticalPathLengths), every particle, no cutoff.
Depths trace_all(const std::vector<Particle>& ps, StandInShape shape, glm::vec3 to_light,
                 const std::optional<GroundQuad>& ground = {}) {
    SmokeScene scene(ps, shape, ground, false);
    scene.update(ps, glm::vec3(0.0f, 0.0f, 10.0f));
    OpticalPathLengths od(ps.size());
    FrameTimings timings;
    od.update(scene, ps, all_of(ps.size()), to_light, OpticalDepthSettings{}, HitSort::adaptive, timings);
    return {od.lengths(), od.status(), od.hit_counts()};
}

// The ray o + t·d (d unit) through the icosahedron of particle p (the float unit mesh, placed exactly by
// translate(centre)·scale(radius) in double): false if it misses, else the chord [t_in, t_out] and the cosines
// between the ray and the faces it enters and leaves through.
struct Chord {
    double t_in, t_out, cos_in, cos_out;
};
std::optional<Chord> icosahedron_chord(const TriangleMesh& unit, const Particle& p, glm::dvec3 o, glm::dvec3 d) {
    Chord c{-std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(), 1.0, 1.0};
    const glm::dvec3 centre(p.center);
    for (const glm::uvec3& tri : unit.triangles) {
        // Object space (o − centre)/r: the same plane, and the same t, as the world-space ray.
        const glm::dvec3 a(unit.vertices[tri.x]), b(unit.vertices[tri.y]), e(unit.vertices[tri.z]);
        const glm::dvec3 n = glm::normalize(glm::cross(b - a, e - a));  // outward (counter-clockwise faces)
        const glm::dvec3 ob = (o - centre) / double(p.radius);
        const glm::dvec3 db = d / double(p.radius);
        const double height = glm::dot(ob - a, n);  // > 0: outside this face's plane
        const double rate = glm::dot(db, n);
        if (rate == 0.0) {
            if (height > 0.0) return std::nullopt;
            continue;
        }
        const double t = -height / rate;
        const double cosine = std::abs(glm::dot(d, n));
        if (rate < 0.0 && t > c.t_in) c = {t, c.t_out, cosine, c.cos_out};
        if (rate > 0.0 && t < c.t_out) c = {c.t_in, t, c.cos_in, cosine};
    }
    if (!(c.t_in < c.t_out)) return std::nullopt;
    return c;
}

// Per endpoint of a chord, the distance the float pass may put it from the exact one: the ray it traces in
// object space has its direction normalised in float (<= 4u), origin and direction rounded once more (u of
// |o − c| and of t each) and its t rounded (u·t), roughly 7u of (t + |o − c| + r) across the face, moved
// along the ray by 1/cos of the angle to the face's normal: 16u leaves twice that.
constexpr double kEndpointRoundings = 16.0;

// Exact length and surface count for a particle's ray through icosahedra, and the tolerance.
struct IcosahedronAnswer {
    double length = 0.0;
    double tolerance = 0.0;
    std::uint32_t surfaces = 0;
    double nearest_to_origin = std::numeric_limits<double>::infinity();  // |t| of the endpoint closest to t = 0
};
IcosahedronAnswer exact_icosahedra(const std::vector<Particle>& ps, std::size_t from, glm::dvec3 d,
                                   double t_cut = std::numeric_limits<double>::infinity()) {
    const TriangleMesh unit = make_icosahedron(1.0f);
    const glm::dvec3 o(ps[from].center);
    IcosahedronAnswer a;
    std::vector<std::pair<double, double>> chords;
    for (const Particle& p : ps) {
        const auto c = icosahedron_chord(unit, p, o, d);
        if (!c) continue;
        const double reach = glm::length(o - glm::dvec3(p.center)) + double(p.radius);
        for (const auto& [t, cosine] : {std::pair{c->t_in, c->cos_in}, std::pair{c->t_out, c->cos_out}}) {
            a.nearest_to_origin = std::min(a.nearest_to_origin, std::abs(t));
            if (t <= 0.0) continue;
            if (t < t_cut) ++a.surfaces;
            a.tolerance += kEndpointRoundings * kFloatUnit * (t + reach) / cosine;
        }
        if (c->t_out > 0.0) chords.emplace_back(c->t_in, c->t_out);
    }
    a.length = union_length(std::move(chords));
    return a;
}

// Particles in a line along d, at scale s: radii s, 0.3s, 0.45s, 0.2s, 1e-4·s, 0.35s, spaced 0.7s (the first
// three overlap, and the first contains the second's centre; the rest are separate), and one beside the line
// that no ray meets. Every endpoint is at least 0.05s from t = 0 and no ray comes near a tangency, so the
// surfaces each ray crosses are certain.
std::vector<Particle> line_of_particles(double s, glm::dvec3 d) {
    const glm::dvec3 base(0.3, -1.6, 0.2);
    const std::pair<double, double> along_radius[] = {{0.0, 1.0},  {0.7, 0.3},    {1.4, 0.45},
                                                      {2.1, 0.2},  {2.375, 1e-4}, {2.8, 0.35}};
    std::vector<Particle> ps;
    for (const auto& [along, radius] : along_radius)
        ps.push_back(particle(glm::vec3(s * (base + along * d)), float(s * radius)));
    const glm::dvec3 side = glm::normalize(glm::cross(d, glm::dvec3(0.0, 0.0, 1.0)));
    ps.push_back(particle(glm::vec3(s * (base + 1.0 * d + 2.0 * side)), float(s * 0.4)));
    return ps;
}

}  // namespace

TEST_CASE("start offset: exact lengths for particles from 1e-13 to 1e15 across", "[optical-depth][start-offset]") {
    // With the thesis's fixed tmin of 1e-7 every particle of the 1e-9 scene lost its own exit (l = 0, no hits);
    // a tmin relative to the radius gives every scale the same answer. Spheres: the tolerance is exact_spheres'
    // (sphere_reference.hpp), which grows with the scene; icosahedra: kEndpointRoundings per endpoint. Both
    // are ~1e-6 of l, while a lost own exit takes at least 0.79 of the particle's radius off l (at least
    // 7.9e-5 of l, for the tiny particle) and changes its hit count by one.
    for (const double s : {1e-9, 1e-4, 1.0, 1e6, 1e15}) {
        for (const glm::vec3 to_light : {glm::vec3(0.0f, 1.0f, 0.0f), glm::vec3(0.3f, 1.0f, -0.2f)}) {
            const glm::dvec3 d = glm::normalize(glm::dvec3(to_light));
            const std::vector<Particle> ps = line_of_particles(s, d);
            const Depths spheres = trace_all(ps, kSphere, to_light);
            const Depths icosahedra = trace_all(ps, kIcosahedron, to_light);
            for (std::size_t i = 0; i < ps.size(); ++i) {
                INFO("scale " << s << ", light (" << to_light.x << ", " << to_light.y << ", " << to_light.z
                              << "), particle " << i << " (radius " << ps[i].radius << ")");
                const SphereAnswer want = exact_spheres(ps, glm::dvec3(ps[i].center), d);
                REQUIRE(want.ambiguous == 0);
                CAPTURE(want.length, spheres.lengths[i], want.tolerance);
                CHECK(spheres.status[i] == DepthStatus::ok);
                CHECK(std::abs(double(spheres.lengths[i]) - want.length) <= want.tolerance);
                CHECK(spheres.hit_counts[i] == want.surfaces);

                const IcosahedronAnswer ico = exact_icosahedra(ps, i, d);
                REQUIRE(ico.nearest_to_origin >= 0.05 * double(ps[i].radius));  // no surface near t = 0
                CAPTURE(ico.length, icosahedra.lengths[i], ico.tolerance);
                CHECK(icosahedra.status[i] == DepthStatus::ok);
                CHECK(std::abs(double(icosahedra.lengths[i]) - ico.length) <= ico.tolerance);
                CHECK(icosahedra.hit_counts[i] == ico.surfaces);
            }
        }
    }
}

TEST_CASE("start offset: the ground occludes at every scale", "[optical-depth][start-offset]") {
    // The same lines with a horizontal ground quad (corners at ±8s) crossing the line in the gap between the
    // fourth and fifth particle (0.0375s from each along the line): the four below it and the one beside the
    // line are occluded and count exactly the surfaces in front of the ground; the two above are lit.
    for (const double s : {1e-9, 1.0, 1e15}) {
        for (const glm::vec3 to_light : {glm::vec3(0.0f, 1.0f, 0.0f), glm::vec3(0.3f, 1.0f, -0.2f)}) {
            const glm::dvec3 d = glm::normalize(glm::dvec3(to_light));
            const std::vector<Particle> ps = line_of_particles(s, d);
            const auto y = float(s * (-1.6 + 2.3375 * d.y));
            const auto h = float(8.0 * s);
            const GroundQuad ground{
                {glm::vec3(-h, y, h), glm::vec3(h, y, h), glm::vec3(h, y, -h), glm::vec3(-h, y, -h)}};
            for (const StandInShape shape : {kSphere, kIcosahedron}) {
                const Depths got = trace_all(ps, shape, to_light, ground);
                std::size_t occluded = 0;
                for (std::size_t i = 0; i < ps.size(); ++i) {
                    INFO("scale " << s << ", " << shape.name() << ", light (" << to_light.x << ", " << to_light.y
                                  << ", " << to_light.z << "), particle " << i);
                    const glm::dvec3 o(ps[i].center);
                    if (o.y > double(y)) {
                        CHECK(got.status[i] == DepthStatus::ok);
                        continue;
                    }
                    ++occluded;
                    const double t_ground = (double(y) - o.y) / d.y;
                    const std::uint32_t in_front = shape == kSphere
                                                       ? exact_spheres(ps, o, d, {.t_cut = t_ground}).surfaces
                                                       : exact_icosahedra(ps, i, d, t_ground).surfaces;
                    CHECK(got.status[i] == DepthStatus::occluded);
                    CHECK(got.hit_counts[i] == in_front);
                }
                CHECK(occluded == 5);
            }
        }
    }
}

TEST_CASE("start offset: each ray of a bundle keeps its own tmin", "[optical-depth][start-offset]") {
    // Sixteen particles of radius 1 or 16 (tmin 2^-22 ≈ 2.4e-7 or 3.8e-6), 40 apart, each with a small
    // stand-in whose surface the ray toward the light (+y) meets 1e-6 from the centre: between the two tmins.
    // All 32 rays go in one bundle. A ray from a radius-1 particle counts that surface (own exit + entry + exit
    // of the small one), a ray from a radius-16 particle does not (own exit + the small one's exit); l is
    // the same either way (the surface lies inside the own stand-in). A bundle that gave all its rays one tmin
    // would get half of them wrong.
    constexpr double kGap = 1e-6;
    const float small = 0.5f;
    for (const StandInShape shape : {kSphere, kIcosahedron}) {
        // How far below its centre the small stand-in's lowest point on the vertical line through it is: the
        // icosahedron's bottom edge midpoint (the mesh's lowest y; exact for a power-of-two radius).
        float bottom = small;
        if (shape == kIcosahedron)
            for (const glm::vec3& v : make_icosahedron(1.0f).vertices) bottom = std::min(bottom, v.y * small);
        bottom = std::abs(bottom);
        std::vector<Particle> ps;
        for (int k = 0; k < 16; ++k) {
            const float x = 40.0f * float(k) - 300.0f;
            ps.push_back(particle({x, 0.0f, 0.0f}, k % 2 == 0 ? 1.0f : 16.0f));
            ps.push_back(particle({x, float(kGap + double(bottom)), 0.0f}, small));
        }
        const glm::vec3 up(0.0f, 1.0f, 0.0f);
        const Depths got = trace_all(ps, shape, up);
        SmokeScene scene(ps, shape, std::nullopt, false);
        scene.update(ps, glm::vec3(0.0f, 0.0f, 10.0f));
        for (std::size_t i = 0; i < ps.size(); i += 2) {
            const float r = ps[i].radius;
            INFO(shape.name() << ", particle " << i << " of radius " << r << " (tmin " << optical_depth_tmin(r) << ")");
            REQUIRE(got.status[i] == DepthStatus::ok);
            CHECK(got.hit_counts[i] == (r == 1.0f ? 3u : 2u));
            // The same as the ray traced alone with the same tmin.
            std::uint32_t alone = 0;
            trace<TlasWalk::all_hits>(scene.scene(), Ray{ps[i].center, optical_depth_tmin(r), up, kOpticalDepthTmax},
                                      ray_flag_none, kLightRayMask, [&](const TraceHit&) {
                                          ++alone;
                                          return AnyHitDecision::ignore;
                                      });
            CHECK(got.hit_counts[i] == alone);
            // l: the own stand-in, and beyond it the small one where it reaches past (r = 1 only).
            const double own_top = shape == kSphere ? double(r) : double(r) * double(bottom) / double(small);
            const double small_top = double(ps[i + 1].center.y) + double(bottom);
            const double want = std::max(own_top, small_top);
            CHECK(std::abs(double(got.lengths[i]) - want) <= 16.0 * kFloatUnit * 2.0 * double(r));
        }
    }
}

TEST_CASE("start offset: bundled rays with radii over six orders of magnitude match trace() alone",
          "[optical-depth][start-offset]") {
    // Random particles whose radii span 1e-4 to 1e2 (log-uniform), so that the rays of a bundle have tmins far
    // apart: every particle's status, hit count and hits (bit for bit) must be what its own ray traced alone
    // with trace() finds.
    Pcg32 rng(5);
    std::vector<Particle> ps;
    for (int i = 0; i < 400; ++i) {
        const glm::vec3 c(rng.uniform(-4.0f, 4.0f), rng.uniform(-4.0f, 4.0f), rng.uniform(-4.0f, 4.0f));
        ps.push_back(particle(c, std::pow(10.0f, rng.uniform(-4.0f, 0.5f))));
    }
    const glm::vec3 light(0.2f, 1.0f, 0.35f);
    const glm::vec3 dir = glm::normalize(light);  // the pass's ray direction
    for (const StandInShape shape : {kSphere, kIcosahedron}) {
        SmokeScene scene(ps, shape, std::nullopt, false);
        scene.update(ps, glm::vec3(0.0f, 0.0f, 10.0f));
        OpticalDepthPass pass;
        OpticalDepthHits out;
        pass.run(scene, ps, all_of(ps.size()), light, OpticalDepthSettings{}, out);
        for (std::size_t i = 0; i < ps.size(); ++i) {
            // (t's bits, facing) of every hit, sorted: the order any-hit sees them in is not fixed.
            std::vector<std::pair<std::uint32_t, int>> alone, bundled;
            const Ray ray{ps[i].center, optical_depth_tmin(ps[i].radius), dir, kOpticalDepthTmax};
            trace<TlasWalk::all_hits>(scene.scene(), ray, ray_flag_none, kLightRayMask, [&](const TraceHit& h) {
                alone.emplace_back(std::bit_cast<std::uint32_t>(h.t), h.front_face() ? 1 : -1);
                return AnyHitDecision::ignore;
            });
            for (const SurfaceHit& h : out.lists.of(i))
                bundled.emplace_back(std::bit_cast<std::uint32_t>(h.t), h.value);
            std::sort(alone.begin(), alone.end());
            std::sort(bundled.begin(), bundled.end());
            INFO(shape.name() << ", particle " << i);
            REQUIRE(out.status[i] == DepthStatus::ok);
            CHECK(bundled == alone);
        }
    }
}
