// Numerical stress suite (issue 7). One TEST_CASE per case of the issue; each states its invariant and
// where its tolerance comes from. Reference answers are computed here in double precision from the float
// scene the tracer actually sees, independently of the code under test:
//  * spheres: the union over spheres of [max(t0, 0), t1] along the ray, t0/t1 the exact roots;
//  * icosahedra / icospheres: the exact chord of the ray through each convex polyhedron (its face planes in
//    double, from the mesh's float vertices placed by the same double transform c + r·v);
//  * the eq. 3.1 counter: counter_start = −Σ values must equal the number of stand-ins that really contain
//    the ray origin and the walk must never see it below 0; and the hits must pair up one to one with the
//    surfaces the exact geometry puts on the ray, [exit] for a stand-in covering the origin and [entry, exit]
//    for one ahead, each hit's t within the tolerance of its surface: a leak (a missed surface), a duplicate
//    (a surface reported twice) or a face of the wrong sign breaks one of them.
// Measured numbers (error growth far from the origin, scale invariance) are printed with WARN, and copied into
// docs/accuracy.md ("The stress suite").
#include "support/fixtures.hpp"
#include "support/sphere_reference.hpp"

#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/smoke/hit_resolver.hpp>
#include <smoketrace/smoke/optical_depth_pass.hpp>
#include <smoketrace/core/prng.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/smoke/stand_in_shapes.hpp>
#include <smoketrace/io/sixway_files.hpp>

#include <catch2/catch.hpp>
#include <tbb/global_control.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <functional>
#include <iomanip>
#include <limits>
#include <numeric>
#include <optional>
#include <span>
#include <sstream>
#include <string>
#include <vector>

using namespace smoketrace;
using namespace smoketrace::test;

namespace {

constexpr double kInfD = std::numeric_limits<double>::infinity();

const StandInShape kSphere{StandInKind::sphere, 0};
const StandInShape kIcosahedron{StandInKind::icosahedron, 0};
StandInShape icosphere(int level) { return {StandInKind::icosphere, level}; }

// The optical-depth pass and the resolver, keeping each particle's hits (sorted by t) for the counter checks.
struct Traced {
    std::vector<float> lengths;
    std::vector<DepthStatus> status;
    std::vector<std::uint32_t> hit_counts;
    HitLists lists;
};

Traced trace_all(const std::vector<Particle>& ps, StandInShape shape, glm::vec3 to_light,
                 const std::optional<GroundQuad>& ground = {}, std::uint32_t cutoff = 0) {
    SmokeScene scene(ps, shape, ground, false);
    scene.update(ps, glm::vec3(0.0f, 0.0f, 10.0f));
    OpticalDepthPass pass;
    OpticalDepthHits hits;
    OpticalDepthSettings settings;
    settings.cutoff = cutoff;
    pass.run(scene, ps, all_of(ps.size()), to_light, settings, hits);
    Traced t;
    t.status = hits.status;
    t.hit_counts = hits.hit_counts;
    t.lists = std::move(hits.lists);
    t.lengths.resize(ps.size());
    resolve_optical_path_lengths(t.lists, t.status, t.lengths, HitSort::adaptive);  // also sorts each list
    return t;
}

// Eq. 3.1's counter over one sorted hit list, applied a group of equal t at a time (as the resolver does).
// (It ends at 0 by construction: it starts at −Σ values and adds them all back.)
struct Walk {
    int start = 0;   // −Σ values: stand-ins covering the origin
    int lowest = 0;  // lowest value between groups
};

Walk walk(std::span<const SurfaceHit> hits) {
    Walk w;
    for (const SurfaceHit& h : hits) w.start -= h.value;
    int counter = w.start;
    w.lowest = counter;
    for (std::size_t i = 0; i < hits.size();) {
        const float t = hits[i].t;
        while (i < hits.size() && hits[i].t == t) counter += hits[i++].value;
        w.lowest = std::min(w.lowest, counter);
    }
    return w;
}

// A particle surface the exact geometry puts on a ray: the tracer must report a hit of this sign (+1 entry,
// −1 exit) with t in [lo, hi]. Each stand-in the ray crosses gives [exit] (it covers the origin) or
// [entry, exit].
struct Surface {
    double lo, hi;
    std::int32_t value;
};

void add_chord(std::vector<Surface>& surfaces, double t_in, double t_out, double tolerance) {
    if (t_in > 0.0) surfaces.push_back({t_in - tolerance, t_in + tolerance, +1});
    surfaces.push_back({t_out - tolerance, t_out + tolerance, -1});
}

// "" when the hits and the surfaces pair up one to one: every hit is one of the surfaces (same sign, t inside
// its bracket) and every surface is hit once; else what went wrong. Per sign, each hit in order of t takes the
// open bracket that closes first, which finds a pairing whenever there is one (a bracket that closes before
// the next hit is a surface nobody can have reported).
std::string pairing_problem(std::span<const SurfaceHit> sorted_hits, std::vector<Surface> surfaces) {
    std::sort(surfaces.begin(), surfaces.end(), [](const Surface& a, const Surface& b) { return a.lo < b.lo; });
    std::ostringstream why;
    for (const std::int32_t value : {+1, -1}) {
        const char* what = value > 0 ? "entry" : "exit";
        std::vector<double> open;  // hi of the brackets opened and not yet taken (a min-heap)
        const auto closes_first = std::greater<double>();
        std::size_t next = 0;
        for (const SurfaceHit& h : sorted_hits) {
            if (h.value != value) continue;
            for (; next < surfaces.size() && surfaces[next].lo <= h.t; ++next) {
                if (surfaces[next].value != value) continue;
                open.push_back(surfaces[next].hi);
                std::push_heap(open.begin(), open.end(), closes_first);
            }
            if (!open.empty() && open.front() < h.t) {
                why << "the " << what << " surface closing at t = " << open.front() << " has no hit";
                return why.str();
            }
            if (open.empty()) {
                why << "the " << what << " hit at t = " << h.t << " is no surface";
                return why.str();
            }
            std::pop_heap(open.begin(), open.end(), closes_first);
            open.pop_back();
        }
        for (; next < surfaces.size(); ++next)
            if (surfaces[next].value == value) open.push_back(surfaces[next].hi);
        if (!open.empty()) {
            why << open.size() << " " << what << " surface(s) without a hit";
            return why.str();
        }
    }
    return "";
}

// ---- Spheres: the exact answer and its tolerance are support/sphere_reference.hpp --------------------------

// Checks every particle's length against exact_spheres and its counter; returns the largest error seen.
struct Errors {
    double max_abs = 0.0;
    double max_tolerance = 0.0;
    std::size_t paired = 0;  // rays whose hits were paired with the exact surfaces (no ambiguous surface)
};

// The surfaces of the spheres on the ray o + t·d (d unit), t > 0, each within ±tolerance.
std::vector<Surface> sphere_surfaces(const std::vector<Particle>& ps, glm::dvec3 o, glm::dvec3 d, double tolerance) {
    std::vector<Surface> surfaces;
    for (const Particle& p : ps) {
        const glm::dvec3 f = o - glm::dvec3(p.center);
        const double mid = -glm::dot(f, d), r = p.radius;
        const glm::dvec3 perp = f + mid * d;
        const double s2 = r * r - glm::dot(perp, perp);
        if (s2 <= 0.0 || mid + std::sqrt(s2) <= 0.0) continue;
        add_chord(surfaces, mid - std::sqrt(s2), mid + std::sqrt(s2), tolerance);
    }
    return surfaces;
}

Errors check_spheres(const std::vector<Particle>& ps, const Traced& got, glm::vec3 to_light,
                     const std::vector<Particle>* reference = nullptr, double displacement = 0.0) {
    const std::vector<Particle>& ref_ps = reference ? *reference : ps;
    Errors e;
    for (std::size_t i = 0; i < ps.size(); ++i) {
        const SphereAnswer want = exact_spheres(ref_ps, glm::dvec3(ref_ps[i].center), glm::dvec3(to_light), {.displacement = displacement});
        const double err = std::abs(double(got.lengths[i]) - want.length);
        INFO("particle " << i << ": exact " << want.length << ", got " << got.lengths[i] << ", tolerance "
                         << want.tolerance << "; surfaces " << want.surfaces << " (+" << want.ambiguous
                         << " ambiguous), got " << got.hit_counts[i]);
        REQUIRE(got.status[i] == DepthStatus::ok);
        REQUIRE(err <= want.tolerance);
        if (!reference) {
            REQUIRE(got.hit_counts[i] >= want.surfaces);
            REQUIRE(got.hit_counts[i] <= want.surfaces + want.ambiguous);
            const Walk w = walk(got.lists.of(i));
            REQUIRE(w.start >= want.covering);
            REQUIRE(w.start <= want.covering + want.covering_ambiguous);
            REQUIRE(w.lowest >= 0);
            // With no surface near a tangent or the origin the set of surfaces is certain. Each endpoint's
            // error is one term of want.tolerance, so the whole of it bounds every one.
            if (want.ambiguous == 0 && want.covering_ambiguous == 0) {
                const glm::dvec3 d = glm::normalize(glm::dvec3(to_light));
                const std::string problem =
                    pairing_problem(got.lists.of(i), sphere_surfaces(ps, glm::dvec3(ps[i].center), d, want.tolerance));
                INFO(problem);
                REQUIRE(problem.empty());
                ++e.paired;
            }
        }
        e.max_abs = std::max(e.max_abs, err);
        e.max_tolerance = std::max(e.max_tolerance, want.tolerance);
    }
    // Most rays have no ambiguous surface (108 of 120 in the near-tangent scene, all in the others): the
    // pairing is not being skipped wholesale.
    if (!reference) CHECK(2 * e.paired >= ps.size());
    return e;
}

// ---- Convex polyhedra (icosahedron, icospheres) in double ----------------------------------------------------

struct Plane {
    glm::dvec3 n;  // outward, not normalised
    double d;      // inside: n·x <= d
};

TriangleMesh mesh_of(StandInShape shape) {
    return shape.kind == StandInKind::icosahedron ? make_icosahedron(1.0f) : make_icosphere(shape.level, 1.0f);
}

// The stand-in of `p` in world space: object vertex v goes to c + r·v in double, as the instance transform.
std::vector<Plane> planes_of(const TriangleMesh& mesh, const Particle& p) {
    std::vector<Plane> planes;
    const glm::dvec3 c(p.center);
    const double r = p.radius;
    for (const glm::uvec3& tri : mesh.triangles) {
        const glm::dvec3 v0 = c + r * glm::dvec3(mesh.vertices[tri.x]);
        const glm::dvec3 v1 = c + r * glm::dvec3(mesh.vertices[tri.y]);
        const glm::dvec3 v2 = c + r * glm::dvec3(mesh.vertices[tri.z]);
        const glm::dvec3 n = glm::cross(v1 - v0, v2 - v0);
        planes.push_back({n, glm::dot(n, v0)});
    }
    return planes;
}

// The chord [t_in, t_out] of the whole line o + t·d through the convex body; false if it misses.
bool convex_chord(const std::vector<Plane>& planes, glm::dvec3 o, glm::dvec3 d, double& t_in, double& t_out) {
    t_in = -kInfD;
    t_out = kInfD;
    for (const Plane& f : planes) {
        const double denom = glm::dot(f.n, d), num = f.d - glm::dot(f.n, o);
        if (denom == 0.0) {
            if (num < 0.0) return false;
            continue;
        }
        const double t = num / denom;
        if (denom > 0.0) t_out = std::min(t_out, t);
        else t_in = std::max(t_in, t);
    }
    return t_in < t_out;
}

// Signed distance of x inside the body (> 0 inside, < 0 outside).
double inside_margin(const std::vector<Plane>& planes, glm::dvec3 x) {
    double m = kInfD;
    for (const Plane& f : planes) m = std::min(m, (f.d - glm::dot(f.n, x)) / glm::length(f.n));
    return m;
}

// The surfaces of convex bodies on the ray o + t·d (d unit), t > 0. The tracer's ray is the exact one moved by
// rounding (its object-space origin and direction: ~16u·(|o − c| + r) <= 4e-6 here), i.e. it sees each body
// moved by less than `eps` = 1e-5: between the body shrunk and grown by eps, so each of its hits lies between
// the two chords' endpoints, give or take the rounding of t (kRoundingsPerRay·u·t). False when that leaves a
// body's surfaces uncertain: crossed when grown but not when shrunk (a graze), or an endpoint's bracket
// reaching t <= tmin (the ray's own, optical_depth_tmin() of its particle's radius).
bool convex_surfaces(const std::vector<std::vector<Plane>>& bodies, glm::dvec3 o, glm::dvec3 d, double tmin,
                     std::vector<Surface>& surfaces) {
    constexpr double eps = 1e-5;
    auto moved = [](std::vector<Plane> body, double by) {
        for (Plane& f : body) f.d += by * glm::length(f.n);
        return body;
    };
    for (const auto& body : bodies) {
        double grown_in = 0.0, grown_out = 0.0, shrunk_in = 0.0, shrunk_out = 0.0;
        if (!convex_chord(moved(body, eps), o, d, grown_in, grown_out)) continue;  // missed by eps at least
        if (!convex_chord(moved(body, -eps), o, d, shrunk_in, shrunk_out)) return false;
        if (grown_out <= tmin) continue;  // behind the origin
        if (shrunk_out <= tmin) return false;
        const double slack = kRoundingsPerRay * kFloatUnit * grown_out;
        if (grown_in > tmin) surfaces.push_back({grown_in - slack, shrunk_in + slack, +1});
        else if (shrunk_in > -tmin) return false;  // the entry may be just ahead of the origin or behind it
        surfaces.push_back({shrunk_out - slack, grown_out + slack, -1});
    }
    return true;
}

// ---- Scenes ---------------------------------------------------------------------------------------------------

std::vector<Particle> random_box(std::uint64_t seed, std::size_t n, float half_x = 3.0f, float half_y = 2.0f,
                                 float half_z = 3.0f, float r_lo = 0.2f, float r_hi = 0.6f) {
    Pcg32 rng(seed);
    std::vector<Particle> ps;
    for (std::size_t i = 0; i < n; ++i)
        ps.push_back(particle({rng.uniform(-half_x, half_x), rng.uniform(-half_y, half_y), rng.uniform(-half_z, half_z)},
                              rng.uniform(r_lo, r_hi)));
    return ps;
}

// The float nearest to x, rounded to a multiple of 2^-6: exact after adding any integer below 2^17.
float dyadic(float x) { return std::round(x * 64.0f) / 64.0f; }

// Spacing of floats at magnitude m (the ulp of the largest coordinate).
double float_spacing(double m) {
    const float f = float(m);
    return double(std::nextafter(f, std::numeric_limits<float>::infinity())) - double(f);
}

std::string fixed(double v, int digits = 3) {
    std::ostringstream s;
    s << std::scientific << std::setprecision(digits) << v;
    return s.str();
}

const SixwayTexture& texture() {
    static const SixwayTexture t =
        load_sixway_texture(std::filesystem::path(SMOKETRACE_ASSET_DIR) / std::string(kSixwayLayoutFile));
    return t;
}

// Every pixel finite and in [0, bound].
void require_finite_image(const ImageRgba& img, float bound) {
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const glm::vec4 c = img.at(x, y);
            INFO("pixel (" << x << ", " << y << ") = " << c.x << " " << c.y << " " << c.z << " " << c.w);
            for (int k = 0; k < 4; ++k) {
                REQUIRE(std::isfinite(c[k]));
                REQUIRE(c[k] >= 0.0f);
                REQUIRE(c[k] <= bound);
            }
        }
}

// Lengths are finite and >= 0 where the status is ok, +inf (documented "fully dark") otherwise.
void require_documented_lengths(const OpticalPathLengths& d) {
    for (std::size_t i = 0; i < d.lengths().size(); ++i) {
        INFO("particle " << i << " l = " << d.lengths()[i]);
        if (d.status()[i] == DepthStatus::ok) {
            REQUIRE(std::isfinite(d.lengths()[i]));
            REQUIRE(d.lengths()[i] >= 0.0f);
        } else {
            REQUIRE(d.lengths()[i] == kFullyDarkPathLength);
        }
    }
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------------
// Far from the origin.
//
// Invariant 1 (exactness of the set-up): a scene whose float coordinates translate exactly (dyadic centres,
// radii and ground corners; T = 10^2 … 10^5 keeps them exact) gives BIT-IDENTICAL lengths, hit counts and
// statuses at every T. Why it must: each instance's object-space ray is W⁻¹·(o − c) with o and c floats
// subtracted in double (instance.hpp), which is exact and independent of T; the ground triangle test
// subtracts float vertices from the float origin, also exact here; world-space boxes are conservative. Any
// T-dependent rounding, or a box test that culls a hit at large coordinates, breaks bit equality.
//
// Invariant 2 (no error growth from the tracer): for a generic scene translated by T, where the float centres
// themselves round, the pass stays within the same tolerance of the exact answer FOR THE FLOAT SCENE IT WAS
// GIVEN as at the origin (exact_spheres' model, which depends on |o − c| and r only, never on T).
//
// Invariant 3 (the growth is the input's): against the exact answer of the UNTRANSLATED scene the error grows
// like the float spacing at T (ulp(10^5) = 2^-7 ≈ 0.0078): each centre was rounded by up to ulp/2 per
// coordinate when it was stored, so particle and origin move relative to each other by up to √3·ulp. The
// tolerance is the same model with that displacement added to eta. Nothing the tracer does could recover
// that: the positions the file can express are 2^-7 apart there. Keeping a scene near the origin (or storing
// positions relative to a local origin) is the cure, not more precision in the tracer.
TEST_CASE("stability: the same scene translated by 1e2 … 1e5", "[stability]") {
    const glm::vec3 to_light(0.3f, 1.0f, -0.2f);
    const double translations[] = {0.0, 1e2, 1e3, 1e4, 1e5};

    SECTION("dyadic scene: bit-identical results at every translation (spheres and icosahedra, with ground)") {
        std::vector<Particle> base = random_box(2024, 120);
        for (Particle& p : base) {
            p.center = {dyadic(p.center.x), dyadic(p.center.y), dyadic(p.center.z)};
            p.radius = dyadic(p.radius);
        }
        // An opaque roof over the left half: the rays of the particles below it are occluded.
        const std::array<glm::vec3, 4> roof{glm::vec3(-8, 3, 8), glm::vec3(0, 3, 8), glm::vec3(0, 3, -8), glm::vec3(-8, 3, -8)};
        for (const StandInShape shape : {kSphere, kIcosahedron}) {
            std::optional<Traced> origin;
            for (const double T : translations) {
                const glm::vec3 shift(static_cast<float>(T));
                std::vector<Particle> ps = base;
                for (Particle& p : ps) p.center += shift;  // exact: dyadic + integer < 2^17
                GroundQuad ground{roof};
                for (glm::vec3& c : ground.corners) c += shift;
                const Traced got = trace_all(ps, shape, to_light, ground);
                INFO("shape " << shape.name() << ", T = " << T);
                if (!origin) {
                    const auto occluded = std::count(got.status.begin(), got.status.end(), DepthStatus::occluded);
                    REQUIRE(occluded > 10);  // the roof takes part
                    REQUIRE(occluded < std::ptrdiff_t(ps.size()) - 10);
                    origin = got;
                    continue;
                }
                REQUIRE(got.status == origin->status);
                REQUIRE(got.hit_counts == origin->hit_counts);
                REQUIRE(std::memcmp(got.lengths.data(), origin->lengths.data(), got.lengths.size() * sizeof(float)) == 0);
            }
        }
    }

    SECTION("generic scene: error against the stored scene stays flat, against the original grows like ulp(T)") {
        const std::vector<Particle> original = random_box(77, 100);
        double max_coordinate = 0.0;
        for (const Particle& p : original)
            for (int a = 0; a < 3; ++a) max_coordinate = std::max(max_coordinate, std::abs(double(p.center[a])));
        std::ostringstream table;
        table << "translation T | float spacing at T | max |l - exact(stored scene)| | max |l - exact(original "
                 "scene)| | its tolerance (model)\n";
        for (const double T : translations) {
            std::vector<Particle> ps = original;
            for (Particle& p : ps) p.center = glm::vec3(glm::dvec3(p.center) + T);  // rounds once
            const Traced got = trace_all(ps, kSphere, to_light);
            INFO("T = " << T);
            const Errors stored = check_spheres(ps, got, to_light);
            // Each stored coordinate is within spacing/2 of c + T: the origin particle and each sphere move by
            // up to (√3/2)·spacing each, √3·spacing relative to each other.
            const double spacing = T == 0.0 ? 0.0 : float_spacing(T + max_coordinate);
            // The reference is the original scene seen from the original centre: the tracer's lengths must be
            // within the model's tolerance with that displacement added.
            const Errors against_original = check_spheres(ps, got, to_light, &original, std::sqrt(3.0) * spacing);
            table << std::setw(7) << T << " | " << fixed(spacing) << " | " << fixed(stored.max_abs) << " | "
                  << fixed(against_original.max_abs) << " | " << fixed(against_original.max_tolerance) << "\n";
        }
        WARN(table.str());
    }
}

// ---------------------------------------------------------------------------------------------------------------
// Tiny and huge particles, and mixed scales.
//
// Invariant: scaling a scene by s scales every length by s, with the relative tolerance of the model (it is
// homogeneous in lengths): max |l − exact| / s is the same for s = 10^-4 … 10^4. In one scene mixing radii
// 10^-4 … 10^4 every particle still matches the exact answer within the model, and a tiny particle far from
// the big ones keeps l = r to a few roundings RELATIVE TO r (object space makes every intersection local to
// its particle: nothing is computed at the scale of the biggest particle).
TEST_CASE("stability: radii from 1e-4 to 1e4 and mixed scales", "[stability]") {
    const glm::vec3 to_light(0.2f, 1.0f, 0.1f);
    std::ostringstream table;
    table << "scale s | max |l - exact| / s | its tolerance / s\n";
    const std::vector<Particle> unit = random_box(5, 80);
    for (const double s : {1e-4, 1e-2, 1.0, 1e2, 1e4}) {
        std::vector<Particle> ps = unit;
        for (Particle& p : ps) {
            p.center = glm::vec3(glm::dvec3(p.center) * s);
            p.radius = float(double(p.radius) * s);
        }
        INFO("scale " << s);
        const Traced got = trace_all(ps, kSphere, to_light);
        const Errors e = check_spheres(ps, got, to_light);
        table << std::setw(7) << s << " | " << fixed(e.max_abs / s) << " | " << fixed(e.max_tolerance / s) << "\n";
    }
    WARN(table.str());

    // One scene: a sphere of radius 10^4 holding clusters of radius ~1 and ~10^-4; outside it a sphere of
    // radius 10^2 and, far from everything, a lone particle of radius 10^-4.
    std::vector<Particle> mixed{particle({0, 0, 0}, 1e4f)};
    Pcg32 rng(99);
    for (int i = 0; i < 30; ++i)
        mixed.push_back(particle({rng.uniform(-20, 20), rng.uniform(-20, 20), rng.uniform(-20, 20)}, rng.uniform(0.5f, 2.0f)));
    for (int i = 0; i < 40; ++i)
        mixed.push_back(particle({1.0f + rng.uniform(-1e-3f, 1e-3f), 1.0f + rng.uniform(-1e-3f, 1e-3f), 1.0f + rng.uniform(-1e-3f, 1e-3f)},
                                 rng.uniform(1e-4f, 3e-4f)));
    mixed.push_back(particle({2e4f, 0, 0}, 1e2f));
    const std::size_t lone = mixed.size();
    mixed.push_back(particle({-3e4f, 5e3f, 7e3f}, 1e-4f));
    const Traced got = trace_all(mixed, kSphere, to_light);
    check_spheres(mixed, got, to_light);
    // The lone tiny particle: its own exit only, l = r within the pass's roundings relative to r.
    CHECK(got.hit_counts[lone] == 1);
    CHECK(std::abs(double(got.lengths[lone]) - double(mixed[lone].radius)) <= kRoundingsPerRay * kFloatUnit * mixed[lone].radius);
}

// ---------------------------------------------------------------------------------------------------------------
// Rays through shared edges and vertices.
//
// Invariant: particles lined up along the light, light along a coordinate axis. Every ray then runs exactly
// through the centres of the particles above it, which for the icosahedron means exactly through the midpoint
// of a shared edge (the axes cross the edges (±1, φ, 0)/n and their permutations) and for icospheres exactly
// through a vertex shared by 6 triangles (level >= 1 puts (0, ±1, 0) etc. on the mesh); the object-space
// rays are exact (dyadic centres, radius 1/2). Each particle is then entered exactly once and left exactly
// once — a leak would lose a surface, a duplicate add one — so the hit count, counter_start (particles
// covering the origin) and the lowest counter (>= 0) are exact integers, and the length is the exact union
// up to the float rounding of the hit t (<= u·t per endpoint; 4u·t_max with margin).
// Second part: the light along a vertex direction of the icosahedron ((0, 1, φ) normalised, rounded to
// float): the rays pass within float noise of shared vertices; the counts are still exact, and the lengths
// within 64u·t_max (the centres and the direction carry a few roundings each, and near a vertex a shift of
// the ray moves the crossing along faces inclined to it by up to ~2x).
TEST_CASE("stability: rays through shared edges and vertices of icosahedra and icospheres", "[stability]") {
    constexpr int n = 12;
    constexpr float r = 0.5f, spacing = 0.3125f;  // neighbours at 0.3125 cover a centre, at 0.625 do not
    const StandInShape shapes[] = {kIcosahedron, icosphere(1), icosphere(2), icosphere(3), icosphere(4)};

    auto check_line = [&](StandInShape shape, glm::dvec3 axis, double length_tolerance_units) {
        const TriangleMesh mesh = mesh_of(shape);
        std::vector<Particle> ps;
        for (int k = 0; k < n; ++k) ps.push_back(particle(glm::vec3(axis * (double(spacing) * k)), r));
        const glm::vec3 to_light(axis);
        const Traced got = trace_all(ps, shape, to_light);
        const glm::dvec3 d = glm::normalize(glm::dvec3(to_light));
        std::vector<std::vector<Plane>> bodies;
        for (const Particle& p : ps) bodies.push_back(planes_of(mesh, p));
        for (int k = 0; k < n; ++k) {
            const glm::dvec3 o(ps[k].center);
            int covering = 0;
            std::uint32_t surfaces = 0;
            std::vector<std::pair<double, double>> chords;
            double t_max = 0.0;
            for (int j = 0; j < n; ++j) {
                double t_in, t_out;
                if (!convex_chord(bodies[j], o, d, t_in, t_out) || t_out <= 0.0) continue;
                chords.emplace_back(t_in, t_out);
                t_max = std::max(t_max, t_out);
                if (t_in < 0.0) {
                    ++covering;
                    surfaces += 1;
                } else {
                    surfaces += 2;
                }
            }
            const double want = union_length(chords);
            const Walk w = walk(got.lists.of(std::size_t(k)));
            INFO("shape " << shape.name() << ", axis " << axis.x << " " << axis.y << " " << axis.z << ", particle " << k
                          << ": exact l = " << want << ", got " << got.lengths[k] << "; surfaces " << surfaces
                          << ", got " << got.hit_counts[k] << "; covering " << covering << ", counter_start " << w.start);
            REQUIRE(got.status[k] == DepthStatus::ok);
            REQUIRE(got.hit_counts[k] == surfaces);
            REQUIRE(w.start == covering);
            REQUIRE(w.lowest >= 0);
            const double tolerance = length_tolerance_units * kFloatUnit * t_max;
            REQUIRE(std::abs(double(got.lengths[k]) - want) <= tolerance);
            // Each hit is an endpoint of one of the exact chords, to the same tolerance as the length.
            std::vector<Surface> exact;
            for (const auto& [t_in, t_out] : chords) add_chord(exact, t_in, t_out, tolerance);
            const std::string problem = pairing_problem(got.lists.of(std::size_t(k)), exact);
            INFO(problem);
            REQUIRE(problem.empty());
        }
    };

    for (const StandInShape shape : shapes)
        for (const glm::dvec3 axis : {glm::dvec3(1, 0, 0), glm::dvec3(-1, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(0, -1, 0),
                                      glm::dvec3(0, 0, 1), glm::dvec3(0, 0, -1)})
            check_line(shape, axis, 4.0);

    // Along the icosahedron's vertex directions (rounded): near-vertex crossings for every shape.
    const double phi = (1.0 + std::sqrt(5.0)) / 2.0;
    for (const StandInShape shape : shapes)
        for (const glm::dvec3 v : {glm::dvec3(0, 1, phi), glm::dvec3(1, phi, 0), glm::dvec3(-phi, 0, 1)})
            check_line(shape, glm::normalize(v), 64.0);
}

// ---------------------------------------------------------------------------------------------------------------
// Grazing rays.
//
// (a) Tangent and near-tangent to spheres: a sphere of radius 1/2 whose centre lies p = r·(1 + ε) off the
//     ray, ε from −10^-2 to +10^-2 down to one float step, and exactly tangent. The object-space ray is exact
//     (dyadic origin, direction (0, 2, 0)), so the chord 2√(r² − p²) is computed from exact inputs: the length
//     is own exit + chord within 4u·t_far (two endpoints rounded to float), an exact tangent (p = r) is a
//     miss (a touch is not a crossing, ray_sphere.hpp), and the hits come in entry/exit pairs. Generic
//     near-tangent rays (oblique light, rounded object-space rays) are within exact_spheres' model, which
//     grows like √(r·eta) at tangency.
// (b) Parallel to triangle planes: a ray along +x running exactly along the top edge of an icosahedron (in
//     the plane of both faces that share it, touching the convex body only at that edge), and 10^-3 … 10^-7
//     below it (inside: a chord about as long as the edge, between the fans at its two ends, parallel to both
//     top faces) or above it (a miss). Off the edge the length matches the exact chord within 16u·t_far;
//     exactly on it the length is one of the two one-sided limits (no chord, or the whole edge: both are the
//     answer of an infinitesimally moved ray),
//     and the counter stays consistent (start 1, never below 0) and the hits pair up with the exact surfaces
//     (its own exit; particle 1 entered and left once, or not at all).
// (c) In the plane of the ground: particles at height h ∈ {0, 10^-6, 10^-3} above a ground quad, light
//     (1, θ, 0) with θ from −10^-2 to +10^-2 and exactly 0. The ground occludes exactly the rays that go
//     down from h > 0 and meet the quad (here: every θ < 0 whose hit point h/|θ| lies inside the quad); a ray
//     lying in the ground plane (h = 0, θ = 0) or parallel to it is never occluded (edge-on triangles do not
//     hit), and a ray starting on the ground (h = 0) does not see it (TMin > 0). Unoccluded lengths match the
//     exact spheres.
TEST_CASE("stability: grazing rays (tangent spheres, parallel to triangles, in the ground plane)", "[stability]") {
    const glm::vec3 up(0.0f, 1.0f, 0.0f);
    SECTION("(a) tangent and near-tangent to a sphere") {
        std::vector<double> eps{0.0};
        for (double e = 1e-2; e > 1e-8; e /= 10.0) {
            eps.push_back(e);
            eps.push_back(-e);
        }
        std::vector<float> offsets;
        for (const double e : eps) offsets.push_back(float(0.5 * (1.0 + e)));
        for (int k = 1; k <= 3; ++k) {  // one, two, three float steps either side of tangency (exact floats)
            offsets.push_back(0.5f - float(k) * 0x1p-25f);  // floats below 1/2 are 2^-25 apart
            offsets.push_back(0.5f + float(k) * 0x1p-24f);  // above, 2^-24
        }
        for (const float p : offsets) {
            const std::vector<Particle> ps{particle({0, 0, 0}, 0.5f), particle({p, 2.0f, 0.0f}, 0.5f)};
            const Traced got = trace_all(ps, kSphere, up);
            const double perp = p, s2 = 0.25 - perp * perp;
            const double chord = s2 > 0.0 ? 2.0 * std::sqrt(s2) : 0.0;
            const double t_far = 2.5;
            INFO("offset " << std::setprecision(9) << p << ": exact chord " << chord << ", l = " << got.lengths[0]);
            REQUIRE(got.status[0] == DepthStatus::ok);
            CHECK(std::abs(double(got.lengths[0]) - (0.5 + chord)) <= 4.0 * kFloatUnit * t_far);
            CHECK(got.hit_counts[0] == (s2 > 0.0 ? 3u : 1u));
            const Walk w = walk(got.lists.of(0));
            CHECK(w.start == 1);
            CHECK(w.lowest >= 0);
            // Its own exit at r, and the grazed sphere's entry and exit about its chord's midpoint t = 2.
            std::vector<Surface> exact;
            add_chord(exact, -0.5, 0.5, 4.0 * kFloatUnit * t_far);
            if (s2 > 0.0) add_chord(exact, 2.0 - 0.5 * chord, 2.0 + 0.5 * chord, 4.0 * kFloatUnit * t_far);
            const std::string problem = pairing_problem(got.lists.of(0), exact);
            INFO(problem);
            CHECK(problem.empty());
        }
        // Generic near-tangent rays: oblique light, random spheres placed 1 ± 10^-k radii off each ray.
        Pcg32 rng(8);
        const glm::vec3 oblique(0.37f, 1.0f, -0.23f);
        const glm::dvec3 d = glm::normalize(glm::dvec3(oblique));
        const glm::dvec3 side = glm::normalize(glm::cross(d, glm::dvec3(1, 0, 0)));
        std::vector<Particle> ps;
        for (int i = 0; i < 60; ++i) {
            const glm::dvec3 o(rng.uniform(-50, 50), rng.uniform(-50, 50), rng.uniform(-50, 50));
            const double radius = 0.5 + rng.uniform01();
            const double e = std::pow(10.0, -1.0 - 6.0 * rng.uniform01()) * (i % 2 ? 1.0 : -1.0);
            ps.push_back(particle(glm::vec3(o), 0.25f));
            ps.push_back(particle(glm::vec3(o + 3.0 * d + radius * (1.0 + e) * side), float(radius)));
        }
        const Traced generic = trace_all(ps, kSphere, oblique);
        check_spheres(ps, generic, oblique);
    }

    SECTION("(b) parallel to triangle planes: along an icosahedron's edge") {
        const TriangleMesh ico = make_icosahedron(1.0f);
        // The top edge: the two vertices (±a, b, 0), b the largest y of the mesh.
        float b = 0.0f, a = 0.0f;
        for (const glm::vec3& v : ico.vertices)
            if (v.y > b) {
                b = v.y;
                a = std::abs(v.x);
            }
        REQUIRE(a > 0.0f);
        const float r = 0.5f;
        const float top = b * r;  // exact: r is a power of two
        for (const float edge_above : {0.0f, 1e-3f, 1e-5f, 1e-7f, -1e-7f, -1e-5f}) {
            // Particle 0 at the origin, light +x; particle 1 ahead, its top edge `edge_above` above the ray.
            const std::vector<Particle> ps{particle({0, 0, 0}, r), particle({4.0f, edge_above - top, 0.0f}, r)};
            const Traced got = trace_all(ps, kIcosahedron, {1.0f, 0.0f, 0.0f});
            const glm::dvec3 o(0.0), d(1.0, 0.0, 0.0);
            double own_in = 0.0, own_out = 0.0, in = 0.0, out = 0.0;  // convex_chord() sets them (GCC 12 warns)
            REQUIRE(convex_chord(planes_of(ico, ps[0]), o, d, own_in, own_out));
            const bool crossed = convex_chord(planes_of(ico, ps[1]), o, d, in, out);
            const double chord = crossed ? out - in : 0.0;
            const Walk w = walk(got.lists.of(0));
            INFO("edge " << edge_above << " above the ray: exact chord " << chord << ", l = " << got.lengths[0] << ", hits "
                         << got.hit_counts[0]);
            REQUIRE(got.status[0] == DepthStatus::ok);
            CHECK(w.start == 1);
            CHECK(w.lowest >= 0);
            const double t_far = 4.0 + double(r);
            const double tolerance = 16.0 * kFloatUnit * t_far;
            std::vector<Surface> own;
            add_chord(own, own_in, own_out, tolerance);
            if (edge_above == 0.0f) {
                // Exactly along the edge: either one-sided limit, no hit on particle 1 or the whole edge.
                const double none = own_out, whole = own_out + 2.0 * double(a) * double(r);
                const double l = got.lengths[0];
                CHECK((std::abs(l - none) <= tolerance || std::abs(l - whole) <= tolerance));
                std::vector<Surface> along = own;
                add_chord(along, 4.0 - double(a) * double(r), 4.0 + double(a) * double(r), tolerance);
                const std::string beside = pairing_problem(got.lists.of(0), own);
                const std::string on = pairing_problem(got.lists.of(0), along);
                INFO("hits against no edge: " << beside << "; against the whole edge: " << on);
                CHECK((beside.empty() || on.empty()));
            } else {
                CHECK(std::abs(double(got.lengths[0]) - (own_out + chord)) <= tolerance);
                // Its own exit, and particle 1 entered and left once where the exact chord says (or not at all).
                if (crossed) add_chord(own, in, out, tolerance);
                const std::string problem = pairing_problem(got.lists.of(0), own);
                INFO(problem);
                CHECK(problem.empty());
            }
        }
    }

    SECTION("(c) in the plane of the ground") {
        const GroundQuad ground{{glm::vec3(-50, 0, 50), glm::vec3(50, 0, 50), glm::vec3(50, 0, -50), glm::vec3(-50, 0, -50)}};
        for (const float h : {0.0f, 1e-6f, 1e-3f}) {
            std::vector<Particle> ps;
            for (int k = 0; k < 10; ++k) ps.push_back(particle({-10.0f + 2.0f * float(k), h, 0.0f}, 0.5f));
            for (const float theta : {-1e-2f, -1e-4f, -1e-7f, 0.0f, 1e-7f, 1e-2f}) {
                const glm::vec3 to_light(1.0f, theta, 0.0f);
                const Traced got = trace_all(ps, kSphere, to_light, ground);
                for (std::size_t k = 0; k < ps.size(); ++k) {
                    // The ray meets the ground plane at x = x_k + h/|θ| when it goes down from h > 0.
                    const bool down = theta < 0.0f && h > 0.0f;
                    const double x_hit = double(ps[k].center.x) + double(h) / std::abs(double(theta));
                    const bool occluded = down && x_hit < 50.0;
                    INFO("h " << h << ", theta " << theta << ", particle " << k << ", ground hit at x " << x_hit);
                    REQUIRE(got.status[k] == (occluded ? DepthStatus::occluded : DepthStatus::ok));
                    if (occluded) REQUIRE(got.lengths[k] == kFullyDarkPathLength);
                }
                if (!(theta < 0.0f && h > 0.0f)) check_spheres(ps, got, to_light);
            }
        }
        // In the plane, along the quad's shared diagonal (corner 0 to corner 2): edge-on, never occluded.
        std::vector<Particle> diagonal;
        for (int k = 0; k < 8; ++k) diagonal.push_back(particle({-20.0f + 5.0f * float(k), 0.0f, 20.0f - 5.0f * float(k)}, 0.5f));
        const Traced got = trace_all(diagonal, kSphere, {1.0f, 0.0f, -1.0f}, ground);
        for (const DepthStatus s : got.status) CHECK(s == DepthStatus::ok);
    }
}

// ---------------------------------------------------------------------------------------------------------------
// Heavy overlap.
//
// Invariant: 400 particles all contain one point, the centre of particle 0 (centres within 0.1 of it, radii
// >= 0.5, inradius of the icosahedron 0.79·r > 0.1 + margin). Its ray starts inside all of them: exactly 400
// exits and no entry, counter_start = 400, and the length is the farthest exit (spheres: exact root; polyhedra:
// exact chord), within 16u·(t + |o − c| + r) / cos(angle to the exit face) (origin and direction rounded in
// object space, moved along the exit face's normal). Every other particle's ray: counter_start equals the
// number of stand-ins that contain its origin (points within 10^-6 of a surface excluded as ambiguous), the
// counter never drops below 0, and its hits pair up with the exact surfaces (convex_surfaces). With a cutoff
// of 100 every one of these rays is cut off (l = +inf).
TEST_CASE("stability: hundreds of particles covering one ray origin", "[stability]") {
    constexpr std::size_t n = 400;
    Pcg32 rng(31);
    std::vector<Particle> ps{particle({0, 0, 0}, 0.5f)};
    while (ps.size() < n) {
        const glm::vec3 c(rng.uniform(-0.1f, 0.1f), rng.uniform(-0.1f, 0.1f), rng.uniform(-0.1f, 0.1f));
        if (glm::length(c) > 0.1f) continue;
        ps.push_back(particle(c, rng.uniform(0.5f, 1.5f)));
    }
    const glm::vec3 to_light(-0.4f, 1.0f, 0.25f);
    const glm::dvec3 d = glm::normalize(glm::dvec3(to_light));

    const Traced spheres = trace_all(ps, kSphere, to_light);
    check_spheres(ps, spheres, to_light);
    CHECK(spheres.hit_counts[0] == n);
    CHECK(walk(spheres.lists.of(0)).start == int(n));

    for (const StandInShape shape : {kIcosahedron, icosphere(2)}) {
        const TriangleMesh mesh = mesh_of(shape);
        const Traced got = trace_all(ps, shape, to_light);
        std::vector<std::vector<Plane>> bodies;
        for (const Particle& p : ps) bodies.push_back(planes_of(mesh, p));
        std::size_t paired = 0;  // rays whose hits were paired with the exact surfaces
        for (std::size_t i = 0; i < n; ++i) {
            const glm::dvec3 o(ps[i].center);
            int covering = 0, ambiguous = 0;
            for (const auto& body : bodies) {
                const double m = inside_margin(body, o);
                if (std::abs(m) < 1e-6) ++ambiguous;
                else if (m > 0.0) ++covering;
            }
            const Walk w = walk(got.lists.of(i));
            INFO("shape " << shape.name() << ", particle " << i << ": covering " << covering << " (+" << ambiguous
                          << "), counter_start " << w.start);
            REQUIRE(got.status[i] == DepthStatus::ok);
            REQUIRE(w.start >= covering);
            REQUIRE(w.start <= covering + ambiguous);
            REQUIRE(w.lowest >= 0);
            std::vector<Surface> exact;
            if (ambiguous == 0 && convex_surfaces(bodies, o, d, double(optical_depth_tmin(ps[i].radius)), exact)) {
                const std::string problem = pairing_problem(got.lists.of(i), exact);
                INFO(problem);
                REQUIRE(problem.empty());
                ++paired;
            }
        }
        CHECK(2 * paired >= n);  // all 400 here: the pairing is not being skipped wholesale
        // Particle 0: exactly n exits, length = farthest exact exit.
        double farthest = 0.0, tolerance = 0.0;
        for (std::size_t j = 0; j < n; ++j) {
            double t_in, t_out;
            REQUIRE(convex_chord(bodies[j], glm::dvec3(0.0), d, t_in, t_out));
            REQUIRE(t_in < 0.0);
            if (t_out < farthest) continue;
            farthest = t_out;
            // The exit face: the plane giving t_out; its inclination to the ray scales the error.
            double cosine = 1.0;
            for (const Plane& f : bodies[j]) {
                const double denom = glm::dot(f.n, d);
                if (denom > 0.0 && std::abs((f.d - glm::dot(f.n, glm::dvec3(0.0))) / denom - t_out) < 1e-12)
                    cosine = std::min(cosine, denom / glm::length(f.n));
            }
            tolerance = 16.0 * kFloatUnit * (t_out + glm::length(glm::dvec3(ps[j].center)) + ps[j].radius) / cosine;
        }
        INFO("shape " << shape.name() << ": exact farthest exit " << farthest << ", l = " << got.lengths[0]);
        CHECK(got.hit_counts[0] == n);
        CHECK(walk(got.lists.of(0)).start == int(n));
        CHECK(std::abs(double(got.lengths[0]) - farthest) <= tolerance);

        const Traced cut = trace_all(ps, shape, to_light, {}, 100);
        for (std::size_t i = 0; i < n; ++i) {
            CHECK(cut.status[i] == DepthStatus::cutoff);
            CHECK(cut.lengths[i] == kFullyDarkPathLength);
        }
    }
}

// ---------------------------------------------------------------------------------------------------------------
// Coincident particles and coplanar billboards.
//
// (a) Invariant: 100 particles with identical centre and radius, and 50 more at the same centre with other
//     radii, plus a few particles above them. Identical particles have identical rays, so identical lengths
//     (bit for bit) and hit counts; their surfaces coincide, so the pass reports all of them at equal t and
//     the resolver's equal-t grouping must neither open a stretch between them nor drop one:
//     counter_start = 150, and l = the largest radius's exit + the particles above, as for one particle.
//     Tolerance: the sphere's exit t = r is computed from an exact object-space ray up to the light
//     direction's normalisation (<= 4 roundings) and one rounding of t: 8u·l.
// (b) Invariant: billboards at exactly equal depth (coincident particles: the same quad 30 times; a grid of
//     particles in one plane facing the camera) render without NaN or Inf in every mode, compositor and
//     compositing rule, every pixel in [0, bound], and the same bytes with 1 and 2 threads. Bound: every
//     layer colour is light map (<= 1) · light colour (1) · transmittance (<= 1) + ambient (0.05) <= 1.05, and
//     so are the ground and the sky; "over" is a convex combination of them (<= 1.05), the thesis's eq. 4.1
//     sums up to one term per layer (<= 1.05 per particle, plus the background). 1.1 per term leaves room
//     for float rounding. The two compositors may order equal-depth layers differently
//     (view_compositor.hpp), so they are not compared here.
TEST_CASE("stability: coincident particles and coplanar billboards at equal depth", "[stability]") {
    SECTION("(a) coincident stand-ins") {
        const glm::vec3 c(0.25f, -0.5f, 0.125f);
        std::vector<Particle> ps(100, particle(c, 0.5f));
        for (int i = 0; i < 50; ++i) ps.push_back(particle(c, 0.1f + 0.008f * float(i)));  // radii up to 0.492
        for (int i = 0; i < 5; ++i) ps.push_back(particle(c + glm::vec3(0.0f, 1.0f + float(i), 0.0f), 0.5f));
        const glm::vec3 to_light(0.0f, 1.0f, 0.0f);
        for (const StandInShape shape : {kSphere, kIcosahedron, icosphere(2)}) {
            const Traced got = trace_all(ps, shape, to_light);
            INFO("shape " << shape.name());
            for (std::size_t i = 1; i < 100; ++i) {
                REQUIRE(std::memcmp(&got.lengths[i], &got.lengths[0], sizeof(float)) == 0);
                REQUIRE(got.hit_counts[i] == got.hit_counts[0]);
            }
            const Walk w = walk(got.lists.of(0));
            CHECK(w.start == 150);
            CHECK(w.lowest >= 0);
            CHECK(got.hit_counts[0] == 150 + 2 * 5);
            // The exact union: spheres touch end to end (one stretch to 5.5); polyhedra leave gaps between the
            // edge midpoints (icosahedron) or vertices (icospheres) the axis passes through.
            double want = 0.0;
            if (shape.kind == StandInKind::sphere) {
                want = exact_spheres(ps, glm::dvec3(c), glm::dvec3(to_light)).length;
            } else {
                std::vector<std::pair<double, double>> chords;
                for (const Particle& p : ps) {
                    double t_in, t_out;
                    if (convex_chord(planes_of(mesh_of(shape), p), glm::dvec3(c), glm::dvec3(0, 1, 0), t_in, t_out))
                        chords.emplace_back(t_in, t_out);
                }
                want = union_length(chords);
            }
            CHECK(std::abs(double(got.lengths[0]) - want) <= 8.0 * kFloatUnit * 6.0);  // t <= 6: 8 roundings of it
        }
    }

    SECTION("(b) coplanar billboards: finite pixels in every mode, deterministic") {
        SceneDescription scene = parse_scene(R"({
            "light": { "direction": [0.3, 1, 0.2] },
            "smoke": { "particles": [], "sigma_t": 2.0, "alpha": 0.9 },
            "ground": { "corners": [[-3, -1, 3], [3, -1, 3], [3, -1, -3], [-3, -1, -3]] },
            "camera": { "position": [0, 0, 5], "look_at": [0, 0, 0], "width": 24, "height": 24 } })",
                                             "coplanar.json");
        for (int i = 0; i < 30; ++i) scene.smoke.particles.push_back(particle({0.0f, 0.0f, 0.0f}, 0.6f));  // one quad, 30x
        for (int y = -2; y <= 2; ++y)
            for (int x = -2; x <= 2; ++x)
                scene.smoke.particles.push_back(particle({0.4f * float(x), 0.4f * float(y), -0.5f}, 0.5f));
        for (const RenderMode mode : {RenderMode::basic, RenderMode::simple_shadow, RenderMode::full})
            for (const CompositorKind compositor :
                 {CompositorKind::tiled, CompositorKind::one_traversal, CompositorKind::retrace})
                for (const Compositing compositing : {Compositing::over, Compositing::thesis}) {
                    RenderOptions o = RenderOptions::from_scene(scene);
                    o.render.mode = mode;
                    o.render.compositing = compositing;
                    o.compositor = compositor;
                    INFO("mode " << to_string(mode) << ", compositing " << to_string(compositing) << ", compositor "
                                 << int(compositor));
                    Rgba8Image bytes[2];
                    for (int threads : {1, 2}) {
                        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
                        FrameRenderer renderer(scene, o, texture());
                        ImageRgba img;
                        renderer.render(0, img);
                        const float terms = compositing == Compositing::over ? 1.0f : float(scene.smoke.particles.size() + 1);
                        require_finite_image(img, 1.1f * terms);
                        require_documented_lengths(renderer.depths());
                        bytes[threads - 1] = to_srgb8(img);
                    }
                    CHECK(bytes[0].pixels == bytes[1].pixels);
                }
    }
}

// ---------------------------------------------------------------------------------------------------------------
// No NaN or Inf anywhere but the documented inf.
//
// Invariant: for scenes at the edges of what a scene file accepts (coordinates and radii at
// ±kMaxSceneCoordinate, radii at the smallest normal float, colours at kMaxSceneColor, σt 0 and huge, alpha
// 0 and 1, softness 0 and huge, threshold 0, a cutoff of 1, the camera inside a particle, the light grazing
// the ground, particles moving and growing to the limits over several frames, no particles at all), every
// optical path length is finite and >= 0 when its status is ok and exactly +inf (kFullyDarkPathLength,
// documented) otherwise, and every pixel of every mode is finite and >= 0. Bound on pixels: a colour is at most
// kMaxSceneColor per factor, and a pixel sums at most (layers + 1) terms of a product of two colours:
// 4·kMaxSceneColor² is finite with a wide margin, so the bound here is "finite".
TEST_CASE("stability: no NaN or Inf in any output except the documented inf", "[stability]") {
    const std::string ground = R"("ground": { "corners": [[-4, -1, 4], [4, -1, 4], [4, -1, -4], [-4, -1, -4]] })";
    const std::string two = R"("particles": [ { "center": [0, 0, 0], "radius": 0.5 }, { "center": [0.3, 0.8, 0], "radius": 0.7 } ])";
    const std::vector<std::pair<std::string, std::string>> scenes{
        {"huge coordinates", R"({ "light": { "direction": [1, 1, 0] }, "smoke": { "particles": [
            { "center": [1e15, -1e15, 1e15], "radius": 1e15 }, { "center": [-1e15, 1e15, -1e15], "radius": 1e15 },
            { "center": [0, 0, 0], "radius": 1e-3 } ] } })"},
        {"smallest radii", R"({ "light": { "direction": [0, 1, 0] }, "smoke": { "particles": [
            { "center": [0, 0, 0], "radius": 1.1754944e-38 }, { "center": [0, 1e-30, 0], "radius": 1.1754944e-38 },
            { "center": [0, 1, 0], "radius": 0.5 } ] },
            "camera": { "position": [0, 0, 3], "look_at": [0, 0, 0] } })"},
        {"brightest colours", R"({ "light": { "direction": [0, 1, 0], "color": [1e6, 1e6, 1e6] },
            "ambient": [1e6, 1e6, 1e6], "background": [1e6, 1e6, 1e6], "smoke": { )" + two + R"( },
            "ground": { "corners": [[-4, -1, 4], [4, -1, 4], [4, -1, -4], [-4, -1, -4]], "color": [1e6, 1e6, 1e6] } })"},
        {"sigma_t 0, alpha 1, hard particles, threshold 0", R"({ "light": { "direction": [0, 1, 0] },
            "smoke": { )" + two + R"(, "sigma_t": 0, "alpha": 1 }, )" + ground + R"(,
            "render": { "softness": 0, "transmittance_threshold": 0 } })"},
        {"huge sigma_t, alpha 0, huge softness, cutoff 1", R"({ "light": { "direction": [0, 1, 0] },
            "smoke": { )" + two + R"(, "sigma_t": 3e38, "alpha": 0 }, )" + ground + R"(,
            "render": { "softness": 3e38, "cutoff": 1 } })"},
        {"camera inside a particle", R"({ "light": { "direction": [0, 1, 0] }, "smoke": { )" + two + R"( }, )" + ground + R"(,
            "camera": { "position": [0, 0, 0.1], "look_at": [0, 0, -1] } })"},
        {"light grazing the ground", R"({ "light": { "direction": [1, 0, 0] }, "smoke": { "particles": [
            { "center": [0, -1, 0], "radius": 0.5 }, { "center": [2, -1, 0], "radius": 0.5 } ] }, )" + ground + R"( })"},
        {"light from below the ground", R"({ "light": { "direction": [0.2, -1, 0] }, "smoke": { )" + two + R"( }, )" + ground + R"( })"},
        {"moving and growing to the limits", R"({ "light": { "direction": [0, 1, 0] }, "smoke": { "particles": [
            { "center": [0, 0, 0], "radius": 0.5, "velocity": [3e14, 0, 0], "growth": 1e3, "spin": 3e38, "rotation": 3e38 },
            { "center": [0, 2, 0], "radius": 0.5, "growth": -0.999 } ] }, )" + ground + R"(,
            "camera": { "position": [0, 0, 10], "look_at": [0, 0, 0] }, "render": { "frames": 3 } })"},
        {"no particles", R"({ "light": { "direction": [0, 1, 0] }, "smoke": { "particles": [] }, )" + ground + R"( })"},
        {"no particles, no ground", R"({ "light": { "direction": [0, 1, 0] }, "smoke": { "particles": [] } })"},
    };
    for (const auto& [name, text] : scenes) {
        INFO("scene: " << name);
        const SceneDescription scene = parse_scene(text, name + ".json");
        for (const RenderMode mode : {RenderMode::basic, RenderMode::simple_shadow, RenderMode::full})
            for (const CompositorKind compositor :
                 {CompositorKind::tiled, CompositorKind::one_traversal, CompositorKind::retrace}) {
                INFO("mode " << to_string(mode) << ", compositor " << int(compositor));
                RenderOptions o = RenderOptions::from_scene(scene);
                o.width = o.height = 12;
                o.render.mode = mode;
                o.compositor = compositor;
                FrameRenderer renderer(scene, o, texture());
                ImageRgba img;
                for (std::uint32_t f = 0; f < o.render.frames; ++f) {
                    renderer.render(f, img);
                    require_finite_image(img, std::numeric_limits<float>::max());
                    require_documented_lengths(renderer.depths());
                }
            }
        // The optical-depth pass alone, with each stand-in shape.
        if (scene.smoke.particles.empty()) continue;
        std::optional<GroundQuad> g;
        if (scene.ground) g = GroundQuad{scene.ground->corners};
        for (const StandInShape shape : {kSphere, kIcosahedron, icosphere(1)}) {
            const Traced got = trace_all(scene.smoke.particles, shape, scene.light.direction, g, scene.render.cutoff);
            for (std::size_t i = 0; i < got.lengths.size(); ++i) {
                INFO("shape " << shape.name() << ", particle " << i << " l = " << got.lengths[i]);
                if (got.status[i] == DepthStatus::ok) REQUIRE((std::isfinite(got.lengths[i]) && got.lengths[i] >= 0.0f));
                else REQUIRE(got.lengths[i] == kFullyDarkPathLength);
            }
        }
    }
}
